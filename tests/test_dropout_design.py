"""A single dropout does not move a log's design: the conditions are measured with each single missing sample bridged
(roadbank.signals.bridged), while the estimators still read the log as it is (they hold their output over it)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals
from roadbank.signals import bridged
from roadbank.vehicle import log_conditions

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def test_a_single_missing_sample_is_interpolated_in_time_and_nothing_else():
    t = np.array([0.0, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7])
    ay = np.array([1.0, np.nan, 4.0, np.nan, np.nan, 2.0, np.nan])      # single, a pair, at the end
    s = Signals(t, np.full(7, 10.0), ay, np.zeros(7), None)
    b = bridged(s)
    np.testing.assert_array_equal(b.ay[[0, 2, 5]], ay[[0, 2, 5]])
    assert b.ay[1] == pytest.approx(1.0 + (0.1 / 0.3) * 3.0)           # linear in time, not in samples
    assert np.isnan(b.ay[[3, 4, 6]]).all()                              # two in a row and the last: left as they are
    assert np.isnan(b.delta_f).all() and np.isnan(s.ay[1])              # no steering stays none; s unchanged
    clean = Signals(t, np.full(7, 10.0), np.ones(7), np.zeros(7), None)
    assert bridged(clean) is clean


def test_one_dropout_in_a_drive_leaves_its_design_where_it_was():
    """KITTI 2011_09_29_drive_0004 read from its ESP channels alone: one ay sample missing 6.7 s in left the noise
    floor not measured (its one long run of driving split in two short ones), and the design fell back to the data
    sheet's noise (raw RMS against the INS roll 0.127 -> 0.184 deg); with the dropout bridged the design reads the
    same floor and the estimate is as before."""
    from roadbank.io import load_log
    from roadbank.vehicle import for_log

    drive = DATA / "kitti-oxts-extra" / "2011_09_29_drive_0004"
    if not drive.is_dir():
        pytest.skip(f"{drive} not found (the shared KITTI drives)")
    log = load_log(drive)
    s = dataclasses.replace(log.signals, p=None, ax=None, q=None)
    ay = s.ay.copy()
    ay[67] = np.nan
    dropped = dataclasses.replace(s, ay=ay)
    before, after = log_conditions(s), log_conditions(dropped)
    assert np.isfinite(after["log_ay_floor"]) and after["log_ay_floor"] == pytest.approx(before["log_ay_floor"],
                                                                                         rel=0.1)

    def rms(signals):
        e = for_log("kinematic-pif", signals).run(signals)
        m = (signals.t > signals.t[0] + 5) & (signals.vx >= 5) & e.valid
        return np.degrees(np.sqrt(np.mean((e.theta[m] - log.reference_roll[m]) ** 2)))
    assert not for_log("kinematic-pif", dropped).run(dropped).valid[67]     # the estimator still holds over it
    assert rms(dropped) == pytest.approx(rms(s), abs=0.005)
