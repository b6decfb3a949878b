"""A log designed quiet on its first minute whose roads turn rough is said so (vehicle.conditions.RoadCheck,
fleet.process.louder_warnings): the truth is how the log was built, a smooth road (a real drive low-passed, with a
data sheet's noise) before real KITTI roads, against logs whose roads do not change."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadbank import Signals
from roadbank.fleet.process import estimate_log
from roadbank.io import load_log
from roadbank.mapping.build import MapSettings, map_one_log
from roadbank.fleet.process import design_words
from roadbank.tuning.real import design_settings
from roadbank.tuning.real.roads import on_one_clock, smoothed_drive
from roadbank.vehicle import load_vehicle
from roadbank.vehicle.conditions import ROAD_CHECK_WINDOW_S, RoadCheck, design_ay_floor

#: the car described (a vehicle file): a quiet log of a car nobody described is designed loud from its start (the
#: sixty-second stage), and only the car's model is handed over or warned about
CAR = load_vehicle("sedan")

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
DRIVES = ("2011_09_26_drive_0036", "2011_09_26_drive_0022", "2011_09_26_drive_0064", "2011_09_30_drive_0034")


def _logs():
    found = [next(iter(DATA.glob(f"*/{d}")), None) for d in DRIVES]
    if any(f is None for f in found):
        pytest.skip(f"the KITTI drives {DRIVES} are not all under {DATA}")
    return [load_log(f) for f in found]


def _drives() -> list[Signals]:
    return [log.signals for log in _logs()]


def _esp(s: Signals, smooth: bool = False, seed: int = 0) -> Signals:
    """The drive's ESP channels; ``smooth``: ay and the yaw rate as a smooth road on a data sheet's sensors (a 2 s
    moving mean with 0.02 m/s^2, 0.002 rad/s of white noise: ``tuning.real.roads.smoothed_drive``)."""
    x = smoothed_drive(s, seed) if smooth else s
    return Signals(x.t, x.vx, x.ay, x.r, np.full(len(x), np.nan))


def _stitched(parts: list[tuple[Signals, bool]]) -> Signals:
    return on_one_clock([_esp(s, smooth, seed=k) for k, (s, smooth) in enumerate(parts)], 0.1)[0]


def _write(s: Signals, path: Path) -> Path:
    pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r}).to_parquet(path)
    return path


def test_a_smooth_first_minute_then_rough_roads_is_said(tmp_path):
    """estimate hands kinematic-pif over to the design of the first loud minute (the fifty-eighth stage) and says when;
    with the hand-over switched off (as before that stage), it warns: split the log. Without the vehicle file the log
    is the blend from its start: nothing to hand over or to say but why."""
    d = _drives()
    log = _stitched([(d[0], True), (d[1], True)] + [(x, False) for x in d])
    path = _write(log, tmp_path / "smooth_then_rough.parquet")
    nobody = estimate_log(path, tmp_path / "out_nobody.csv")
    assert nobody.status == "ok" and nobody.design["quiet"] and "handed_over_s" not in nobody.design
    assert "reads quiet" not in nobody.warnings
    assert "the low-pass blend (a quiet log, but" in design_words(nobody.design, "kinematic-pif")
    summary = estimate_log(path, tmp_path / "out.csv", vehicle=CAR)
    assert summary.status == "ok" and summary.design["quiet"]
    assert "designed on its first minute of driving, which reads quiet" in summary.warnings
    assert "but its roads turned loud: from" in summary.warnings
    assert "split the log where the road changes" not in summary.warnings
    smooth_s = float(np.ptp(d[0].t) + 0.1 + np.ptp(d[1].t))        # where the rough roads begin
    assert smooth_s < summary.design["handed_over_s"] <= smooth_s + 2 * ROAD_CHECK_WINDOW_S
    assert "until its roads turn loud" in design_words(summary.design, "kinematic-pif")
    with design_settings(road_change=False):
        before = estimate_log(path, tmp_path / "out_before.csv", vehicle=CAR)
    assert "split the log where the road changes" in before.warnings and "handed_over_s" not in before.design
    # read in chunks of any size, the check reads the same stretches
    whole = RoadCheck(design_ay_floor(log))
    whole.add(log)
    for rows in (97, 1000):
        pieces = RoadCheck(design_ay_floor(log))
        for a in range(0, len(log), rows):
            pieces.add(log[a:a + rows])
        assert pieces.finish() == pytest.approx(whole.finish(), rel=1e-12)
    loud, driving = whole.finish()
    assert loud >= 0.5 * driving > 0


def test_roads_that_stay_as_they_began_are_not_said(tmp_path):
    d = _drives()
    smooth = _stitched([(x, True) for x in d])            # smooth throughout: quiet, and stays so
    summary = estimate_log(_write(smooth, tmp_path / "smooth.parquet"), tmp_path / "out.csv")
    assert summary.design["quiet"] and "reads quiet" not in summary.warnings
    rough = _stitched([(x, False) for x in d])            # rough throughout: loud, nothing to check
    summary = estimate_log(_write(rough, tmp_path / "rough.parquet"), tmp_path / "out2.csv")
    assert not summary.design["quiet"] and "reads quiet" not in summary.warnings


def _map_log(tmp_path) -> None:
    """``drive.parquet`` (smooth then rough, with positions) and ``map.toml`` in ``tmp_path``."""
    logs = _logs()
    parts = [(logs[0], True), (logs[1], True)] + [(x, False) for x in logs]
    sig = _stitched([(log.signals, smooth) for log, smooth in parts])
    lat = np.concatenate([log.extra["lat_deg"] for log, _ in parts])
    lon = np.concatenate([log.extra["lon_deg"] for log, _ in parts])
    pd.DataFrame({"t": sig.t, "vx": sig.vx, "ay": sig.ay, "r": sig.r, "lat": lat, "lon": lon}).to_parquet(
        tmp_path / "drive.parquet")
    (tmp_path / "map.toml").write_text(
        'convention = "ISO"\n[channels]\ntime = { column = "t", unit = "s" }\n'
        'speed = { column = "vx", unit = "m/s" }\nlateral_acceleration = { column = "ay", unit = "m/s^2" }\n'
        'yaw_rate = { column = "r", unit = "rad/s" }\nlatitude = { column = "lat", unit = "deg" }\n'
        'longitude = { column = "lon", unit = "deg" }\n')


def test_map_says_it_too(tmp_path):
    """roadbank map designs on the first minute as estimate does (its smoother is pif-smoother on a quiet log, the car
    described), and says so the same way; without the vehicle file the smoother is the low-pass one from the start
    (the sixty-third stage): nothing to say."""
    _map_log(tmp_path)
    rec, _, _ = map_one_log(tmp_path / "drive.parquet", 0, MapSettings(channels=tmp_path / "map.toml", vehicle=CAR))
    assert rec.status == "ok", rec.error
    said = [w for w in rec.warnings if "which reads quiet" in w]
    assert len(said) == 1 and "kinematic-smoother is pif-smoother" in said[0]
    rec, _, _ = map_one_log(tmp_path / "drive.parquet", 0, MapSettings(channels=tmp_path / "map.toml"))
    assert rec.status == "ok", rec.error
    assert not [w for w in rec.warnings if "which reads quiet" in w]


def test_map_with_a_causal_estimator_says_its_hand_over(tmp_path):
    """roadbank map -e kinematic-pif hands over as estimate does: it says when, as estimate says it, not that the car's
    model was kept (it said 'split the log where the road changes' of an estimator that had been handed over)."""
    _map_log(tmp_path)
    rec, _, _ = map_one_log(tmp_path / "drive.parquet", 0,
                            MapSettings(estimator="kinematic-pif", channels=tmp_path / "map.toml", vehicle=CAR))
    assert rec.status == "ok", rec.error
    est = estimate_log(tmp_path / "drive.parquet", tmp_path / "out.csv", channels=tmp_path / "map.toml", vehicle=CAR)
    assert "handed_over_s" in est.design
    said = [w for w in rec.warnings if "which reads quiet" in w]
    assert len(said) == 1 and "split the log" not in said[0]
    assert f"from {est.design['handed_over_s']:.1f} s on kinematic-pif is the low-pass blend" in said[0]
