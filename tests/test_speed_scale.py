"""A speed in mph or km/h declared m/s is read by the channels that measure the car's motion without it: a roll rate
(the roll in ``ay - vx r``) or a longitudinal acceleration (the speed's change). ``ay`` and ``vx r`` alone cannot
tell such a speed from a banked road, so before this a KITTI drive written to CSV with its speed in mph read as m/s
gave a 5 deg error in silence."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank import Signals
from roadbank.cli import main
from roadbank.constants import G
from roadbank.io import LogError, check_consistency, load_log
from roadbank.io.consistency import SCALE_SPAN_S, speed_scale_error, speed_scales
from roadbank.io.stream import stream_log
from roadbank.sim import run_scenario
from roadbank.sim.sensors import ChannelErrorModel, SensorConfig

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
KITTI_DRIVES = sorted(p for p in DATA.glob("kitti-oxts*/20*") if p.is_dir())
MPH = 1 / 0.44704
UNITS = [(1.0, None), (MPH, "mph"), (3.6, "km/h")]


def _refused_unit(signals) -> str | None:
    """The unit :func:`check_consistency` names for the speed from its scale check, None where it says nothing of it."""
    try:
        speed_scale_error(speed_scales(signals.t, signals.vx, signals.ay, signals.r, signals.p, signals.ax))
    except LogError as exc:
        return str(exc).split("speed looks like ")[1].split(" declared")[0]
    return None


def _scaled(s, factor, p=True, ax=True) -> Signals:
    """``s`` with its speed times ``factor``, its roll rate and ax as a channel map's (not documented by the format)."""
    return Signals(s.t, s.vx * factor, s.ay, s.r, s.delta_f, p=s.p if p else None, ax=s.ax if ax else None)


def _synthetic(duration: float, rate: float = 100.0):
    """``(t, vx, ay, r, p, ax)`` of a car whose ``ay`` is ``vx r + g sin(phi)`` (no sideslip), with the roll and bank
    ``phi`` the integral of its roll rate ``p`` and ``ax`` the derivative of its speed, on a road whose bank carries
    half of each turn (as a banked curve's does)."""
    t = np.arange(0.0, duration, 1.0 / rate)
    vx = 20.0 + 4.0 * np.sin(2 * np.pi * t / 23.0)
    r = 0.08 * np.sin(2 * np.pi * t / 17.0) + 0.03 * np.sin(2 * np.pi * t / 7.0)
    phi = -0.5 * vx * r / G + 0.01 * np.sin(2 * np.pi * t / 5.0)      # a bank carrying half the turn, body roll
    return t, vx, vx * r + G * np.sin(phi), r, np.gradient(phi, t), np.gradient(vx, t)


def test_the_scale_of_a_synthetic_log_is_read_exactly():
    """Analytic (:func:`_synthetic`): each reading gives the factor the speed was scaled by (to 1 %), on a road whose
    bank follows the turns and would fool ``ay`` on ``vx r``."""
    t, vx, ay, r, p, ax = _synthetic(200.0)
    for factor in (1.0, MPH, 3.6):
        got = speed_scales(t, vx * factor, ay, r, p, ax)
        assert set(got) == {"roll_rate", "longitudinal_acceleration"}, got
        assert got["roll_rate"] == pytest.approx(factor, rel=0.01)
        assert got["longitudinal_acceleration"] == pytest.approx(factor, rel=0.01)
    # ay on vx r alone reads the bank as a scale: about 0.5 here, what a speed in mph declared m/s gives (0.45)
    assert (ay @ (vx * r)) / ((vx * r) @ (vx * r)) == pytest.approx(0.5, abs=0.05)


@pytest.mark.skipif(len(KITTI_DRIVES) < 16, reason="the 16 KITTI drives of ../shared/data/kitti-oxts* not present")
@pytest.mark.parametrize("factor, unit", UNITS)
def test_every_kitti_drive_is_read_in_its_unit(factor, unit):
    """The 16 KITTI drives (their INS's roll rate and ax in the place of a channel map's): as recorded no speed unit is
    named, by either channel or both; with the speed in mph or km/h declared m/s, the roll rate names the unit on every
    drive, ax on those where it follows the speed closely (14 of 16), and the two together never name another."""
    from roadbank.io.kitti import load_kitti_oxts

    named = [0, 0, 0]           # drives on which the roll rate alone, both, ax alone name the unit
    for drive in KITTI_DRIVES:
        s = load_kitti_oxts(drive).signals
        readings = [_refused_unit(_scaled(s, factor, **kw)) for kw in ({"ax": False}, {}, {"p": False})]
        assert all(x in (unit, None) for x in readings), (drive.name, readings)     # never another unit
        named = [n + (x == unit) for n, x in zip(named, readings)]
    # the 16 shared drives: the roll rate names the unit on all 16, ax on 14 (a drive added to the folder may turn
    # too little to be read: the counts are of the 16)
    everyone = len(KITTI_DRIVES)
    assert named[0] >= (16 if unit else everyone) and named[1] >= (16 if unit else everyone)
    assert named[2] >= (14 if unit else everyone)


