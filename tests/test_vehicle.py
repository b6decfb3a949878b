"""Vehicle files (roadbank.vehicle): TOML round trip, units, every malformed case, shipped cars, CLI."""

from __future__ import annotations

import dataclasses
import math
import pickle
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank import VehicleParams
from roadbank.cli import main
from roadbank.vehicle import (SensorSpec, Vehicle, VehicleFileError, builtin_names, load_vehicle,
                              parse_quantity)

ROOT = Path(__file__).resolve().parents[1]

#: a minimal valid [vehicle] table (the paper's Table 1)
TABLE1 = "[vehicle]\nm = 1687.0\nIz = 3401.0\nLf = 1.15\nLr = 1.47\nCf = 115000.0\nCr = 396820.0\n"


def _car(**changes) -> str:
    """TABLE1 with keys replaced/added (values are TOML source text)."""
    lines = dict(line.split(" = ") for line in TABLE1.splitlines()[1:])
    lines.update(changes)
    return "[vehicle]\n" + "".join(f"{k} = {v}\n" for k, v in lines.items())


# ---- round trip -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rich_vehicle():
    v = load_vehicle("sedan")
    v = v.with_tuning("pif-modified", {"Q": 30.0, "R": 1e-5, "th": 0.5, "variant": "steady"},
                      scores={"val_rms_deg": 0.1 + 0.2, "val_p95_deg": 1e-300, "n_runs": 40,
                              "note": 'quote " backslash \\ newline \n tab \t unicode ° del \x7f'})
    v = v.with_tuning("pif-original", {"R": [0.307, 0.0035]})
    v = v.with_identified({"Cr": {"value": 105123.456789, "std": 2.5e3, "unit": "N/rad",
                                  "note": "quasi-steady cornering", "logs": ["a.csv", "b dir/c.parquet"]},
                           "lap_time": {"value": -0.0012, "std": 1e-4, "unit": "s", "ok": True}})
    return v.with_sensors(r_bias=0.001).replace(description="round trip\nwith a newline",
                                                sources=("a", "b [1]"))


def test_round_trip_is_exact(rich_vehicle):
    text = rich_vehicle.dumps()
    back = Vehicle.loads(text)
    assert back == rich_vehicle
    assert back.scores["pif-modified"]["val_rms_deg"] == 0.1 + 0.2  # float bits preserved
    assert back.dumps() == text  # and the text is a fixed point
    assert isinstance(back.scores["pif-modified"]["n_runs"], int)


def test_round_trip_through_a_file_and_pickle(rich_vehicle, tmp_path):
    path = tmp_path / "car.toml"
    rich_vehicle.to_toml(path)
    assert Vehicle.from_toml(path) == rich_vehicle
    assert load_vehicle(path) == rich_vehicle and load_vehicle(str(path)) == rich_vehicle
    assert pickle.loads(pickle.dumps(rich_vehicle)) == rich_vehicle


def test_copies_and_make_merge_tuning(rich_vehicle):
    v = rich_vehicle.with_tuning("pif-modified", {"Q": 3.0})
    assert v.tuning["pif-modified"] == {"Q": 3.0}  # replaced, not merged
    assert v.scores == rich_vehicle.scores  # scores untouched without new ones
    v = v.with_tuning("dfc", {"a_ref": 2.0, "tau": 0.5})
    est = v.make("dfc", tau=0.25)  # file options, then overrides
    assert (est.params, est.a_ref, est.tau) == (v.params, 2.0, 0.25)
    w = v.with_params(Cr=2e5)
    assert w.params == v.params.replace(Cr=2e5) and v.params.Cr != 2e5
    assert v.with_identified({"Cr": {"value": 1.0}}).identified["Cr"] == {"value": 1.0}
    assert "lap_time" in v.with_identified({"Cr": {"value": 1.0}}).identified


