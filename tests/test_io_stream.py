"""Long logs streamed in chunks: the same signals and estimates as reading the whole log, bounded buffers.

Truth is roadbank's whole-file path (``load_log`` + one ``run()``), itself tested
against hand-made files in test_io_readers.py; streaming must reproduce it
exactly whatever the chunk size, including channels at different rates with
jitter and a gap (the resampling rule) and an MDF4 file with one clock per channel.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from roadbank import estimators
from roadbank.io import LogError, load_log
from roadbank.io.stream import StreamResampler, stream_log
from roadbank.io.writers import TableWriter, write_table


def _concat(chunks, attr):
    return np.concatenate([getattr(c.signals, attr) for c in chunks])


def _assert_same(chunks, full):
    for k in ("t", "vx", "ay", "r", "delta_f"):
        np.testing.assert_array_equal(_concat(chunks, k), getattr(full.signals, k), err_msg=k)


@pytest.fixture(scope="module")
def sim_parquet(tmp_path_factory):
    from roadbank.sim import run_scenario
    res = run_scenario("track-lane1", seed=3)
    p = tmp_path_factory.mktemp("stream") / "run.parquet"
    write_table(p, res.table(), {"scenario": "track-lane1"})
    return p


@pytest.mark.parametrize("chunk", [2, 97, 1000, 10_000])
def test_parquet_table_clock_chunks_equal_whole(sim_parquet, chunk):
    full = load_log(sim_parquet)
    chunks = list(stream_log(sim_parquet, chunk_rows=chunk))
    assert max(len(c) for c in chunks) <= chunk                  # memory: one record batch at a time
    assert len(chunks) == -(-len(full) // chunk)
    _assert_same(chunks, full)
    np.testing.assert_array_equal(np.concatenate([c.truth["true_phi_b"] for c in chunks]),
                                  full.truth["true_phi_b"])
    assert chunks[0].metadata["scenario"] == "track-lane1"


def test_chunked_estimates_equal_one_run(sim_parquet):
    full = load_log(sim_parquet)
    for name in ("dfc", "uio"):            # (run(reset=False) for every estimator: test_streaming.py)
        est = estimators.make(name)
        whole = est.run(full.signals)
        parts = [est.run(c.signals, reset=(k == 0)) for k, c in enumerate(stream_log(sim_parquet, chunk_rows=211))]
        np.testing.assert_array_equal(np.concatenate([p.phi_b for p in parts]), whole.phi_b)
        np.testing.assert_array_equal(np.concatenate([p.valid for p in parts]), whole.valid)


def _mixed_rate_series(n=3000, seed=0):
    """ay, r at 100 Hz; speed at ~50 Hz with jitter; steering at 20 Hz with a 1.2 s gap."""
    rng = np.random.default_rng(seed)
    tf = 10.0 + np.arange(n) * 0.01
    ts = 10.003 + np.arange(n // 2) * 0.02 + rng.uniform(-0.003, 0.003, n // 2)
    tw = 10.0 + np.arange(n // 5) * 0.05
    tw = tw[(tw < 15.0) | (tw > 16.2)]
    return {"AccY": (tf, 0.5 * np.sin(tf) + 0.01 * rng.standard_normal(n)), "Gyro": (tf, 0.05 * np.cos(tf)),
            "VehSpd": (ts, 72.0 + ts), "SWA": (tw, 30.0 * np.sin(0.5 * tw))}


MAP = """
[channels]
time = {{ column = "t", unit = "s" }}
speed = {{ column = "VehSpd", unit = "km/h" }}
lateral_acceleration = {{ column = "AccY", unit = "m/s^2" }}
yaw_rate = {{ column = "Gyro", unit = "rad/s" }}
steering_wheel_angle = {{ column = "SWA", unit = "deg" }}
{extra}
"""


@pytest.mark.parametrize("chunk", [37, 500])
def test_mdf4_channels_on_own_clocks_equal_whole(tmp_path, chunk):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    series = _mixed_rate_series()
    mdf = MDF(version="4.10")
    mdf.append([Signal(series["AccY"][1], series["AccY"][0], name="AccY"),
                Signal(series["Gyro"][1], series["Gyro"][0], name="Gyro")])
    mdf.append([Signal(series["VehSpd"][1], series["VehSpd"][0], name="VehSpd")])
    mdf.append([Signal(series["SWA"][1], series["SWA"][0], name="SWA")])
    p = tmp_path / "mixed.mf4"
    mdf.save(p)
    (tmp_path / "m.toml").write_text(MAP.format(extra=""))
    full = load_log(p, channels=tmp_path / "m.toml")
    assert np.isnan(full.signals.delta_f).any()                  # the steering gap is NaN, not bridged
    chunks = list(stream_log(p, channels=tmp_path / "m.toml", chunk_rows=chunk))
    assert len(chunks) > 1
    _assert_same(chunks, full)


def test_parquet_mixed_rates_uniform_grid_equal_whole(tmp_path):
    series = _mixed_rate_series()
    t = np.unique(np.concatenate([s[0] for s in series.values()]))
    cols = {"t": t}
    for name, (ts, v) in series.items():        # one table, each channel only at its own rows
        col = np.full(len(t), np.nan)
        col[np.searchsorted(t, ts)] = v
        cols[name] = col
    p = tmp_path / "mixed.parquet"
    pq.write_table(pa.table(cols), p)
    (tmp_path / "m.toml").write_text(MAP.format(extra=""))
    full = load_log(p, channels=tmp_path / "m.toml")
    assert not np.array_equal(full.signals.t, t)              # resampled onto the 100 Hz grid
    for chunk in (50, 777):
        _assert_same(list(stream_log(p, channels=tmp_path / "m.toml", chunk_rows=chunk)), full)


def test_resampler_buffers_stay_bounded():
    n, chunk = 200_000, 1000
    rs = StreamResampler(["a", "b"], time_base="uniform", rate_hz=100.0)
    ta, tb = np.arange(n) * 0.01, 0.005 + np.arange(n // 2) * 0.02
    peak, emitted = 0, 0
    ib = 0
    for i in range(0, n, chunk):
        rs.add("a", ta[i:i + chunk], np.sin(ta[i:i + chunk]))
        while ib < len(tb) and tb[ib] <= ta[min(i + chunk, n) - 1] + 0.05:   # the slower channel lags/leads a bit
            j = min(ib + chunk // 2, len(tb))
            rs.add("b", tb[ib:j], np.cos(tb[ib:j]))
            ib = j
        out = rs.emit()
        emitted += 0 if out is None else len(out["t"])
        peak = max(peak, rs.buffered())
    rs.finish("a")
    rs.finish("b")
    out = rs.emit()
    emitted += 0 if out is None else len(out["t"])
    assert peak <= 4 * chunk                          # not growing with the log (200 000 samples)
    assert emitted == int(np.floor((tb[-1] - tb[0]) * 100 + 1e-9)) + 1


def test_errors_reach_the_caller_when_streamed(tmp_path, sim_parquet):
    cols = pq.read_table(sim_parquet).to_pydict()
    t = np.asarray(cols["t"])
    t[1100:1500] = t[1100]                    # the 3rd chunk stuck on one stamp: nothing to repair it with
    cols["t"] = t
    p = tmp_path / "back.parquet"
    pq.write_table(pa.table(cols), p)
    with pytest.raises(LogError, match=r"back\.parquet: channel 'time' \(column 't'\): no increasing time base: "
                                       r"\d+ of \d+ stamps missing, repeated or out of order \(rows 1000-1499\)"):
        list(stream_log(p, chunk_rows=500))


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_table_writer_appends_and_aborts(tmp_path, suffix):
    rng = np.random.default_rng(1)
    cols = {"t": np.arange(10.0), "x.phi_b": rng.standard_normal(10), "x.valid": rng.random(10) > 0.5}
    whole = tmp_path / f"whole{suffix}"
    write_table(whole, cols, {"source": "a"})
    parts = tmp_path / f"parts{suffix}"
    with TableWriter(parts, {"source": "a"}) as w:
        for i in range(0, 10, 3):
            w.write({k: v[i:i + 3] for k, v in cols.items()})
    if suffix == ".csv":
        assert parts.read_text() == whole.read_text()
    else:
        assert pq.read_table(parts).equals(pq.read_table(whole))
        assert pq.ParquetFile(parts).num_row_groups == 4
        assert pq.read_schema(parts).metadata[b"source"] == b"a"
    bad = tmp_path / f"bad{suffix}"
    with pytest.raises(RuntimeError):
        with TableWriter(bad) as w:
            w.write(cols)
            raise RuntimeError("interrupted")
    assert not bad.exists() and not list(tmp_path.glob("*.partial"))


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 1001])
def test_arrow_conversion_equals_pyarrow_array(n):
    # the writer's zero-copy conversion must give exactly what pa.array gives (bools bit-packed)
    import pyarrow as pa
    from roadbank.io.writers import _to_arrow

    rng = np.random.default_rng(n)
    for v in (rng.normal(size=n), rng.integers(-5, 5, n), rng.random(n) > 0.5, rng.normal(size=2 * n)[::2]):
        assert _to_arrow(v).equals(pa.array(v)), v.dtype


def test_pauses_are_left_out_of_the_uniform_grid():
    """A stretch longer than PAUSE_S with no sample of any channel is left out of the grid: the grid is the full
    grid's points outside it (counted analytically), built without the full grid's memory."""
    from roadbank.io.resample import PAUSE_S, grid_indices, pauses, uniform_grid
    a = np.concatenate([np.arange(0.0, 10.0, 0.01), 1e9 + np.arange(0.0, 5.0, 0.01)])
    b = np.concatenate([np.arange(0.0, 10.0, 0.1), [200.0], 1e9 + np.arange(0.0, 5.0, 0.1)])
    gaps = pauses([a, b])                            # 9.99 .. 200 and 200 .. 1e9: each longer than PAUSE_S
    assert gaps.shape == (2, 2) and np.all(np.diff(gaps, axis=1) > PAUSE_S)
    grid = uniform_grid(0.0, 1e9 + 4.99, 100.0, gaps)
    assert len(grid) == 1000 + 1 + 500               # 0 .. 9.99, the one sample at 200, 1e9 .. 1e9 + 4.99
    assert np.allclose(grid[-500:] - 1e9, np.arange(500) / 100.0, atol=1e-6)
    assert np.isclose(grid[1000], 200.0)
    assert len(pauses([a[:1000], b[:100]])) == 0     # no pause: the grid is the full one
    assert np.array_equal(grid_indices(0.0, 100.0, 3, 50), np.arange(3, 50))


def test_a_logger_pause_costs_no_rows(tmp_path):
    """A mixed-rate table (resampled onto a uniform grid) with a one-day pause: the log keeps its 2 x 20 s of rows,
    not a day of NaN rows, whole or streamed, and a warning names the file and the pause."""
    series = _mixed_rate_series()
    t = np.unique(np.concatenate([s[0] for s in series.values()]))
    cols = {"t": t}
    for name, (ts, v) in series.items():
        col = np.full(len(t), np.nan)
        col[np.searchsorted(t, ts)] = v
        cols[name] = col
    half = len(t) // 2
    cols["t"] = np.where(np.arange(len(t)) >= half, t + 86400.0, t)
    p = tmp_path / "paused.parquet"
    pq.write_table(pa.table(cols), p)
    (tmp_path / "m.toml").write_text(MAP.format(extra=""))
    full = load_log(p, channels=tmp_path / "m.toml")
    assert len(full.signals.t) < 1.05 * (t[-1] - t[0]) * 100
    assert np.max(np.diff(full.signals.t)) > 86000.0
    assert any("paused.parquet" in w and "no channel has a sample for 864" in w for w in full.warnings)
    for chunk in (50, 777):
        _assert_same(list(stream_log(p, channels=tmp_path / "m.toml", chunk_rows=chunk)), full)
