"""A log whose output is no estimate is named. A log whose speed is negative most of the time: the estimators
need forward driving, so its estimate is mostly not valid, and a speed logged with the opposite sign would otherwise
pass in silence. A log too short for the filter to settle, or with no valid sample: the summary's bank numbers are
then the filter's start, or none."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from conftest import DATA_DIR
from roadbank.cli import main
from roadbank.io import load_log
from roadbank.sim import run_scenario


@pytest.fixture(scope="module")
def drive():
    """A simulated S-curve's inputs (t s, vx m/s, ay m/s^2, r rad/s) as a table."""
    s = run_scenario("s-curve").signals
    return pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r})


def _estimate(log: Path, out: Path, *extra):
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out), *extra])
    assert res.exit_code == 0 and "Traceback" not in res.output, res.output
    return res.output, pd.read_csv(out)


def test_a_speed_logged_negative_is_named_and_a_map_reads_it(tmp_path, drive):
    forward, backward = tmp_path / "forward.csv", tmp_path / "backward.csv"
    drive.to_csv(forward, index=False)
    drive.assign(vx=-drive.vx).to_csv(backward, index=False)
    text, out = _estimate(backward, tmp_path / "b.csv")
    assert "channel 'speed' (column 'vx'): negative on" in text and "invert = true" in text, text
    assert "kinematic-pif gave no valid sample" in text
    assert out["kinematic-pif.valid"].mean() < 0.05          # nothing valid while "reversing"

    mapped = tmp_path / "map.toml"
    mapped.write_text('convention = "ISO"\n[channels]\ntime = { column = "t", unit = "s" }\n'
                      'speed = { column = "vx", unit = "m/s", invert = true }\n'
                      'lateral_acceleration = { column = "ay", unit = "m/s^2" }\n'
                      'yaw_rate = { column = "r", unit = "rad/s" }\n')
    text_mapped, fixed = _estimate(backward, tmp_path / "m.csv", "--channels", str(mapped))
    text_forward, ref = _estimate(forward, tmp_path / "f.csv")
    both = text_mapped + text_forward
    assert "negative on" not in both and "gave no valid sample" not in both and "never settled" not in both
    np.testing.assert_allclose(fixed["kinematic-pif.theta"], ref["kinematic-pif.theta"], atol=1e-12)


def test_a_drive_that_reverses_for_a_while_is_not_named(tmp_path, drive):
    """Parking manoeuvres: a fifth of the samples in motion reversing is driving, not a sign convention."""
    n = len(drive)
    vx = drive.vx.to_numpy().copy()
    vx[: n // 5] = -2.0
    log = tmp_path / "parking.csv"
    drive.assign(vx=vx).to_csv(log, index=False)
    text, out = _estimate(log, tmp_path / "p.csv")
    assert "negative on" not in text
    assert out["kinematic-pif.valid"].iloc[n // 2:].all()


@pytest.mark.skipif(not DATA_DIR.is_dir(), reason="../shared/data (real drives) is not beside the checkout")
def test_no_real_drive_is_named():
    paths = sorted(DATA_DIR.glob("kitti-oxts*/*/oxts")) + sorted(DATA_DIR.glob("comma2k19*/processed_log"))
    assert len(paths) >= 3
    for p in paths:
        assert not [w for w in load_log(p.parent).warnings if "negative on" in w], p


def test_a_log_shorter_than_the_settling_time_is_named(tmp_path, drive):
    log = tmp_path / "short.csv"
    drive.iloc[:5].to_csv(log, index=False)                  # 0.04 s of driving
    text, out = _estimate(log, tmp_path / "s.csv")
    assert "kinematic-pif never settled" in text and "settling time" in text, text
    assert out["kinematic-pif.valid"].all() and not out["kinematic-pif.settled"].any()