@pytest.mark.parametrize("name,options", [
    ("pif-rate", {"Q": 4e-5, "Q_rate": 5e-4, "th": 1e5, "roll": "dynamic"}),
    ("pif-rate-adaptive", {"Q": 4e-5, "Q_rate": 5e-4, "mu": 1.1, "tau": 0.4}),
    ("pif-adaptive", {"Q": 2e-4, "mu": 1.1, "tf": 0.2}),
])
@pytest.mark.slow
def test_tuning_tables_accept_every_option_of_the_estimator(tmp_path, name, options):
    """What ``roadbank tune`` writes for each PIF variant (options of the class and of its bases,
    mixins included) is a valid [tuning] table, and the file round-trips into the estimator."""
    v = load_vehicle("suv-paper").with_tuning(name, options)
    v.to_toml(tmp_path / "car.toml")
    est = load_vehicle(tmp_path / "car.toml").make(name)
    assert all(getattr(est, k) == val for k, val in options.items() if k != "roll")
    assert est.roll == options.get("roll", est.roll)


def test_make_uses_the_vehicle_params_and_tuning():
    from roadbank import estimators

    v = load_vehicle("van").with_tuning("dfc", {"a_ref": 1.5})
    a = v.make("dfc").run(_signals())
    np.testing.assert_array_equal(a.theta, estimators.make("dfc", v.params, a_ref=1.5).run(_signals()).theta)
    assert not np.array_equal(a.theta, estimators.make("dfc", v.params).run(_signals()).theta)


@pytest.mark.slow
def test_smoother_takes_the_filters_tuning_table_under_its_own():
    """pif-smoother runs pif-modified forward: a car tuned for pif-modified smooths with those weights;
    a table of its own overrides the keys it has."""
    v = load_vehicle("sedan").with_tuning("pif-modified", {"Q": 4e-4, "th": 1e4})
    est = v.make("pif-smoother")
    assert (est.Q, est.th) == (4e-4, 1e4) and est.params == v.params
    own = v.with_tuning("pif-smoother", {"Q": 1e-4})
    assert (own.make("pif-smoother").Q, own.make("pif-smoother").th) == (1e-4, 1e4)


def _signals():
    from roadbank import Signals

    t = np.arange(0, 4, 0.01)
    return Signals(t, np.full_like(t, 20.0), 1.0 + 0.5 * np.sin(t), 0.05 * np.sin(t), 0.01 * np.sin(t))


# ---- the paper SUV and the sensors ------------------------------------------------------------

def test_default_is_the_paper_suv_with_the_simulators_sensors():
    from roadbank.sim import SensorConfig

    v = load_vehicle(None)
    assert v == load_vehicle("suv-paper") and v.name == "suv-paper"
    assert v.params == VehicleParams()  # Table 1 + documented roll data, bit for bit
    assert v.sensors == SensorSpec() and v.sensors.to_sim() == SensorConfig()
    assert v.to_plant() == __import__("roadbank.sim", fromlist=["PlantParams"]).PlantParams()


def test_sensor_variances():
    s = SensorSpec(r_noise=0.002, r_resolution=0.006, ay_noise=0.05, ay_resolution=0.12)
    assert s.r_variance == pytest.approx(0.002 ** 2 + 0.006 ** 2 / 12, rel=1e-15)
    assert s.ay_variance == pytest.approx(0.0025 + 0.0012, rel=1e-15)
    # quantisation variance of the simulator's sensor model: a slow ramp through the quantiser
    cfg = SensorSpec(r_noise=0.0, r_resolution=0.006).to_sim()
    x = np.linspace(-0.3, 0.3, 200_001)
    err = cfg.yaw_rate.apply(x, np.zeros_like(x)) - x
    assert err.var() == pytest.approx(SensorSpec(r_noise=0.0, r_resolution=0.006).r_variance, rel=0.01)


# ---- units ------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, dimension, si", [
    ("1687 kg", "mass", 1687.0),
    ("1.6 t", "mass", 1600.0),
    ("350 mm", "length", 0.35),
    ("35cm", "length", 0.35),
    ("16.7 deg", "angle", 16.7 * 3.141592653589793 / 180.0),
    ("16.7°", "angle", 0.29146998508305),
    ("0.3 deg/s", "angular rate", 0.005235987755982988),
    ("115 kN/rad", "cornering stiffness", 115000.0),
    ("2 kN/deg", "cornering stiffness", 2000.0 * 57.29577951308232),
    ("0.005 g", "acceleration", 0.04905),
    ("5 mg", "acceleration", 0.04905),
    ("2.5 m/s^2", "acceleration", 2.5),
    ("2.5 m/s²", "acceleration", 2.5),
    ("84 kN m/rad", "roll stiffness", 84000.0),
    ("84 kN*m/rad", "roll stiffness", 84000.0),
    ("1000 N m/deg", "roll stiffness", 57295.77951308232),
    ("6.5 kN m s/rad", "roll damping", 6500.0),
    ("3401 kg m^2", "inertia", 3401.0),
    ("3401 kg·m²", "inertia", 3401.0),
    ("100 km/h", "speed", 27.77777777777778),
    ("100 Hz", "frequency", 100.0),
    ("20 ms", "time", 0.02),
    ("60 %", "dimensionless", 0.6),
    ("1e3 kg", "mass", 1000.0),
])
def test_unit_strings(text, dimension, si):
    assert parse_quantity(text, dimension) == pytest.approx(si, rel=1e-12)