@pytest.mark.skipif(not KITTI_DRIVES, reason="../shared/data/kitti-oxts* not present")
def test_a_roll_rate_channel_that_is_not_one_names_no_unit():
    """A pitch rate or the yaw rate mapped as the roll rate (the speed right): it does not follow the roll in ``ay``
    and reads nothing, or reads the speed as it is; never a unit."""
    from roadbank.io.kitti import load_kitti_oxts

    for drive in KITTI_DRIVES:
        s = load_kitti_oxts(drive).signals
        for wrong in (s.q, s.r, -s.p):
            assert _refused_unit(Signals(s.t, s.vx, s.ay, s.r, s.delta_f, p=wrong)) is None, drive.name


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bank-lane-change", "track-lane-change"])
def test_banked_tracks_read_their_speed_as_it_is(name):
    """The paper's banked lanes (10-30 deg) with a roll-rate gyro: ``ay`` is 0.3-0.4 times ``vx r`` there, as a speed
    in mph would give, but the roll rate carries the bank: the speed reads 1.00 (+-3 %) and nothing is named; in mph
    declared m/s it reads 2.24 and mph is named."""
    sim = run_scenario(name, sensors=SensorConfig(roll_rate=ChannelErrorModel(noise_std=0.002)))
    s = sim.signals
    assert speed_scales(s.t, s.vx, s.ay, s.r, s.p)["roll_rate"] == pytest.approx(1.0, abs=0.03)
    assert _refused_unit(s) is None
    assert speed_scales(s.t, s.vx * MPH, s.ay, s.r, s.p)["roll_rate"] == pytest.approx(MPH, rel=0.03)
    assert _refused_unit(_scaled(s, MPH, ax=False)) == "mph"
    check_consistency(s)                # no LogError: the simulated track is read as it is


def _csv(tmp_path: Path, s, name: str, factor: float) -> Path:
    path = tmp_path / f"{name}.csv"
    pd.DataFrame({"t": s.t, "vx": s.vx * factor, "ay": s.ay, "r": s.r, "p": s.p}).to_csv(path, index=False)
    return path


@pytest.mark.skipif(not KITTI_DRIVES, reason="../shared/data/kitti-oxts* not present")
@pytest.mark.parametrize("chunk_rows", [None, 7, 500])
def test_estimate_refuses_a_speed_in_mph_and_keeps_the_other_logs(tmp_path, chunk_rows):
    """``roadbank estimate`` on a batch: KITTI drive 0047 written as a CSV without a units row (t, vx, ay, r, p) with
    its speed in mph, and the same drive as recorded: the first fails naming the file, the column 'vx', mph and what
    read it, without a traceback and without an output; the second is written. Read in pieces of 7 or 500 rows the
    verdict is the same (the span read is the log's first SCALE_SPAN_S, whatever the pieces)."""
    from roadbank.io.kitti import load_kitti_oxts

    s = load_kitti_oxts(DATA / "kitti-oxts" / "2011_10_03_drive_0047").signals
    bad, good = _csv(tmp_path, s, "mph", MPH), _csv(tmp_path, s, "ok", 1.0)
    args = ["estimate", str(bad), str(good), "-o", str(tmp_path / "out")]
    res = CliRunner().invoke(main, args + (["--chunk-rows", str(chunk_rows)] if chunk_rows else []))
    assert res.exit_code == 1, res.output
    assert "Traceback" not in res.output
    said = [line for line in res.output.splitlines() if "mph.csv" in line and "FAILED" in line]
    assert said and "channel 'speed' (column 'vx'): speed looks like mph declared as m/s" in said[0], res.output
    assert "roll rate" in said[0]
    written = sorted(f.name for f in (tmp_path / "out").iterdir())
    assert written == ["ok.bank.parquet", "settings.json", "summary.csv"], written
    with pytest.raises(LogError, match="mph declared as m/s"):
        load_log(bad)


@pytest.mark.parametrize("mph_first", [False, True])
def test_the_span_read_is_the_logs_first_and_the_same_in_pieces(tmp_path, mph_first):
    """A 400 s CSV (:func:`_synthetic` at 20 Hz) whose speed is in mph over its first SCALE_SPAN_S only, or after it
    only: the verdict is the first span's (refused, or read), the same whole and in pieces of 7 or 1000 rows."""
    t, vx, ay, r, p, ax = _synthetic(400.0, rate=20.0)
    first = t <= SCALE_SPAN_S
    scale = np.where(first == mph_first, MPH, 1.0)
    path = tmp_path / "log.csv"
    pd.DataFrame({"t": t, "vx": vx * scale, "ay": ay, "r": r, "p": p}).to_csv(path, index=False)
    reads = [lambda: load_log(path)] + [lambda n=n: list(stream_log(path, chunk_rows=n)) for n in (7, 1000)]
    for read in reads:
        if mph_first:
            with pytest.raises(LogError, match="speed looks like mph declared as m/s"):
                read()
        else:
            read()


