"""Time-stamp repair: one rule (io.timebase.repair_time) in load_log, the Parquet / MDF4 streams and
``roadbank estimate``.

Truth: hand-made stamp series whose repair is known sample by sample, and a simulated log whose
stamps are damaged in known places (the repaired log must be the original minus the dropped
samples, with the flagged ones NaN).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, load_log
from roadbank.io.stream import stream_log
from roadbank.io.timebase import UnrepairableTime, repair_time
from roadbank.io.writers import write_table

SIG = ("t", "vx", "ay", "r", "delta_f")


@pytest.mark.parametrize("t, kept, flagged, counts", [
    ([0, 1, 2, 3, 4, 5], [0, 1, 2, 3, 4, 5], [], {}),
    ([0, 1, 2, 2, 3, 4], [0, 1, 2, 4, 5], [2], {"duplicate": 1}),                  # first of the two kept
    ([0, 1, 3, 2, 4, 5], [0, 1, 3, 2, 4, 5], [2, 3], {"swapped": 1}),             # reordered
    ([0, 1, 2, 99, 4, 5], [0, 1, 2, 4, 5], [4], {"out_of_order": 1}),             # isolated high stamp
    ([0, 1, 2, -5, 4, 5], [0, 1, 2, 4, 5], [4], {"out_of_order": 1}),             # isolated low stamp
    ([99, 1, 2, 3, 4], [1, 2, 3, 4], [1], {"out_of_order": 1}),                   # bad first stamp
    ([0, 1, 2, 3, 4, 1], [0, 1, 2, 3, 4], [], {"out_of_order": 1}),               # bad last stamp
    ([0, 1, 2, 3, 4, 2.5, 2.6, 2.7, 5, 6, 7, 8],                                   # a backwards jump:
     [0, 1, 2, 5, 6, 7, 8, 9, 10, 11], [5], {"out_of_order": 2}),                  # the fewest dropped
    ([0, 1, np.nan, 3, 4], [0, 1, 3, 4], [3], {"missing": 1}),
    ([0, 1, 2, 3, 10, 11, 12, 13], list(range(8)), [], {"gaps": 1}),              # forward jump kept
])
def test_repair_rule(t, kept, flagged, counts):
    rep = repair_time(t)
    np.testing.assert_array_equal(rep.keep, kept)
    assert np.asarray(t, float)[rep.keep].tolist() == sorted(np.asarray(t, float)[rep.keep].tolist())
    assert sorted(rep.keep[rep.flagged].tolist()) == flagged
    assert {k: v for k, v in rep.counts.items() if v} == counts


def test_repair_after_previous_chunk():
    # the stamps of a chunk are repaired after the last good stamp of the chunk before
    rep = repair_time([3.0, 3.5, 2.0, 4.0], after=3.0)
    np.testing.assert_array_equal(rep.keep, [1, 3])
    assert rep.counts["duplicate"] == 1 and rep.counts["out_of_order"] == 1


@pytest.mark.parametrize("t, why", [([1.0] * 5, "all 5 stamps equal"),
                                    ([5, 4, 3, 2, 1, 0], "only 1 of 6 stamps in increasing order"),
                                    ([0, 1, 2, 1, 0, -1, -2, -3], "5 of 8 stamps missing, repeated or out of order"),
                                    # every other stamp missing: each kept sample follows one and is not trusted
                                    ([0, np.nan, 2, np.nan, 4, np.nan], r"3 of 6 stamps missing \(not numbers\); "
                                     "the samples next to them are not trusted, which leaves 1 of 6 usable")])
def test_unrepairable(t, why):
    with pytest.raises(UnrepairableTime, match=why):
        repair_time(t)


def test_long_clean_log_is_fast_path():
    t = np.arange(2_000_000) * 0.01
    rep = repair_time(t)
    assert not rep.changed and len(rep.keep) == len(t)


# ------------------------------------------------------------------ a damaged simulated log

#: rows damaged, and what the repair must do (rows of the original table)
DUP, SWAP, SWAP2, HIGH, LOW, GAP = 103, 407, 249, 700, 999, 900


@pytest.fixture(scope="module")
def damaged(tmp_path_factory):
    """(original table, damaged table, rows dropped, rows flagged, counts): the damage lands on
    the boundaries of 250-row chunks (rows 499/500, 999/1000) and inside them."""
    from roadbank.sim import run_scenario
    tab = {k: np.asarray(v, dtype=np.float64) for k, v in run_scenario("track-lane1", seed=3).table().items()}
    n = len(tab["t"])
    assert n > 1100
    bad = {k: v.copy() for k, v in tab.items()}
    t = bad["t"]
    t[DUP] = t[DUP - 1]                              # a duplicated stamp: row DUP dropped, DUP-1 flagged
    t[SWAP], t[SWAP + 1] = t[SWAP + 1], t[SWAP]      # swapped stamps: rows reordered, both flagged
    t[SWAP2], t[SWAP2 + 1] = t[SWAP2 + 1], t[SWAP2]  # the same across a chunk boundary (249 | 250)
    t[499] = t[499] + 7.0                            # isolated high stamp at a chunk's end: dropped
    t[HIGH] = t[HIGH] + 3.0                          # isolated high stamp inside a chunk
    t[LOW] = t[LOW] - 4.0                            # isolated low stamp at a chunk's end
    t[1000] = np.nan                                 # a missing stamp starting a chunk
    t[GAP:] += 2.0                                   # the logger paused 2 s: a gap, kept
    dropped = [DUP, 499, HIGH, LOW, 1000]
    flagged = [DUP - 1, SWAP2, SWAP2 + 1, SWAP, SWAP + 1, 500, HIGH + 1, 1001]  # 1001: after the low and missing
    counts = {"missing": 1, "duplicate": 1, "swapped": 2, "out_of_order": 3, "gaps": 1, "flagged": len(flagged)}
    d = tmp_path_factory.mktemp("damaged")
    write_table(d / "bad.csv", bad)
    write_table(d / "bad.parquet", bad)
    return tab, bad, dropped, flagged, counts, d


def _expected(tab, bad, dropped, flagged):
    """The repaired log by hand: rows in time order (the swapped pair back in place), dropped rows
    gone, the flagged rows NaN; times as the (damaged) file gives them."""
    order = [i for i in range(len(tab["t"])) if i not in dropped]
    for sw in (SWAP, SWAP2):
        i = order.index(sw)
        order[i], order[i + 1] = sw + 1, sw
    out = {"t": bad["t"][order]}
    for k in ("vx", "ay", "r", "delta_f"):
        v = tab[k].copy()
        v[flagged] = np.nan
        out[k] = v[order]
    return out


def test_load_log_repairs_as_by_hand(damaged):
    tab, bad, dropped, flagged, counts, d = damaged
    exp = _expected(tab, bad, dropped, flagged)
    log = load_log(d / "bad.csv")
    for k in SIG:
        np.testing.assert_array_equal(getattr(log.signals, k), exp[k], err_msg=k)
    assert log.time_repairs == counts
    assert any("time stamps repaired" in w and "(first at line 104)" in w for w in log.warnings), log.warnings


@pytest.mark.parametrize("chunk", [250, 333, 5000])
def test_stream_repairs_like_load_log(damaged, chunk):
    tab, bad, dropped, flagged, counts, d = damaged
    whole = load_log(d / "bad.csv")
    chunks = list(stream_log(d / "bad.parquet", chunk_rows=chunk))
    assert len(chunks) > (1 if chunk < 5000 else 0)
    for k in SIG:
        np.testing.assert_array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                      getattr(whole.signals, k), err_msg=k)
    total = {}
    for c in chunks:
        for kind, v in c.time_repairs.items():
            total[kind] = total.get(kind, 0) + v
    assert total == counts
    # the CSV goes through load_log when streamed: the same again
    csv_chunks = list(stream_log(d / "bad.csv", chunk_rows=chunk))
    np.testing.assert_array_equal(np.concatenate([c.signals.t for c in csv_chunks]), whole.signals.t)


def test_mdf4_channel_clock_repaired_whole_and_streamed(tmp_path):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal
    n = 2000
    t = np.arange(n) * 0.01
    tb = t.copy()
    tb[600], tb[601] = tb[601], tb[600]         # swapped pair in the speed channel's own clock
    tb[1299] = tb[1298]                         # duplicate at a 100-sample window's end
    rng = np.random.default_rng(1)
    mdf = MDF(version="4.10")
    mdf.append([Signal(0.5 * np.sin(t) + 0.01 * rng.standard_normal(n), t, name="AccY"),
                Signal(0.05 * np.cos(t), t, name="Gyro"), Signal(np.zeros(n), t, name="SWA")])
    mdf.append([Signal(72.0 + t, tb, name="VehSpd")])
    p = tmp_path / "m.mf4"
    mdf.save(p)
    (tmp_path / "m.toml").write_text(
        '[channels]\ntime = { column = "t", unit = "s" }\nspeed = { column = "VehSpd", unit = "km/h" }\n'
        'lateral_acceleration = { column = "AccY", unit = "m/s^2" }\n'
        'yaw_rate = { column = "Gyro", unit = "rad/s" }\nsteering_wheel_angle = { column = "SWA", unit = "deg" }\n')
    full = load_log(p, channels=tmp_path / "m.toml")
    assert full.time_repairs["swapped"] == 1 and full.time_repairs["duplicate"] == 1
    chunks = list(stream_log(p, channels=tmp_path / "m.toml", chunk_rows=100))
    assert len(chunks) > 1
    for k in SIG:
        np.testing.assert_array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                      getattr(full.signals, k), err_msg=k)
    total = {}
    for c in chunks:
        for kind, v in c.time_repairs.items():
            total[kind] = total.get(kind, 0) + v
    assert total == full.time_repairs


# ------------------------------------------------------------------ the command line

def test_cli_estimate_repairs_flags_and_counts(damaged, tmp_path):
    tab, bad, dropped, flagged, counts, d = damaged
    out = tmp_path / "o.csv"
    res = CliRunner().invoke(main, ["estimate", str(d / "bad.csv"), "-e", "kinematic", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "time stamps repaired in bad.csv: 1 missing stamp dropped, 1 duplicate stamp dropped, " \
           "2 swapped pairs reordered, 3 out-of-order stamps dropped, 1 gap kept; 8 sample(s) flagged not valid" \
           in res.output, res.output
    got = np.genfromtxt(out, delimiter=",", names=True)
    exp = _expected(tab, bad, dropped, flagged)
    np.testing.assert_array_equal(got["t"], exp["t"])
    flagged_rows = np.isnan(exp["r"])
    assert flagged_rows.sum() == len(flagged)
    assert not got["kinematicvalid"][flagged_rows].any()           # flagged samples: not valid
    assert got["kinematicvalid"][~flagged_rows].mean() > 0.5        # the rest is estimated

    res = CliRunner().invoke(main, ["estimate", str(d / "bad.csv"), "-e", "kinematic", "-o", str(out), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["logs"][0]["time_repairs"] == counts and doc["failed"] == 0


def test_cli_estimate_unrepairable_time_one_line(tmp_path):
    t = np.full(50, 3.0)
    z = np.zeros(50)
    write_table(tmp_path / "stuck.csv", {"t": t, "vx": z + 20, "ay": z, "r": z, "delta_f": z})
    res = CliRunner().invoke(main, ["estimate", str(tmp_path / "stuck.csv"), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 1
    line = [x for x in res.output.splitlines() if x.startswith("FAILED")]
    assert len(line) == 1 and "stuck.csv: channel 'time' (column 't'): no increasing time base: all 50 stamps " \
                               "equal" in line[0], res.output
    assert "Traceback" not in res.output


def test_load_log_refuses_what_cannot_be_repaired(tmp_path):
    z = np.zeros(40)
    write_table(tmp_path / "back.csv", {"t": -np.arange(40) * 0.01, "vx": z + 20, "ay": z, "r": z, "delta_f": z})
    with pytest.raises(LogError, match=r"back\.csv: channel 'time' \(column 't'\): no increasing time base"):
        load_log(tmp_path / "back.csv")


def test_a_log_left_without_usable_samples_says_why(tmp_path):
    """Every other stamp missing: no usable sample is left, and the one line says so about the time channel
    (it used to read: channels do not overlap: 'speed' starts at 0.000 s but 'speed' ends at 0.000 s). A speed
    channel with a single finite value is named as such."""
    n = 400
    t, z = np.arange(n) * 0.01, np.zeros(n)
    write_table(tmp_path / "half.csv", {"t": np.where(np.arange(n) % 2, np.nan, t), "vx": z + 20, "ay": z, "r": z,
                                        "delta_f": z})
    write_table(tmp_path / "one.csv", {"t": t, "vx": np.where(np.arange(n) == 7, 20.0, np.nan), "ay": z, "r": z,
                                       "delta_f": z})
    res = CliRunner().invoke(main, ["estimate", str(tmp_path / "half.csv"), str(tmp_path / "one.csv"),
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code == 1 and "Traceback" not in res.output
    lines = sorted(x for x in res.output.splitlines() if x.startswith("FAILED"))
    assert len(lines) == 2, res.output
    assert "half.csv: channel 'time' (column 't'): no increasing time base: 200 of 400 stamps missing" in lines[0]
    assert "which leaves 1 of 400 usable" in lines[0]
    assert "one.csv: channel 'speed': a single valid (finite) sample, at 0.070 s" in lines[1], lines[1]