def test_unit_strings_in_a_file_become_si():
    v = Vehicle.loads(_car(m='"1.687 t"', Cf='"2007.1 N/deg"', Lf='"1150 mm"')
                      + '[sensors]\nr_resolution = "0.3 deg/s"\nay_range = "1.8 g"\nrate = "0.2 kHz"\n')
    assert v.params.m == pytest.approx(1687.0, rel=1e-12)
    assert v.params.Cf == pytest.approx(2007.1 * 180 / math.pi, rel=1e-12)
    assert v.params.Lf == pytest.approx(1.15, rel=1e-12)
    assert v.sensors.r_resolution == pytest.approx(math.radians(0.3), rel=1e-12)
    assert v.sensors.ay_range == pytest.approx(1.8 * 9.81, rel=1e-12)
    assert v.sensors.rate == 200.0


def test_optional_roll_data_scale_with_mass():
    v = Vehicle.loads(_car(m="1200.0"))
    suv = VehicleParams()
    k = 1200.0 / suv.m
    assert v.params.ms == pytest.approx(suv.ms * k) and v.params.k_roll == pytest.approx(suv.k_roll * k)
    # the SUV's steady roll gradient ms h / (k - ms g h) is kept
    grad = lambda p: p.ms * p.h_roll / (p.k_roll - p.ms * p.g * p.h_roll)  # noqa: E731
    assert grad(v.params) == pytest.approx(grad(suv), rel=1e-12)


# ---- malformed files: every one names the file and the key ------------------------------------

