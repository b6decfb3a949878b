"""Odd inputs to ``roadbank map``, ``export c`` and the log reader (odd-input sweep 3).

Truths: the map of the good log alone (a log without a GNSS fix must add nothing and must not move the
origin); the same log with its no-fix samples blanked by hand (a 0, 0 sample is a missing fix); the
same log without a steering column (a steering column without a value reads as one without steering);
the range the help text states for ``export c --rate``.
"""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank import estimators
from roadbank.cli import main
from roadbank.export.design import RATE_RANGE_HZ, export_design
from roadbank.io import LogError, load_log
from roadbank.io.assemble import concat_logs
from roadbank.io.stream import stream_log
from roadbank.mapping import LocalProjection, map_logs

RATE = 20.0                   # Hz
ORIGIN = LocalProjection(48.123, 11.456)
MAP = """
[channels]
time = { column = "t", unit = "s" }
speed = { column = "vx", unit = "m/s" }
lateral_acceleration = { column = "ay", unit = "m/s^2" }
yaw_rate = { column = "r", unit = "rad/s" }
latitude = { column = "latitude", unit = "deg" }
longitude = { column = "longitude", unit = "deg" }
"""


def _drive(seconds: float = 90.0, seed: int = 3) -> dict:
    """A winding drive at 15 m/s with consistent ay = vx r (ISO, SI), a 2 deg bank, sensor noise and its
    GNSS track (deg) about :data:`ORIGIN`."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / RATE)
    vx = 15.0 + 0.5 * np.sin(2 * np.pi * t / 40.0)
    r = 0.08 * np.sin(2 * np.pi * t / 25.0)
    psi = np.cumsum(r) / RATE
    east, north = np.cumsum(vx * np.sin(psi)) / RATE, np.cumsum(vx * np.cos(psi)) / RATE
    lat, lon = ORIGIN.to_latlon(east, north)
    ay = vx * r - 9.81 * math.sin(math.radians(2.0)) + rng.normal(0.0, 0.05, len(t))
    return {"t": t, "vx": vx + rng.normal(0.0, 0.02, len(t)), "ay": ay, "r": r + rng.normal(0.0, 0.002, len(t)),
            "delta_f": 0.05 * r, "latitude": lat, "longitude": lon}


def _csv(path, cols: dict):
    names = list(cols)
    rows = np.column_stack([np.asarray(cols[c], dtype=np.float64) for c in names])
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in rows:
            f.write(",".join("" if not np.isfinite(v) else repr(float(v)) for v in row) + "\n")
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """good.csv, allnan.csv (latitude column empty), zero.csv (every position 0, 0), late.csv (0, 0 until
    the receiver's first fix at 10 s), late_nan.csv (the same with those positions blank), ll.toml."""
    d = tmp_path_factory.mktemp("maplogs")
    cols = {k: v for k, v in _drive().items() if k != "delta_f"}
    _csv(d / "good.csv", cols)
    _csv(d / "allnan.csv", {**cols, "latitude": np.full(len(cols["t"]), np.nan)})
    zeros = np.zeros(len(cols["t"]))
    _csv(d / "zero.csv", {**cols, "latitude": zeros, "longitude": zeros})
    late = cols["t"] < 10.0
    _csv(d / "late.csv", {**cols, "latitude": np.where(late, 0.0, cols["latitude"]),
                          "longitude": np.where(late, 0.0, cols["longitude"])})
    _csv(d / "late_nan.csv", {**cols, "latitude": np.where(late, np.nan, cols["latitude"]),
                              "longitude": np.where(late, np.nan, cols["longitude"])})
    (d / "ll.toml").write_text(MAP)
    return d


def _same_map(a, b):
    assert a.projection == b.projection and a.cell_m == b.cell_m
    ta, tb = a.table(), b.table()
    assert list(ta) == list(tb)
    for k in ta:
        np.testing.assert_array_equal(np.asarray(ta[k]), np.asarray(tb[k]), err_msg=k)


def test_logs_without_a_fix_are_not_mapped_and_leave_the_map_and_its_origin_alone(logs):
    """The no-fix logs come first: before, the 0, 0 log set the origin (0, 0) and both counted as mapped."""
    kw = {"channels": logs / "ll.toml", "estimator": "kinematic"}
    alone, (rec,) = map_logs([logs / "good.csv"], **kw)
    assert rec.status == "ok" and rec.mapped > 500
    bmap, recs = map_logs([logs / "zero.csv", logs / "allnan.csv", logs / "good.csv"], **kw)
    assert [r.status for r in recs] == ["error", "error", "ok"]
    assert str(logs / "zero.csv") in recs[0].error and "0, 0" in recs[0].error and "no GNSS fix" in recs[0].error
    assert "'latitude' (column 'latitude')" in recs[0].error and "not mapped" in recs[0].error
    assert (recs[1].error.startswith(f"{logs / 'allnan.csv'}: channel 'latitude' (column 'latitude')")
            and "all missing" in recs[1].error and "longitude" not in recs[1].error)
    assert recs[0].mapped == recs[1].mapped == 0 and recs[2].mapped == rec.mapped
    _same_map(bmap, alone)
    assert bmap.projection == LocalProjection(48.12, 11.46)     # the good log's first fix, rounded


def test_a_zero_zero_sample_is_a_missing_fix_and_never_the_origin(logs):
    """A receiver logs 0, 0 until its first fix: those samples are mapped as blank positions are."""
    kw = {"channels": logs / "ll.toml", "estimator": "kinematic"}
    late, (rec,) = map_logs([logs / "late.csv"], **kw)
    blank, (want,) = map_logs([logs / "late_nan.csv"], **kw)
    assert rec.status == want.status == "ok" and rec.mapped == want.mapped > 300
    _same_map(late, blank)
    assert late.projection == LocalProjection(48.12, 11.46)


def test_map_cli_names_the_unmapped_log_and_fails_when_none_is_usable(logs, tmp_path):
    runner = CliRunner()
    out = tmp_path / "m.parquet"
    res = runner.invoke(main, ["map", str(logs / "good.csv"), str(logs / "allnan.csv"), "--channels",
                               str(logs / "ll.toml"), "-e", "kinematic", "-o", str(out)])
    assert res.exit_code == 1, res.output            # one log not mapped
    assert f"{logs / 'allnan.csv'}: channel 'latitude' (column 'latitude')" in res.stderr
    assert "of 1 log(s)" in res.stdout and out.is_file()
    alone, _ = map_logs([logs / "good.csv"], channels=logs / "ll.toml", estimator="kinematic")
    got = pq.read_table(out)
    np.testing.assert_array_equal(got["count"].to_numpy(), np.asarray(alone.table()["count"]))

    none = tmp_path / "none.parquet"
    res = runner.invoke(main, ["map", str(logs / "zero.csv"), str(logs / "allnan.csv"), "--channels",
                               str(logs / "ll.toml"), "-e", "kinematic", "-o", str(none)])
    assert res.exit_code == 1 and not none.exists()
    assert "no log could be mapped (2 not mapped" in res.stderr and "no GNSS fix" in res.stderr


def test_a_log_given_twice_is_mapped_once(logs, tmp_path):
    """The same log by its name and through a link to it: mapped once, saying so (before: every cell counted its
    samples twice, "of 2 log(s)"); the map is the log's alone."""
    link = tmp_path / "again.csv"
    link.symlink_to(logs / "good.csv")
    out = tmp_path / "m.parquet"
    res = CliRunner().invoke(main, ["map", str(logs / "good.csv"), str(link), "--channels", str(logs / "ll.toml"),
                                    "-e", "kinematic", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "given again (the same log): read once" in res.stderr and "of 1 log(s)" in res.stdout
    alone, _ = map_logs([logs / "good.csv"], channels=logs / "ll.toml", estimator="kinematic")
    np.testing.assert_array_equal(pq.read_table(out)["count"].to_numpy(), np.asarray(alone.table()["count"]))


def test_map_names_a_missing_path(tmp_path):
    """Before: 'cannot tell the format from the suffix ''' for a folder name that does not exist. No path given
    exists: a usage error (exit code 2), as for estimate and identify (tests/test_cli_inputs_missing.py)."""
    res = CliRunner().invoke(main, ["map", str(tmp_path / "no_such_drive"), "-o", str(tmp_path / "m.parquet")])
    assert res.exit_code == 2
    assert f"{tmp_path / 'no_such_drive'}: not found" in res.stderr and "suffix" not in res.stderr


def _steer_logs(d):
    """nansteer.csv (a delta_f column without a value), nosteer.csv (no delta_f column), their Parquet twins."""
    cols = {k: v for k, v in _drive(60.0).items() if k not in ("latitude", "longitude")}
    n = len(cols["t"])
    _csv(d / "nansteer.csv", {**cols, "delta_f": np.full(n, np.nan)})
    _csv(d / "nosteer.csv", {k: v for k, v in cols.items() if k != "delta_f"})
    pq.write_table(pa.table({**cols, "delta_f": np.full(n, np.nan)}), d / "nansteer.parquet")
    pq.write_table(pa.table({k: v for k, v in cols.items() if k != "delta_f"}), d / "nosteer.parquet")


def _same_signals(a, b):
    for k in ("t", "vx", "ay", "r", "delta_f"):
        np.testing.assert_array_equal(getattr(a.signals, k), getattr(b.signals, k), err_msg=k)


def test_a_steering_column_without_a_value_reads_as_a_log_without_steering(tmp_path):
    """Before: 'channel road_wheel_angle (column delta_f): no finite values', and every command failed."""
    _steer_logs(tmp_path)
    nan, none = load_log(tmp_path / "nansteer.csv"), load_log(tmp_path / "nosteer.csv")
    _same_signals(nan, none)
    assert np.isnan(nan.signals.delta_f).all()
    assert [w for w in nan.warnings if f"{tmp_path / 'nansteer.csv'}: channel 'road_wheel_angle' (column "
            "'delta_f'): no finite values, so the steering angle is NaN" in w]
    # streamed in chunks (the time base decided on the whole log first) as read whole, and as without steering
    whole = load_log(tmp_path / "nosteer.parquet")
    streamed = concat_logs(list(stream_log(tmp_path / "nansteer.parquet", chunk_rows=150)))
    _same_signals(streamed, whole)
    _same_signals(load_log(tmp_path / "nansteer.parquet"), whole)
    # a map naming the column (steering not optional) reads it the same way
    steer = tmp_path / "steer.toml"
    steer.write_text(MAP.split("latitude")[0] + 'road_wheel_angle = { column = "delta_f", unit = "rad" }\n')
    _same_signals(load_log(tmp_path / "nansteer.csv", channels=steer), none)
    # the estimators: the default does not read the steering angle, dfc gives no valid sample
    assert np.array_equal(estimators.make("kinematic").run(nan.signals).phi_b,
                          estimators.make("kinematic").run(none.signals).phi_b, equal_nan=True)
    assert not estimators.make("dfc").run(nan.signals).valid.any()


def test_only_the_steering_angle_may_be_without_a_value(tmp_path):
    cols = {k: v for k, v in _drive(20.0).items() if k not in ("latitude", "longitude")}
    _csv(tmp_path / "nanr.csv", {**cols, "r": np.full(len(cols["t"]), np.nan)})
    with pytest.raises(LogError, match=r"nanr.csv: channel 'yaw_rate' \(column 'r'\): no finite values"):
        load_log(tmp_path / "nanr.csv")
    _csv(tmp_path / "nansteer.csv", {**cols, "delta_f": np.full(len(cols["t"]), np.nan)})
    base = tmp_path / "base.toml"     # the time base cannot be a channel without a value
    base.write_text('[resample]\ntime_base = "road_wheel_angle"\n' + MAP.split("latitude")[0]
                    + 'road_wheel_angle = { column = "delta_f", unit = "rad" }\n')
    with pytest.raises(LogError, match=r"channel 'road_wheel_angle' \(column 'delta_f'\): no finite values"):
        load_log(tmp_path / "nansteer.csv", channels=base)


def test_estimate_and_export_read_a_log_whose_steering_is_empty(tmp_path):
    _steer_logs(tmp_path)
    runner = CliRunner()
    log = str(tmp_path / "nansteer.csv")
    res = runner.invoke(main, ["estimate", log, "-e", "kinematic", "-o", str(tmp_path / "e.csv")])
    assert res.exit_code == 0, res.output
    assert "channel 'road_wheel_angle' (column 'delta_f'): no finite values" in res.stderr
    for name in ("nansteer", "nosteer"):     # designed for the log as for the one without a steering column
        res = runner.invoke(main, ["export", "c", "-e", "kinematic", "--log", str(tmp_path / f"{name}.csv"),
                                   "-o", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
    c = [(tmp_path / name / "roadbank_kinematic.c").read_text() for name in ("nansteer", "nosteer")]
    assert c[0] == c[1]


@pytest.mark.parametrize("rate", ["1e9", "0.5", "0", "-100", "nan", "inf", "10001"])
def test_export_c_refuses_an_implausible_rate(rate, tmp_path):
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic", "--rate", rate, "-o", str(tmp_path / "c")])
    assert res.exit_code == 2 and "--rate" in res.output and "must be 1 to 10000 Hz" in res.output
    assert not (tmp_path / "c").exists()


def test_export_rate_range_is_the_one_the_help_states(tmp_path):
    res = CliRunner().invoke(main, ["export", "c", "--help"])
    assert "1 to 10000" in " ".join(res.output.split())
    assert RATE_RANGE_HZ == (1.0, 10_000.0)
    est = estimators.make("kinematic")
    for bad in (0.99, 10_000.5, 1e9):
        with pytest.raises(ValueError, match="rate must be 1 to 10000 Hz"):
            export_design(est, bad)
    assert export_design(est, 1.0).rate == 1.0
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic", "--rate", "1", "-o", str(tmp_path / "c")])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("option", [["--channels", "car.toml"], ["--format", "csv"]])
def test_export_c_refuses_log_options_without_a_log(option, tmp_path):
    """Before: --channels without --log was ignored without a word."""
    (tmp_path / "car.toml").write_text(MAP)
    opt = [option[0], str(tmp_path / option[1]) if option[1].endswith(".toml") else option[1]]
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic", *opt, "-o", str(tmp_path / "c")])
    assert res.exit_code == 2 and f"{option[0]} describes --log, which is not given" in res.output
    assert not (tmp_path / "c").exists()


def test_a_log_far_from_the_maps_origin_is_warned_about(logs, tmp_path):
    """The same drive moved 1.5 deg of latitude (about 167 km) north, after the drive at the origin: mapped, with a
    warning naming it and its distance (its flat cells are distorted beyond 50 km); the drive at the origin gets
    none. Before: mapped without a word."""
    cols = {k: v for k, v in _drive().items() if k != "delta_f"}
    far = _csv(tmp_path / "far.csv", {**cols, "latitude": cols["latitude"] + 1.5})
    bmap, recs = map_logs([logs / "good.csv", far], channels=logs / "ll.toml", estimator="kinematic")
    assert [r.status for r in recs] == ["ok", "ok"] and recs[1].mapped > 500
    assert not [w for w in recs[0].warnings if "from the map's origin" in w]
    said = [w for w in recs[1].warnings if "from the map's origin" in w]
    assert said and said[0].startswith(f"{far}: positions up to 16") and "beyond 50 km" in said[0], recs[1].warnings


def test_positions_in_radians_declared_degrees_are_refused(logs, tmp_path):
    """The drive's latitude and longitude written in radians under a map that says degrees: each position is
    plausible (0.84 deg, 0.2 deg), but they move about 1/57 as far as the speed drives: refused naming the channels
    and the ratio (before: mapped as a few cells near 0.84 N, 0.2 E). The drive in degrees moves as far as it drives."""
    import math

    from roadbank.mapping.geo import TrackScale

    cols = {k: v for k, v in _drive().items() if k != "delta_f"}
    rad = _csv(tmp_path / "rad.csv", {**cols, "latitude": np.radians(cols["latitude"]),
                                      "longitude": np.radians(cols["longitude"])})
    _, (rec,) = map_logs([rad], channels=logs / "ll.toml", estimator="kinematic")
    assert rec.status == "error" and "channels 'latitude' (column 'latitude') and 'longitude'" in rec.error
    assert "times as far as the speed drives" in rec.error and "not degrees?" in rec.error, rec.error
    good = TrackScale()
    good.add(cols["t"], cols["latitude"], cols["longitude"], cols["vx"])
    assert good.driven > 200.0 and math.isclose(good.moved / good.driven, 1.0, rel_tol=0.05)


def test_a_log_that_mostly_did_not_settle_says_so(logs):
    """Only settled estimates are mapped: where fewer than half of a log's valid ones settled, the log says how many
    and the estimator's settling time (KITTI drive 0070 with the map's default: 154 of 415, 26.9 s: the map kept 129
    samples of a 43 s drive without a word before); the kinematic estimate settles at once and says nothing."""
    from pathlib import Path

    _, (rec,) = map_logs([logs / "good.csv"], channels=logs / "ll.toml", estimator="kinematic")
    assert rec.status == "ok" and not [w for w in rec.warnings if "had settled" in w]
    drive = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
    if not drive.is_dir():
        pytest.skip("../shared/data/kitti-oxts not present")
    _, (rec,) = map_logs([drive])
    said = [w for w in rec.warnings if "had settled" in w]
    assert said and "of its" in said[0] and "settles 26.9 s after each (re)start" in said[0], rec.warnings
