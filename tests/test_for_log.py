"""The library path designs for the log as the command line does (roadbank.vehicle.for_log), and says so when it
does not."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank import estimators
from roadbank.cli import main
from roadbank.vehicle import for_log

DRIVE = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"
needs_drive = pytest.mark.skipif(not DRIVE.is_dir(), reason="../shared/data/kitti-oxts is not here")


@needs_drive
@pytest.mark.parametrize("name", ["pif-modified", "kinematic-ff"])
def test_for_log_is_what_estimate_writes(tmp_path, name):
    from roadbank.io.kitti import load_kitti_oxts

    s = load_kitti_oxts(DRIVE).signals
    out = tmp_path / "out.parquet"
    res = CliRunner().invoke(main, ["estimate", str(DRIVE), "-e", name, "-o", str(out)])
    assert res.exit_code == 0, res.output
    cli = pd.read_parquet(out)
    lib = for_log(name, s).run(s)
    np.testing.assert_allclose(cli[f"{name}.theta"].to_numpy(), lib.theta, rtol=0, atol=1e-12)


@needs_drive
def test_make_warns_when_the_log_is_not_the_data_sheets_rate():
    from roadbank.io.kitti import load_kitti_oxts

    s = load_kitti_oxts(DRIVE).signals
    est = estimators.make("pif-modified")
    with pytest.warns(RuntimeWarning, match=r"sampled at 10 Hz; roadbank.vehicle.for_log"):
        est.run(s)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        est.run(s)                                  # said once
        estimators.make("pif-modified", R=1e-6).run(s)   # weights given: nothing to say
        estimators.make("kinematic-ff").run(s)           # no sensor weights