BAD = [
    ("syntax", "[vehicle]\nm = = 5\n" + TABLE1[10:], ["TOML syntax error", "line 2"]),
    ("duplicate key", TABLE1 + "m = 1500.0\n", ["TOML syntax error"]),
    ("unknown table", TABLE1 + "[vehicel]\n", ["[vehicel]", "did you mean 'vehicle'"]),
    ("top-level key", "m = 5\n" + TABLE1, ["m = 5", "outside any table"]),
    ("unknown key", TABLE1 + "Izz = 5.0\n", ["[vehicle] Izz", "did you mean 'Iz'"]),
    ("case typo", TABLE1 + "steering_Ratio = 16.0\n", ["[vehicle] steering_Ratio", "'steering_ratio'"]),
    ("missing key", "[vehicle]\nm = 1687.0\nIz = 3401.0\nLf = 1.15\nLr = 1.47\nCf = 115000.0\n",
     ["[vehicle] Cr", "missing"]),
    ("missing table", "[meta]\nname = 'x'\n", ["missing table [vehicle]"]),
    ("bool", _car(m="true"), ["[vehicle] m = true", "expected a number"]),
    ("array", _car(m="[1687.0]"), ["[vehicle] m = [1687.0]", "expected a number"]),
    ("not a number", _car(Iz='"heavy"'), ["[vehicle] Iz", "expected a number"]),
    ("unknown unit", _car(m='"1687 kgs"'), ["[vehicle] m", "unknown unit 'kgs'", "did you mean 'kg'"]),
    ("incompatible unit", _car(m='"5 deg"'), ["[vehicle] m = \"5 deg\"", "is an angle", "needs a mass"]),
    ("rate for an angle", _car(steering_ratio='"16 deg/s"'), ["[vehicle] steering_ratio", "angular rate"]),
    ("negative mass", _car(m="-5"), ["[vehicle] m = -5", "must be > 0 kg"]),
    ("infinite", _car(Iz="inf"), ["[vehicle] Iz = inf", "finite"]),
    ("mass in tonnes", _car(m="1.687"), ["[vehicle] m = 1.687", "plausible range", "kg"]),
    ("Cf in N/deg", _car(Cf="2007.0"), ["[vehicle] Cf = 2007.0", "plausible range", "N/rad"]),
    ("Cf per tyre unit mix", _car(Cf='"115 N/rad"'), ["[vehicle] Cf", "= 115 N/rad", "plausible"]),
    ("height in mm", _car(h_cg="700.0"), ["[vehicle] h_cg = 700.0", "plausible"]),
    ("roll stiffness in N m/deg", _car(k_roll="1466.0"), ["[vehicle] k_roll", "plausible"]),
    ("wheelbase", _car(Lf="0.6", Lr="0.6"), ["[vehicle] Lf + Lr", "wheelbase"]),
    ("sprung mass > mass", _car(ms="1800.0"), ["[vehicle] ms = 1800.0", "cannot exceed"]),
    ("roll arm > cg height", _car(h_roll="0.8"), ["[vehicle] h_roll = 0.8", "cannot exceed"]),
    ("roll unstable", _car(k_roll="7000.0"), ["[vehicle] k_roll = 7000.0", "unstable in roll"]),
    ("share > 1", _car(roll_stiffness_front_share="1.2"), ["[vehicle] roll_stiffness_front_share"]),
    ("sensor key", TABLE1 + "[sensors]\nr_noize = 0.001\n", ["[sensors] r_noize", "did you mean 'r_noise'"]),
    ("yaw resolution in deg/s", TABLE1 + "[sensors]\nr_resolution = 0.3\n",
     ["[sensors] r_resolution = 0.3", "plausible", "rad/s"]),
    ("sensor unit", TABLE1 + '[sensors]\nrate = "100 deg"\n', ["[sensors] rate", "needs a frequency"]),
    ("negative noise", TABLE1 + "[sensors]\nay_noise = -0.1\n", ["[sensors] ay_noise = -0.1", ">= 0"]),
    ("dropout", TABLE1 + "[sensors]\ndropout_prob = 0.9\n", ["[sensors] dropout_prob", "plausible"]),
    ("plant key", TABLE1 + "[plant]\nCd = 0.3\n", ["[plant] Cd", "did you mean 'CdA'"]),
    ("plant value", TABLE1 + "[plant]\nmu = 5.0\n", ["[plant] mu = 5.0", "plausible"]),
    ("meta key", "[meta]\nnam = 'x'\n" + TABLE1, ["[meta] nam", "did you mean 'name'"]),
    ("meta type", "[meta]\nname = 5\n" + TABLE1, ["[meta] name = 5", "expected a string"]),
    ("sources type", "[meta]\nsources = [1, 2]\n" + TABLE1, ["[meta] sources", "array of strings"]),
    ("unknown estimator", TABLE1 + "[tuning.pif-modifed]\nQ = 30.0\n",
     ["[tuning.pif-modifed]", "did you mean 'pif-modified'"]),
    ("unknown option", TABLE1 + "[tuning.pif-modified]\nq = 30.0\n",
     ["[tuning.pif-modified] q", "did you mean 'Q'"]),
    ("option of another estimator", TABLE1 + "[tuning.dfc]\nth = 0.5\n", ["[tuning.dfc] th", "option of dfc"]),
    ("tuning not a table", TABLE1 + "[tuning]\npif-modified = 3\n", ["[tuning.pif-modified]", "must be a table"]),
    ("nested tuning", TABLE1 + "[tuning.kalman.sub]\nx = 1\n", ["[tuning.kalman] sub", "got a table"]),
    ("nested scores", TABLE1 + "[scores.kalman.sub]\nx = 1\n", ["[scores.kalman] sub", "got a table"]),
    ("identified not a table", TABLE1 + "[identified]\nCr = 5\n", ["[identified.Cr]", "must be a table"]),
    ("identified offset typo", TABLE1 + "[identified.yaw_rate_ofset]\nvalue = 0.01\n",
     ["[identified.yaw_rate_ofset]", "not an offset roadbank removes", "did you mean 'yaw_rate_offset'"]),
    ("identified offset name", TABLE1 + "[identified.r_offset]\nvalue = 0.01\n",
     ["[identified.r_offset]", "not an offset roadbank removes", "yaw_rate_offset"]),
]


