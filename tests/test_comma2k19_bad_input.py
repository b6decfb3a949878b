"""comma2k19 segments damaged in ways a logger or a copy damages them, built from the shared example segment:
each read is checked against the clean segment read as it is (or read without the part that is broken)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, load_log
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


def _same_signals(got, want) -> None:
    """Two logs with the same signals (every channel, NaN where NaN)."""
    for name in ("t", "vx", "ay", "r", "delta_f", "p", "ax", "q"):
        a, b = getattr(got.signals, name), getattr(want.signals, name)
        if b is None:
            assert a is None, name
            continue
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12, err_msg=name)


def _same_log(got, want) -> None:
    """Two logs with the same samples: every signal, the reference roll and the positions, NaN where NaN."""
    _same_signals(got, want)
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


def _no_steering(tmp_path: Path):
    seg = _copy(tmp_path, "no_steering")
    shutil.rmtree(seg / STEERING)
    return load_log(seg)


@needs_data
@pytest.mark.parametrize("damage, problem", [
    ("empty", "no samples (t and value are empty)"),
    ("short", "4974 time stamps (t) but 4964 values (value)"),
    ("cut", "comma2k19 file 'processed_log/CAN/steering_angle/value' is unreadable"),
    ("no_t", "comma2k19 file 'processed_log/CAN/steering_angle/t' is missing"),
    ("columns", "'processed_log/CAN/steering_angle/value': an array of shape (4974, 2), need (n,) or (n, 1)"),
    ("one_stamp", "no increasing time base"),
])
@needs_data
def test_a_broken_steering_file_is_read_as_a_missing_one(tmp_path, damage, problem):
    """The steering angle is optional: a segment without it is read (its delta_f NaN). One whose steering file is
    there but broken (empty, values fewer than the stamps, cut off, its t missing, two columns, every stamp the
    same) had refused the whole segment; now it is read as the segment without it, with a warning naming the file,
    the channel and the problem."""
    seg = _copy(tmp_path, damage)
    t, v = seg / STEERING / "t", seg / STEERING / "value"
    if damage == "empty":
        _save(t, np.zeros(0))
        _save(v, np.zeros(0))
    elif damage == "short":
        _save(v, _load(v)[:-10])
    elif damage == "cut":
        v.write_bytes(v.read_bytes()[:-100])
    elif damage == "no_t":
        t.unlink()
    elif damage == "columns":
        _save(v, np.stack([_load(v)] * 2, axis=1))
    else:
        _save(t, np.full(len(_load(t)), 46410.0))
    log = load_log(seg)
    _same_log(log, _no_steering(tmp_path))
    assert np.isnan(log.signals.delta_f).all()
    said = [w for w in log.warnings if STEERING in w]
    assert len(said) == 1 and problem in said[0] and "channel 'steering_wheel_angle'" in said[0], log.warnings
    assert "read without it" in said[0] and "steering angle is NaN" in said[0]


@needs_data
def test_a_broken_pose_is_read_as_a_missing_one(tmp_path):
    """The pose is the reference, not an input: positions cut off while written are read as a segment without the
    pose (no reference roll, no positions), saying which file and why; before, the segment was refused."""
    seg = _copy(tmp_path, "pose_cut")
    f = seg / "global_pose" / "frame_positions"
    f.write_bytes(f.read_bytes()[:-200])
    log = load_log(seg)
    no_pose = _copy(tmp_path, "no_pose")
    shutil.rmtree(no_pose / "global_pose")
    _same_log(log, load_log(no_pose))
    said = [w for w in log.warnings if "global_pose" in w]
    assert len(said) == 1 and "'global_pose/frame_positions' is unreadable" in said[0], log.warnings
    assert "read without the pose" in said[0] and "no reference roll" in said[0]


@needs_data
@pytest.mark.parametrize("rel, damage, channel", [
    ("processed_log/CAN/speed", "short", "channel 'speed'"),
    ("processed_log/IMU/gyro", "empty", "channels 'yaw_rate', 'roll_rate', 'pitch_rate'"),
    ("processed_log/IMU/accelerometer", "cut", "channels 'lateral_acceleration', 'longitudinal_acceleration'"),
])
@needs_data
def test_a_broken_required_file_refuses_the_segment_naming_it(tmp_path, rel, damage, channel):
    """The speed and the IMU are inputs: a broken one still refuses the segment, with an error naming the segment,
    the channels, the file and the problem, and on the command line no traceback."""
    seg = _copy(tmp_path, "seg")
    t, v = seg / rel / "t", seg / rel / "value"
    if damage == "short":
        _save(v, _load(v)[:-10])
        problem = "time stamps (t) but"
    elif damage == "empty":
        _save(t, np.zeros(0))
        _save(v, np.zeros((0, 3)))
        problem = "no samples"
    else:
        t.write_bytes(t.read_bytes()[:-100])
        problem = f"file '{rel}/t' is unreadable"
    with pytest.raises(LogError) as err:
        load_log(seg)
    text = str(err.value)
    assert text.startswith(f"{seg}: {channel}: comma2k19 ") and rel in text and problem in text, text
    res = CliRunner().invoke(main, ["estimate", str(seg), "-o", str(tmp_path / "x.csv")])
    assert res.exit_code != 0 and "Traceback" not in res.output and problem in res.output, res.output


@needs_data
def test_validate_reads_a_segment_with_a_broken_steering_file(tmp_path):
    """validate reads the steering's resolution for its data limits: a cut-off steering file (read by the reader as a
    missing one) had failed the segment there with numpy's message and no file named; now the segment is scored as
    the segment without its steering file."""
    from roadbank.validation.comma2k19 import validate_comma2k19

    seg = _copy(tmp_path, "cut")
    v = seg / STEERING / "value"
    v.write_bytes(v.read_bytes()[:-100])
    no_steer = _copy(tmp_path, "no_steering")
    shutil.rmtree(no_steer / STEERING)
    got = validate_comma2k19(seg, names=["kinematic"], sensitivity=False)
    want = validate_comma2k19(no_steer, names=["kinematic"], sensitivity=False)
    assert got.scores["kinematic"] == want.scores["kinematic"]
    assert np.isfinite(got.scores["kinematic"].r) and np.isnan(got.data["steer_quantum_deg"])


@needs_data
def test_a_clock_that_steps_back_keeps_the_longer_stretch_and_names_what_is_dropped(tmp_path):
    """Every IMU stamp from row 3000 on 0.4 s earlier (the clock stepped back once and ran on): the rows after the
    step overlap those before it in time, so sorting would interleave two parts of the drive. The longer stretch
    (rows 3000-6255, 32.6 s) is kept, the other dropped, and each IMU channel's warning names its file, the step,
    the rows and seconds kept and those dropped. The log equals the segment whose IMU files hold only the rows
    after the first kept one (the first is flagged not valid: the sample after a dropped one)."""
    stepped, kept = _copy(tmp_path, "stepped"), _copy(tmp_path, "kept")
    for rel in IMU:
        t = _load(SEGMENT / rel / "t")
        t[3000:] -= 0.4
        _save(stepped / rel / "t", t)
        _save(kept / rel / "t", t[3001:])
        _save(kept / rel / "value", _load(SEGMENT / rel / "value")[3001:])
    log = load_log(stepped)
    _same_log(log, load_log(kept))
    t = _load(stepped / IMU[1] / "t")
    dropped = f"the rest dropped: sample 0 to sample 2999 ({t[0]:.3f} to {t[2999]:.3f} s)"
    for role, column in (("lateral_acceleration", "processed_log/IMU/accelerometer[1]"),
                         ("yaw_rate", "processed_log/IMU/gyro[2]"), ("roll_rate", "processed_log/IMU/gyro[0]")):
        said = [w for w in log.warnings if f"channel '{role}' (column '{column}')" in w]
        assert len(said) == 1, log.warnings
        assert f"clock restarts at sample 3000 (from {t[2999]:.3f} s back to {t[3000]:.3f} s)" in said[0]
        assert f"only the longest is kept: sample 3000 to sample 6255 ({t[3000]:.3f} to {t[-1]:.3f} s)" in said[0]
        assert dropped in said[0]
    assert not any("sorted by time" in w for w in log.warnings)


def _pose_cut(seg: Path, keep) -> float:
    """The segment's pose frames where ``keep(frame_times)``; the last frame's time (s)."""
    ft = _load(seg / "global_pose" / "frame_times")
    kept = keep(ft)
    for f in (seg / "global_pose").iterdir():
        a = _load(f)
        if len(a) == len(ft):
            _save(f, a[kept])
    return float(ft[kept][-1])


@needs_data
def test_a_pose_that_ends_early_leaves_the_log_its_inputs_span(tmp_path):
    """The last 20 s of pose frames gone: the log had been cut to the pose's 40 s without a word. The reference is no
    input: the log now spans the inputs (the uniform 100 Hz grid from the latest first to the earliest last stamp of
    the speed, IMU and steering files), with the clean segment's signals, its reference the clean one's up to the
    pose's last frame and NaN after, and a warning saying so. roadbank estimate writes the whole span; validate
    scores the stretch the pose covers, as it scores a segment whose inputs end there too."""
    seg = _copy(tmp_path, "pose_short")
    last = _pose_cut(seg, lambda ft: ft < ft[0] + 40.0)
    log, clean = load_log(seg), load_log(SEGMENT)
    firsts, lasts = zip(*((_load(SEGMENT / rel / "t")[[0, -1]]) for rel in (*IMU, "processed_log/CAN/speed", STEERING)))
    grid = max(firsts) + np.arange(int(np.floor((min(lasts) - max(firsts)) * 100 + 1e-9)) + 1) / 100
    np.testing.assert_allclose(log.signals.t, grid, rtol=0, atol=1e-9)
    _same_signals(log, clean)
    covered = log.signals.t <= last
    assert 0.66 < covered.mean() < 0.67
    for got, want in ((log.reference_roll, clean.reference_roll), (log.extra["lat_deg"], clean.extra["lat_deg"]),
                      (log.extra["lon_deg"], clean.extra["lon_deg"])):
        np.testing.assert_array_equal(got[covered], want[covered])
        assert np.isnan(got[~covered]).all()
    said = [w for w in log.warnings if "reference_roll" in w]
    assert len(said) == 1 and f"covers {grid[0]:.3f} to {log.signals.t[covered][-1]:.3f} s of the log's " \
        f"{grid[0]:.3f} to {grid[-1]:.3f} s: the reference roll is NaN for the 20.03 s after it" in said[0], said

    out = tmp_path / "estimate.csv"
    res = CliRunner().invoke(main, ["estimate", str(seg), "-o", str(out)])
    assert res.exit_code == 0, res.output
    table = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_allclose(table["t"], log.signals.t, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(np.isnan(table["reference_roll"]), ~covered)

    from roadbank.validation.comma2k19 import validate_comma2k19
    ends = _copy(tmp_path, "inputs_end_there")        # the same segment with every input cut 0.05 s after the pose
    _pose_cut(ends, lambda ft: ft < ft[0] + 40.0)
    for rel in (*IMU, "processed_log/CAN/speed", STEERING):
        t = _load(ends / rel / "t")
        for name in ("t", "value"):
            _save(ends / rel / name, _load(ends / rel / name)[t < last + 0.05])
    got = validate_comma2k19(seg, names=["kinematic", "kinematic-pif"], sensitivity=False)
    want = validate_comma2k19(ends, names=["kinematic", "kinematic-pif"], sensitivity=False)
    assert got.t[-1] <= last and np.array_equal(got.t, want.t)
    for name in ("kinematic", "kinematic-pif"):
        assert got.scores[name] == want.scores[name] and np.isfinite(got.scores[name].r), name


@needs_data
def test_repair_counts_are_given_channel_by_channel(tmp_path):
    """Three speed stamps written twice and one gyro pair swapped: Log.time_repairs adds the counts of every channel
    (the gyro's pair counts once for each of its three channels); time_repairs_by_channel, the command line's summary
    and its --json say which channel had what (before: '3 duplicate stamps dropped, 3 swapped pairs reordered; 9
    sample(s) flagged not valid', the speed's and the gyro's added up)."""
    seg = _copy(tmp_path, "seg")
    t = _load(seg / "processed_log/CAN/speed/t")
    t[[100, 200, 300]] = t[[99, 199, 299]]
    _save(seg / "processed_log/CAN/speed/t", t)
    t = _load(seg / IMU[1] / "t")
    t[[2000, 2001]] = t[[2001, 2000]]
    _save(seg / IMU[1] / "t", t)
    log = load_log(seg)
    by = {ch: {k: v for k, v in c.items() if v} for ch, c in log.time_repairs_by_channel.items()}
    gyro = {"swapped": 1, "flagged": 2}
    assert by == {"speed": {"duplicate": 3, "flagged": 3}, "yaw_rate": gyro, "roll_rate": gyro, "pitch_rate": gyro,
                  "lateral_acceleration": {}, "longitudinal_acceleration": {}, "steering_wheel_angle": {},
                  "reference_roll": {}}
    assert {k: v for k, v in log.time_repairs.items() if v} == {"duplicate": 3, "swapped": 3, "flagged": 9}

    res = CliRunner().invoke(main, ["estimate", str(seg), "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == 0, res.output
    assert ("time stamps repaired in seg: speed: 3 duplicate stamps dropped, 3 sample(s) flagged not valid; each of "
            "yaw_rate, roll_rate, pitch_rate: 1 swapped pair reordered, 2 sample(s) flagged not valid") in res.output
    res = CliRunner().invoke(main, ["estimate", str(seg), "-o", str(tmp_path / "x.csv"), "--json"])
    doc = json.loads(res.stdout)["logs"][0]
    assert doc["time_repairs_by_channel"] == {k: v for k, v in by.items() if v}


@needs_data
def test_the_optional_files_stamps_are_repaired_and_counted_once(tmp_path):
    """The steering angle and the pose are optional: their stamps are first tried for a time base (a file whose stamps
    cannot be repaired is read as missing), which only checks them; the assembler's repair is the one that counts.
    Three steering stamps written twice and a pair swapped, one pose stamp written twice and a pair swapped: each
    counted once, in time_repairs_by_channel, the sums and the warnings, the stamps as in the file."""
    seg = _copy(tmp_path, "seg")
    f = seg / STEERING / "t"
    t = _load(f)
    t[[100, 200, 300]] = t[[99, 199, 299]]
    t[[500, 501]] = t[[501, 500]]
    _save(f, t)
    f = seg / "global_pose/frame_times"
    t = _load(f)
    t[50] = t[49]
    t[[80, 81]] = t[[81, 80]]
    _save(f, t)
    log = load_log(seg)
    by = {ch: {k: v for k, v in c.items() if v} for ch, c in log.time_repairs_by_channel.items()}
    assert by["steering_wheel_angle"] == {"duplicate": 3, "swapped": 1, "flagged": 5}      # 3 firsts + the pair
    assert by["reference_roll"] == {"duplicate": 1, "swapped": 1, "flagged": 3}
    assert {k: v for k, v in log.time_repairs.items() if v} == {"duplicate": 4, "swapped": 2, "flagged": 8}
    said = [w for w in log.warnings if "time stamps repaired" in w]
    assert len(said) == 2 and any("3 duplicate stamps dropped, 1 swapped pair" in w for w in said), said
