"""comma2k19 segments damaged in ways a logger or a copy damages them, built from the shared example segment:
each read is checked against the clean segment read as it is (or read without the part that is broken)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from roadbank.io import load_log
from roadbank.io.timebase import repair_time, stretch_order

SEGMENT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "comma2k19-example"
needs_data = pytest.mark.skipif(not SEGMENT.is_dir(), reason=f"comma2k19 example segment absent at {SEGMENT}")

IMU = ("processed_log/IMU/accelerometer", "processed_log/IMU/gyro")
STEERING = "processed_log/CAN/steering_angle"


def _copy(tmp_path: Path, name: str) -> Path:
    """A writable copy of the example segment."""
    seg = tmp_path / name
    shutil.copytree(SEGMENT, seg)
    for f in seg.rglob("*"):
        f.chmod(0o755 if f.is_dir() else 0o644)
    return seg


def _load(f: Path) -> np.ndarray:
    return np.load(f, allow_pickle=False)


def _save(f: Path, a: np.ndarray) -> None:
    with open(f, "wb") as fh:          # the segment's files have no .npy suffix
        np.save(fh, a)


def _same_log(got, want) -> None:
    """Two logs with the same samples: every signal, the reference roll and the positions, NaN where NaN."""
    for name in ("t", "vx", "ay", "r", "delta_f", "p", "ax", "q"):
        a, b = getattr(got.signals, name), getattr(want.signals, name)
        if b is None:
            assert a is None, name
            continue
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12, err_msg=name)
    if want.reference_roll is None:
        assert got.reference_roll is None
    else:
        np.testing.assert_allclose(got.reference_roll, want.reference_roll, rtol=0, atol=1e-12)
    assert set(got.extra) == set(want.extra)
    for k in want.extra:
        np.testing.assert_allclose(got.extra[k], want.extra[k], rtol=0, atol=1e-12, err_msg=k)


def test_only_stretches_that_fill_their_place_in_time_are_sorted():
    """A 100 Hz clock: blocks written backwards or two blocks exchanged are put back (the stamps come out as
    written before the damage); a swapped pair and a repeated stamp stay for the time-stamp repair (it flags them),
    and so does a clock that steps back 0.4 s (the stretches after and before it overlap in time: sorting would
    interleave them) or is reset to an earlier time (sorted, the later rows would stand 100 s apart, before the
    others); a row without a stamp stays behind the row before it."""
    t = np.arange(1000) * 0.01
    reversed_blocks = np.arange(1000)
    for b in range(3, 20, 8):
        reversed_blocks[b * 50:(b + 1) * 50] = reversed_blocks[b * 50:(b + 1) * 50][::-1]
    exchanged = np.r_[0:100, 150:200, 100:150, 200:1000]
    for order in (reversed_blocks, exchanged):
        got = stretch_order(t[order])
        assert got is not None and got[1] == np.count_nonzero(order != np.arange(1000))
        np.testing.assert_array_equal(t[order][got[0]], t)
    stepped, reset, swapped, repeated = t.copy(), t.copy(), t.copy(), t.copy()
    stepped[500:] -= 0.4
    reset[500:] -= 100.0
    swapped[[200, 201]] = swapped[[201, 200]]
    repeated[300] = repeated[299]
    for stamps in (t, stepped, reset, swapped, repeated):
        assert stretch_order(stamps) is None
    assert repair_time(stepped).restarts == (500,) and repair_time(reset).restarts == (500,)
    blank = t[reversed_blocks]
    blank[160] = np.nan                    # inside the first reversed block: t[189]'s row
    order, _ = stretch_order(blank)
    np.testing.assert_array_equal(order[np.isnan(blank[order])], [160])
    assert np.flatnonzero(np.isnan(blank[order]))[0] == 190      # after t[190]'s row, its row before in the file
    fin = blank[order][np.isfinite(blank[order])]
    np.testing.assert_array_equal(fin, np.delete(t, 189))


@needs_data
def test_imu_rows_written_in_reversed_blocks_are_sorted_back(tmp_path):
    """Every 8th block of 50 IMU rows written backwards in time (stamps and values together, accelerometer and
    gyro): the rows have distinct stamps and are merely out of place, so the reader sorts them and says so once per
    file. Before, the 750 rows of each file were dropped as out of order (r of the default's estimate with the pose
    roll 0.92 -> 0.58); now the log equals the clean segment's."""
    seg = _copy(tmp_path, "blocks")
    n = len(_load(SEGMENT / IMU[0] / "t"))
    order = np.arange(n)
    for b in range(7, n // 50, 8):
        order[b * 50:(b + 1) * 50] = order[b * 50:(b + 1) * 50][::-1]
    for rel in IMU:
        for name in ("t", "value"):
            _save(seg / rel / name, _load(SEGMENT / rel / name)[order])
    moved = int(np.count_nonzero(order != np.arange(n)))
    assert moved == 750

    log = load_log(seg)
    _same_log(log, load_log(SEGMENT))
    assert not any(log.time_repairs.values()), log.time_repairs      # nothing dropped or flagged
    for rel in IMU:
        said = [w for w in log.warnings if f"'{rel}'" in w]
        assert len(said) == 1, log.warnings
        assert f"{moved} of {n} rows out of time order" in said[0] and "sorted by time" in said[0]
    assert "channels 'yaw_rate', 'roll_rate', 'pitch_rate'" in next(w for w in log.warnings if IMU[1] in w)