@pytest.mark.skipif(len(KITTI_DRIVES) < 16, reason="the 16 KITTI drives of ../shared/data/kitti-oxts* not present")
def test_a_lateral_channel_that_reads_the_forward_axis_is_refused_and_real_drives_are_not():
    """An IMU turned by 90 deg in the car: its 'ay' is the car's -ax, which follows the speed's changes, not the turns
    (a bank that changes makes ay follow vx r as loosely, so the balance checks cannot tell). Refused naming the
    channel, whole and in pieces, on every KITTI drive whose speed changes; none of the drives as recorded is."""
    from roadbank.io.consistency import lateral_axis_error
    from roadbank.io.kitti import load_kitti_oxts

    refused = 0
    for drive in KITTI_DRIVES:
        s = load_kitti_oxts(drive).signals
        check_consistency(s)                                  # as recorded: nothing refused
        turned = Signals(s.t, s.vx, -s.ax, s.r, s.delta_f)
        try:
            lateral_axis_error(turned.t, turned.vx, turned.ay, turned.r, "turned.csv")
        except LogError as exc:
            assert "channel 'lateral_acceleration': it follows the speed's changes" in str(exc)
            assert "forward axis" in str(exc)
            refused += 1
    assert refused >= 14, refused     # 14 of the 16 shared drives (two follow the speed loosely: docs); more drives
    #                                   in the folder can only add to it


@pytest.mark.skipif(not KITTI_DRIVES, reason="../shared/data/kitti-oxts* not present")
@pytest.mark.parametrize("chunk_rows", [None, 7])
def test_estimate_refuses_a_turned_imu_and_keeps_the_other_logs(tmp_path, chunk_rows):
    """``roadbank estimate`` on drive 0047 written with its ay column holding -ax (a turned IMU) beside the drive as
    recorded: the first fails naming the file and the column, the second is written."""
    from roadbank.io.kitti import load_kitti_oxts

    s = load_kitti_oxts(DATA / "kitti-oxts" / "2011_10_03_drive_0047").signals
    good = _csv(tmp_path, s, "ok", 1.0)
    bad = tmp_path / "turned.csv"
    pd.DataFrame({"t": s.t, "vx": s.vx, "ay": -s.ax, "r": s.r}).to_csv(bad, index=False)
    args = ["estimate", str(bad), str(good), "-o", str(tmp_path / "out")]
    res = CliRunner().invoke(main, args + (["--chunk-rows", str(chunk_rows)] if chunk_rows else []))
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    said = [line for line in res.output.splitlines() if "turned.csv" in line and "FAILED" in line]
    assert said and "channel 'lateral_acceleration' (column 'ay'): it follows the speed's changes" in said[0]
    assert sorted(f.name for f in (tmp_path / "out").iterdir()) == ["ok.bank.parquet", "settings.json", "summary.csv"]


@pytest.mark.skipif(len(KITTI_DRIVES) < 16, reason="the 16 KITTI drives of ../shared/data/kitti-oxts* not present")
def test_esp_channels_alone_warn_of_a_speed_in_kmh_or_an_ay_in_g_on_gentle_drives():
    """The ESP channels alone (no roll rate or ax to read the speed's scale): a speed in km/h or an ay in g declared SI
    is warned about on the gentle drives too, from the gently turning samples' slope and what is left of ay there
    (drive 0070 had run in silence to 45 deg of bank in km/h, 15 deg in g), or for g the moving samples' slope where
    too few turn; as recorded none warns of either."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.validation.splits import SHARED_DRIVES

    said = {"km/h": 0, "g": 0}
    gentle = 0
    for drive in (d for d in KITTI_DRIVES if d.name in SHARED_DRIVES):      # the 16 the counts were read on
        s = load_kitti_oxts(drive).signals
        esp = Signals(s.t, s.vx, s.ay, s.r, s.delta_f)
        assert not [w for w in check_consistency(esp) if "declared" in w], drive.name
        kmh = check_consistency(Signals(s.t, s.vx * 3.6, s.ay, s.r, s.delta_f))
        in_g = check_consistency(Signals(s.t, s.vx, s.ay / G, s.r, s.delta_f))
        said["km/h"] += any("km/h" in w and "declared as m/s" in w for w in kmh)
        said["g"] += any("g declared as m/s^2" in w for w in in_g)
        gentle += "2011_09_26_drive_0070" == drive.name and any("gently turning" in w for w in kmh)
    assert gentle == 1                              # 0070 never turns hard: the gentle turns say it
    # km/h: 10 of 16 (the silent six turn little: 3 or 19 gently turning samples, a slope of 0.07 no unit explains, or
    # what is left of ay below a 15 deg bank's root mean square, which the paper's bank-lane-change reaches); g: 13
    assert said["km/h"] >= 10 and said["g"] >= 13, said
