"""``roadbank estimate --vehicle car.toml`` removes the sensor offsets ``roadbank identify`` wrote.

Truth: a simulated drive whose sensors carry known offsets (yaw rate 0.5 deg/s, ay 0.15 m/s^2,
steering wheel 3 deg) and whose true road bank is known; identify -> vehicle file -> estimate
must then be closer to the true bank than the same file without its offsets, or no file.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank import Signals
from roadbank.cli import main
from roadbank.identification.check import SimCase
from roadbank.sim.drives import DriveSpec, mixed_drive
from roadbank.io.writers import write_table
from roadbank.sim import PlantParams, run
from roadbank.vehicle import Vehicle, VehicleFileError

CROWN = 0.02          # 2 % crown on the straights (told to identify with --straight-bank)
NAMES = ("kinematic", "pif-modified")


def _read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """~3 min of mixed driving with offsets on yaw rate, ay and steering; the log, the true bank, car.toml."""
    d = tmp_path_factory.mktemp("offsets")
    case = SimCase(drive=DriveSpec(crown=CROWN), seed=1)
    s = case.sensors
    sens = s.replace(yaw_rate=replace(s.yaw_rate, bias=case.r_bias), ay=replace(s.ay, bias=case.ay_bias),
                     steering=replace(s.steering, bias=case.swa_bias))
    plant = PlantParams(vehicle=case.params, cornering_scale_front=case.scale_front,
                        cornering_scale_rear=case.scale_rear)
    res = run(mixed_drive(case.seed, case.drive), plant=plant, sensors=sens, seed=case.seed)
    sg = res.signals
    log = d / "drive.parquet"
    write_table(log, {"t": sg.t, "vx": sg.vx, "ay": sg.ay, "r": sg.r, "delta_f": sg.delta_f}, {})
    car = d / "car.toml"
    out = CliRunner().invoke(main, ["identify", str(log), "--straight-bank", str(math.degrees(CROWN)),
                                    "-o", str(car)])
    assert car.exists(), out.output
    return case, log, res.truth, car, d


def _bank_rms_deg(path, truth):
    got = _read_csv(path)
    keep = got["t"] > got["t"][0] + 5.0                      # after the warm-up
    out = {}
    for name in NAMES:
        v = keep & got[f"{name}.valid"].astype(bool)
        out[name] = math.degrees(float(np.sqrt(np.mean((got[f"{name}.phi_b"][v] - truth.phi_b[v]) ** 2))))
    return out


@pytest.mark.slow
def test_estimate_with_the_identified_file_removes_the_offsets(drive):
    case, log, truth, car_path, d = drive
    car = Vehicle.from_toml(car_path)
    off = car.sensor_offsets
    assert off["r"] == pytest.approx(case.r_bias, rel=0.05)
    assert off["ay"] == pytest.approx(case.ay_bias, rel=0.05)
    assert off["delta_f"] == pytest.approx(case.swa_bias / case.params.steering_ratio, rel=0.05)
    bare = d / "bare.toml"                                  # the same car without its offsets
    car.replace(identified={k: v for k, v in car.identified.items() if not k.endswith("_offset")}).to_toml(bare)
    rms = {}
    # the identified offsets alone (online learning off), then the default: learnt while the log runs
    for label, extra in (("with", ["--vehicle", str(car_path)]), ("bare", ["--vehicle", str(bare)]),
                         ("none", []), ("learnt", None)):
        out = d / f"{label}.csv"
        extra = ["--no-online-offsets", *extra] if extra is not None else []
        res = CliRunner().invoke(main, ["estimate", str(log), "-e", ",".join(NAMES), "-o", str(out), *extra])
        assert res.exit_code == 0, res.output
        assert ("removing the sensor offsets" in res.output) == (label == "with")
        rms[label] = _bank_rms_deg(out, truth)
    for name in NAMES:
        assert rms["with"][name] < 0.8 * rms["bare"][name], (name, rms)
        assert rms["with"][name] < 0.8 * rms["none"][name], (name, rms)
    assert rms["with"]["pif-modified"] < 0.3, rms        # measured 0.155 deg (0.48 without)
    # this drive has no standstill and no long straight: online learning has nothing to learn from
    for name in NAMES:
        assert rms["learnt"][name] == pytest.approx(rms["none"][name], abs=1e-9), (name, rms)


def test_export_c_with_the_identified_file_takes_the_offsets_off_in_c(drive, tmp_path):
    """`roadbank export c --vehicle car.toml` says what it removes, as estimate does, and the module holds the file's
    offsets (tests/test_export_c.py checks the numbers against step())."""
    _, _, _, car_path, _ = drive
    off = Vehicle.from_toml(car_path).sensor_offsets
    res = CliRunner().invoke(main, ["export", "c", "--vehicle", str(car_path), "-e", "pif-modified", "--rate", "100",
                                    "-o", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "removing the sensor offsets identified in the vehicle file" in res.output
    src = (tmp_path / "roadbank_pif_modified.c").read_text()
    got = {name: float(re.search(rf"#define RB_OFF_{name} \(([^)]*)\)", src).group(1)) for name in ("R", "AY", "D")}
    assert got == pytest.approx({"R": off["r"], "AY": off["ay"], "D": off["delta_f"]}, rel=1e-12)


def test_correct_subtracts_exactly_and_only_what_was_identified():
    n = 50
    t = np.arange(n) * 0.01
    s = Signals(t, np.full(n, 20.0), np.linspace(0, 1, n), np.linspace(0, 0.1, n), np.r_[np.nan, np.zeros(n - 1)])
    car = Vehicle()
    assert car.sensor_offsets == {} and car.correct(s) is s
    car = car.with_identified({"yaw_rate_offset": {"value": 0.01, "std": 1e-4, "unit": "rad/s"},
                               "steering_offset": {"value": 0.002, "std": 1e-5, "unit": "rad"},
                               "Cr": {"value": 3e5, "std": 1e4, "unit": "N/rad"}})
    c = car.correct(s)
    np.testing.assert_array_equal(c.r, s.r - 0.01)
    np.testing.assert_array_equal(c.ay, s.ay)                  # no ay offset identified: unchanged
    np.testing.assert_array_equal(c.delta_f[1:], -0.002)
    assert np.isnan(c.delta_f[0])                              # missing samples stay missing
    np.testing.assert_array_equal(c.t, s.t)
    np.testing.assert_array_equal(c.vx, s.vx)


def test_an_offset_in_the_wrong_unit_is_a_clear_error(tmp_path, drive):
    _, log, _, car_path, _ = drive
    text = car_path.read_text()
    assert 'unit = "rad/s"' in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('unit = "rad/s"', 'unit = "deg/s"'))
    with pytest.raises(VehicleFileError, match=r"bad\.toml: \[identified\.yaw_rate_offset\] unit .*rad/s"):
        _ = Vehicle.from_toml(bad).sensor_offsets
    res = CliRunner().invoke(main, ["estimate", str(log), "--vehicle", str(bad), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 2 and "yaw_rate_offset" in res.output and "Traceback" not in res.output


@pytest.mark.parametrize("vx", [10.0, 22.2, 39.0])
def test_a_yaw_rate_bias_is_unobservable_on_the_modified_model(vx):
    """Why offsets must be identified before estimating: the design model of the default PIF,
    augmented with a constant yaw-rate bias ``b`` (``r_meas = r + b``), loses one observable
    direction (python-control's observability matrix), and along it the bank moves by
    ``vx b / g``: at the track's 39 m/s a bias of 0.3 deg/s is 1.2 deg of bank that no
    estimator reading ``ay``, ``r`` and ``vx`` can tell from road bank."""
    import control as ct
    from scipy.linalg import null_space

    from roadbank import estimators

    est = estimators.make("pif-modified")
    A, _, C, *_ = est.design_model(vx)
    n = A.shape[0]
    Aa = np.zeros((n + 1, n + 1))
    Aa[:n, :n] = A
    Ca = np.hstack([C, [[1.0]]])
    O = ct.obsv(Aa, Ca)
    assert np.linalg.matrix_rank(O) == n
    z = null_space(O)[:, 0]
    g = est.params.g
    assert z[est.state_names.index("w")] / z[n] == pytest.approx(vx / g, rel=1e-9)
    assert z[est.state_names.index("r")] / z[n] == pytest.approx(-1.0, rel=1e-9)


def test_the_default_pif_reads_a_yaw_rate_bias_as_a_bank_of_vx_b_over_g():
    """The filter's behaviour along that direction: a steady turn, then the same turn with a
    yaw-rate bias ``b``; the steady bank estimate moves by ``-vx b / g`` (sin of the bank)."""
    from roadbank import estimators

    n, vx, b = 3000, 30.0, math.radians(0.3)
    t = np.arange(n) * 0.01
    ay, r = 3.0, 0.08
    base = Signals(t, np.full(n, vx), np.full(n, ay), np.full(n, r), np.full(n, 0.02))
    biased = replace(base, r=base.r + b)
    est = estimators.make("pif-modified")
    w0 = est.run(base).w[-1]
    w1 = est.run(biased).w[-1]
    assert w1 - w0 == pytest.approx(-vx * b / est.params.g, rel=1e-3)


def test_the_library_takes_a_vehicle_files_path_as_the_vehicle(drive, tmp_path):
    """fleet.estimate_log and mapping.map_logs take vehicle= as a path or a name, as --vehicle does (a path had
    failed with AttributeError: 'str' object has no attribute 'correct')."""
    from roadbank.fleet import estimate_log

    _, log, _, car_path, _ = drive
    by_path = estimate_log(log, tmp_path / "p.csv", vehicle=str(car_path))
    by_object = estimate_log(log, tmp_path / "o.csv", vehicle=Vehicle.from_toml(car_path))
    assert by_path.status == "ok", by_path.error
    assert (tmp_path / "p.csv").read_text() == (tmp_path / "o.csv").read_text()
    assert by_object.status == "ok"