@pytest.mark.parametrize("text, needles", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_malformed_file_names_file_and_key(text, needles):
    with pytest.raises(VehicleFileError) as err:
        Vehicle.loads(text, source="car.toml")
    msg = str(err.value)
    assert msg.startswith("car.toml: "), msg
    for needle in needles:
        assert needle in msg, msg
    assert "\n" not in msg


def test_a_tuned_th_adapts_to_the_sensor_but_one_far_too_large_is_an_error():
    """[tuning.pif-modified] with th and no R (as roadbank tune writes it): halved to the sensor's solvable one, but
    not below th/1000 (a th of 1e12 had become th = 0, the Kalman filter, in silence)."""
    car = load_vehicle(None)
    sane = car.with_tuning("pif-modified", {"th": 4.0 * car.make("pif-modified").th})
    sane.check()
    assert 0.0 < sane.make("pif-modified").th
    with pytest.raises(VehicleFileError, match=r"\[tuning\.pif-modified\] .*th = 1e\+12 .*far too large"):
        car.with_tuning("pif-modified", {"th": 1e12}).check()


def test_missing_file_and_unknown_name():
    with pytest.raises(VehicleFileError, match=r"nope\.toml: no such vehicle file"):
        load_vehicle("nope.toml")
    with pytest.raises(VehicleFileError, match=r"sedn: not a vehicle file .* did you mean 'sedan'"):
        load_vehicle("sedn")


def test_design_failure_is_reported_with_the_table():
    v = load_vehicle(None).with_tuning("pif-modified", {"R": -1.0})
    with pytest.raises(VehicleFileError, match=r"\[tuning\.pif-modified\] \{R = -1\.0\}: "):
        v.check()


def test_vehicle_built_in_code_gets_the_same_checks():
    with pytest.raises(VehicleFileError, match=r"<vehicle x>: \[vehicle\] m = 1\.5: outside the plausible"):
        Vehicle(name="x", params=VehicleParams(m=1.5, ms=1.0, k_roll=84000.0))
    with pytest.raises(VehicleFileError, match=r"\[tuning\.kalmann\]: unknown estimator"):
        load_vehicle(None).with_tuning("kalmann", {})


# ---- shipped cars -----------------------------------------------------------------------------

def test_builtins_are_listed_packaged_and_documented():
    names = builtin_names()
    assert names[0] == "suv-paper" and {"compact", "sedan", "van"} <= set(names)
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["tool"]["setuptools"]["package-data"]["roadbank.vehicles"] == ["*.toml"]
    from roadbank.cli.options import _BUILTIN_HELP

    assert [n.split()[0] for n in _BUILTIN_HELP.split(", ")] == list(names)
    doc = (ROOT / "docs" / "vehicles.md").read_text()
    for n in names:
        assert f"`{n}`" in doc


@pytest.mark.parametrize("name", ["suv-paper", "compact", "sedan", "van"])
def test_builtin_loads_and_designs_a_stable_pif(name):
    v = load_vehicle(name)
    assert v.name == name and v.sources and v.description
    est = v.make("pif-modified")
    for vx in (5.0, 10.0, 20.0, 40.0, 60.0):
        eig = np.linalg.eigvals(est.error_dynamics(vx))
        assert eig.real.max() < 0, (name, vx, eig)


@pytest.mark.parametrize("name, k", [("compact", 1), ("sedan", 2), ("van", 3)])
def test_commonroad_cars_match_their_source(name, k):
    """Every value taken from CommonRoad equals it (6 significant digits); Cr = -p_ky1 * rear axle load;
    the effective Cf gives the documented 4 deg/g understeer gradient."""
    pytest.importorskip("vehiclemodels")
    import importlib

    from roadbank.models.bicycle import understeer_gradient

    P = getattr(importlib.import_module(f"vehiclemodels.parameters_vehicle{k}"), f"parameters_vehicle{k}")()
    p = load_vehicle(name).params
    g = 9.81
    for ours, theirs in ((p.m, P.m), (p.Iz, P.I_z), (p.Lf, P.a), (p.Lr, P.b), (p.h_cg, P.h_cg),
                         (p.ms, P.m_s), (p.track_f, P.T_f), (p.track_r, P.T_r), (p.wheel_radius, P.R_w),
                         (p.Cr, -P.tire.p_ky1 * P.m * g * P.a / (P.a + P.b)),
                         (p.k_roll, (P.K_sf * P.T_f ** 2 + P.K_sr * P.T_r ** 2) / 2 + abs(P.K_tsf) + abs(P.K_tsr))):
        assert ours == pytest.approx(theirs, rel=1e-5)
    assert math.degrees(understeer_gradient(p) * g) == pytest.approx(4.0, rel=1e-4)


# ---- simulator and command line ---------------------------------------------------------------

def _yaw_gain(vehicle, vx=22.0):
    """Steady yaw rate / road-wheel angle of the simulated car, small open-loop step steer."""
    from roadbank.sim import Driver, Scenario, SensorConfig, flat_road, run

    swa = math.radians(4.0)
    sc = Scenario("step", flat_road(), Driver(speed=vx, steering=((0.0, 0.5, 1.0, 5.0), (0.0, 0.0, swa, swa))),
                  5.0, pre_roll=0.5)
    res = run(sc, plant=vehicle.to_plant(), sensors=SensorConfig.ideal(), dt=2e-3)
    k = res.truth.t > 4.0
    return res.truth.r[k].mean() / (swa / vehicle.params.steering_ratio), res.truth.vx[k].mean()


@pytest.mark.parametrize("name", ["suv-paper", "van"])
def test_simulated_car_has_the_bicycle_models_yaw_gain(name):
    """Analytic: r/delta = vx / (L + K vx^2), K = m/L (Lr/Cf - Lf/Cr), with this car's parameters."""
    v = load_vehicle(name)
    gain, vx = _yaw_gain(v)
    p = v.params
    K = p.m / p.L * (p.Lr / p.Cf - p.Lf / p.Cr)
    assert gain == pytest.approx(vx / (p.L + K * vx ** 2), rel=0.02)


@pytest.fixture(scope="module")
def van_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("veh")
    out = d / "van.parquet"
    r = CliRunner().invoke(main, ["simulate", "const-bank", "--vehicle", "van", "-o", str(out)])
    assert r.exit_code == 0, r.output
    return out


def test_simulate_uses_the_car(van_run):
    import pyarrow.parquet as pq

    table = pq.read_table(van_run)
    assert table.schema.metadata[b"roadbank.vehicle"] == b"van"
    lib = load_vehicle("van").simulate("const-bank")
    np.testing.assert_array_equal(table.column("ay").to_numpy(), lib.signals.ay)
    # steady body roll on the straight bank (analytic, roll moment balance of the sprung mass):
    # phi = ms h g sin(phi_b) / (k_roll - ms g h cos(phi_b)) with *this* car's roll data
    def roll(p, bank):
        return p.ms * p.h_roll * p.g * np.sin(bank) / (p.k_roll - p.ms * p.g * p.h_roll * np.cos(bank))

    k = table.column("t").to_numpy() > 5
    phi = table.column("true_phi").to_numpy()[k].mean()
    bank = table.column("true_phi_b").to_numpy()[k].mean()
    assert phi == pytest.approx(roll(load_vehicle("van").params, bank), rel=0.01)
    assert abs(phi - roll(VehicleParams(), bank)) > 0.1 * phi  # not the SUV's


def test_estimate_designs_for_the_vehicle(van_run, tmp_path):
    import pyarrow.parquet as pq

    from roadbank.io import load_log

    car = load_vehicle("sedan").with_tuning("pif-modified", {"tuning": "paper", "Q": 3.0})
    path = tmp_path / "car.toml"
    car.to_toml(path)
    outs = {}
    for label, extra in (("car", ["--vehicle", str(path)]), ("suv", [])):
        out = tmp_path / f"{label}.csv"
        r = CliRunner().invoke(main, ["estimate", str(van_run), "-e", "pif-modified", "-o", str(out)] + extra)
        assert r.exit_code == 0, r.output
        outs[label] = out
    import pandas as pd

    got = pd.read_csv(outs["car"])
    signals = load_log(van_run, params=car.params).signals
    for name in ("pif-modified",):
        lib = car.make(name).run(signals)
        col = [c for c in got.columns if c.startswith(name) and "phi_b" in c][0]
        np.testing.assert_allclose(got[col].to_numpy(), lib.phi_b, rtol=0, atol=1e-12)
        suv_col = pd.read_csv(outs["suv"])[col].to_numpy()
        assert np.max(np.abs(suv_col - lib.phi_b)) > 1e-3
    del pq


@pytest.mark.parametrize("command", [["simulate", "const-bank", "-o", "{out}.csv"],
                                     ["estimate", "{log}", "-o", "{out}.csv"],
                                     ["reproduce", "-o", "{out}"]])
def test_bad_vehicle_file_on_the_cli(command, tmp_path, van_run):
    bad = tmp_path / "car.toml"
    bad.write_text(_car(m="-5"))
    args = [a.format(out=tmp_path / "o", log=van_run) for a in command] + ["--vehicle", str(bad)]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2
    assert "Traceback" not in r.output and (r.exception is None or isinstance(r.exception, SystemExit))
    err = [line for line in r.output.splitlines() if line.startswith("Error")]
    assert len(err) == 1 and f"{bad}: [vehicle] m = -5: must be > 0 kg" in err[0]


def test_help_lists_the_builtins():
    r = CliRunner().invoke(main, ["simulate", "--help"])
    assert "--vehicle" in r.output and "sedan" in r.output


def test_dataclass_fields_are_all_in_the_file_format():
    """Every VehicleParams / SensorSpec field is a documented [vehicle] / [sensors] key."""
    from roadbank.vehicle import PLAUSIBLE, SENSOR_FIELDS

    assert [f.name for f in dataclasses.fields(VehicleParams)] == list(PLAUSIBLE)
    assert [f.name for f in dataclasses.fields(SensorSpec)] == list(SENSOR_FIELDS)


@pytest.mark.slow
def test_reproduce_cell_with_a_vehicle():
    """--vehicle on reproduce: the car is plant and design; its [tuning.<name>] table drives the
    column of that name, so pif-modified is the car's tuned PIF, and pif-gated, which runs pif-modified, takes that
    table as `estimate` does (Vehicle.make; before, reproduce left it untuned); pif-paper stays Table 4."""
    from roadbank import estimators
    from roadbank.report.reproduce import run_cell

    car = load_vehicle("van").with_tuning("pif-modified", {"tuning": "paper", "Q": 3.0}) \
                             .with_tuning("dfc", {"a_ref": 1.5})
    cell = run_cell("const-bank", "nominal", names=("pif-paper", "pif-modified", "dfc", "pif-gated"), vehicle=car)
    sim = car.simulate("const-bank", "nominal")
    np.testing.assert_array_equal(cell.inputs["vx"], sim.truth.vx)
    s = sim.signals
    np.testing.assert_array_equal(cell.phi_b["pif-modified"], car.make("pif-modified").run(s).phi_b)
    np.testing.assert_array_equal(cell.phi_b["dfc"], car.make("dfc").run(s).phi_b)
    np.testing.assert_array_equal(cell.phi_b["pif-gated"], car.make("pif-gated").run(s).phi_b)
    untuned = estimators.make("pif-gated", car.params).run(s).phi_b
    assert np.max(np.abs(untuned - cell.phi_b["pif-gated"])) > 1e-4          # the table matters here
    published = estimators.make("pif-modified", car.params, tuning="paper").run(s).phi_b
    np.testing.assert_array_equal(cell.phi_b["pif-paper"], published)


def test_campaign_runs_perturb_the_vehicle():
    from roadbank.campaign.runner import RunOptions, run_one
    from roadbank.campaign.sampling import draw

    spec = draw(3, base_seed=1)
    van = load_vehicle("van")
    plant, sensors = spec.plant_and_sensors(van)
    assert plant.vehicle.m == pytest.approx(van.params.m * spec.mass_scale)
    assert plant.vehicle.Lf == van.params.Lf and plant.CdA == van.plant["CdA"]
    assert plant.axle_cornering_stiffness == pytest.approx((spec.cf_scale * van.params.Cf,
                                                            spec.cr_scale * van.params.Cr))
    assert spec.plant_and_sensors(load_vehicle(None)) == spec.plant_and_sensors()  # SUV = no vehicle
    assert "vehicle" not in RunOptions().as_dict()  # stored campaigns without cars still resume
    opts = RunOptions(names=("dfc",), duration_scale=0.15, pre_roll=0.5, settle=0.5,
                      vehicle=van.with_tuning("dfc", {"a_ref": 1.5}))
    assert Vehicle.loads(opts.as_dict()["vehicle"]) == opts.vehicle
    rows = run_one(spec, opts)
    assert [r["estimator"] for r in rows] == ["dfc"] and rows[0]["error"] == ""
    assert pickle.loads(pickle.dumps(opts)) == opts  # shipped to Dask workers


def test_campaign_cli_bad_vehicle(tmp_path):
    bad = tmp_path / "car.toml"
    bad.write_text(TABLE1 + "[tuning.pif-modified]\nq = 3.0\n")
    r = CliRunner().invoke(main, ["campaign", "-n", "1", "-o", str(tmp_path / "c"), "--vehicle", str(bad)])
    assert r.exit_code == 2 and "[tuning.pif-modified] q: unknown option" in r.output


COMMA = ROOT / ".." / "shared" / "data" / "comma2k19-example"


@pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 example segment absent at {COMMA}")
def test_validate_designs_for_the_vehicle(tmp_path):
    """validate comma2k19 --vehicle: the car's params and tuning; without it the car for a log whose car
    is not described (roadbank.vehicle.undescribed_params, as every command)."""
    import json

    from roadbank.validation import validate_comma2k19
    from roadbank.vehicle import undescribed_params

    car = load_vehicle("van").with_tuning("dfc", {"a_ref": 1.5})
    path = tmp_path / "car.toml"
    car.to_toml(path)
    args = ["validate", "comma2k19", str(COMMA), "--json", "--no-sensitivity", "-e", "dfc"]
    with_car = json.loads(CliRunner().invoke(main, args + ["--vehicle", str(path)]).stdout)
    default = json.loads(CliRunner().invoke(main, args).stdout)
    lib = validate_comma2k19(COMMA, names=["dfc"], params=car.params, tuning=car.tuning, sensitivity=False)
    assert with_car["dfc"]["rms_deg"] == pytest.approx(lib.scores["dfc"].rms_deg, abs=6e-5)  # JSON: 4 decimals
    sedan = validate_comma2k19(COMMA, names=["dfc"], params=undescribed_params(), sensitivity=False)
    assert default["dfc"]["rms_deg"] == pytest.approx(sedan.scores["dfc"].rms_deg, abs=6e-5)
    assert abs(lib.scores["dfc"].rms_deg - sedan.scores["dfc"].rms_deg) > 1e-3


def test_design_failure_in_a_file_names_the_file(tmp_path):
    path = tmp_path / "car.toml"
    path.write_text(TABLE1 + "[tuning.pif-modified]\nvariant = \"exact\"\n")
    r = CliRunner().invoke(main, ["simulate", "const-bank", "-o", str(tmp_path / "o.csv"), "--vehicle", str(path)])
    assert r.exit_code == 2
    assert f"{path}: [tuning.pif-modified] {{variant = \"exact\"}}: " in r.output


def test_numpy_values_from_the_tools_are_written_as_toml():
    v = load_vehicle(None).with_tuning("kalman", {"R": np.array([0.01, 2.5e-5]), "q": (1.0, 2.0, 3.0)},
                                       scores={"rms": np.float64(0.25), "n": np.int64(3)})
    assert v.tuning["kalman"] == {"R": [0.01, 2.5e-5], "q": [1.0, 2.0, 3.0]}
    back = Vehicle.loads(v.dumps())
    assert back == v and type(back.scores["kalman"]["n"]) is int


@pytest.mark.parametrize("name, scenario, condition", [("compact", "track-lane-change", "cf150"),
                                                       ("van", "bank-lane-change", "low-mu")])
def test_shipped_cars_stay_in_control_in_the_hardest_paper_cells(name, scenario, condition):
    """The simulator's driver keeps every shipped car on its path in the paper's cells (these two
    spun a neutral or 3 deg/g car): sideslip stays small, speed near the target."""
    sim = load_vehicle(name).simulate(scenario, condition)
    tr = sim.truth
    assert np.degrees(np.abs(np.arctan2(tr.vy, tr.vx))).max() < 4.0
    assert tr.vx.min() > 0.9 * sim.signals.vx[0]
