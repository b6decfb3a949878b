"""One place per concept: the vehicle package's modules, the one units table, the one gravity constant,
the one road-wheel angle and the one sensor-noise rule."""

from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import numpy as np
import pytest

import roadbank
from roadbank import constants, units
from roadbank.vehicle import SensorSpec, VehicleFileError, make_estimator, noise_densities, parse_quantity

SRC = Path(__file__).resolve().parents[1] / "src" / "roadbank"


def _relative_imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    return {n.module.split(".")[0] for n in ast.walk(tree)
            if isinstance(n, ast.ImportFrom) and n.level == 1 and n.module}


def test_the_vehicle_modules_import_one_way():
    """Each module of roadbank.vehicle imports only modules listed before it: no circle, and a reader
    can take them in this order."""
    order = ["errors", "tomltext", "sensors", "plausibility", "conditions", "file", "factory", "__init__"]
    found = sorted(p.stem for p in (SRC / "vehicle").glob("*.py"))
    assert sorted(order) == found
    for k, name in enumerate(order):
        later = _relative_imports(SRC / "vehicle" / f"{name}.py") - set(order[:k])
        assert not later, f"vehicle/{name}.py imports {sorted(later)}, which come after it"


def test_the_package_keeps_every_name_the_module_had():
    import roadbank.vehicle as v

    for name in ("Vehicle", "SensorSpec", "VehicleFileError", "load_vehicle", "builtin_names", "BUILTINS", "UNITS",
                 "PLAUSIBLE", "parse_quantity", "SI_UNIT", "SENSOR_FIELDS", "PLANT_FIELDS", "WHEELBASE_RANGE",
                 "TABLES", "META_KEYS", "REQUIRED_VEHICLE_KEYS", "OFFSET_CHANNELS", "DEFAULT_VEHICLE",
                 "DESIGN_SPAN_S", "log_conditions", "make_estimator", "for_conditions", "for_log",
                 "undescribed_params"):
        assert hasattr(v, name), name
    assert set(v.__all__) <= set(dir(v))


# ---- one gravity constant ---------------------------------------------------------------------

_GRAVITY_LITERAL = re.compile(r"(?<![\d.])9\.8(?:1|0665)(?!\d)")


def test_gravity_is_written_once_in_the_source():
    """No module but roadbank/constants.py writes gravity as a number (comments and docstrings aside)."""
    offenders = []
    for path in SRC.rglob("*.py"):
        if path.name == "constants.py" and path.parent == SRC:
            continue
        tree = ast.parse(path.read_text())
        docs = {id(n.body[0].value) for n in ast.walk(tree)
                if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef)) and n.body
                and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value in (9.81, 9.80665):
                offenders.append(f"{path.relative_to(SRC)}:{node.lineno}")
            elif (isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs
                  and _GRAVITY_LITERAL.search(node.value)):
                offenders.append(f"{path.relative_to(SRC)}:{node.lineno} (text)")
    assert not offenders, offenders


def test_every_user_of_gravity_reads_the_one_constant():
    from roadbank import params
    from roadbank.io import units as io_units
    from roadbank.sim.sensors import SensorConfig

    G = constants.G
    assert roadbank.G is G and params.G is G and io_units.G_UNIT is G
    assert params.VehicleParams().g == G
    assert units.UNITS["acceleration"]["g"] == G and units.FACTORS["acceleration"]["g"] == G
    assert SensorSpec().ay_range == 1.8 * G and SensorConfig().ay.range == 1.8 * G
    assert parse_quantity("1 g", "acceleration") == G


# ---- one set of sensor defaults ---------------------------------------------------------------

def test_the_paper_sensors_are_the_default_of_a_car_and_of_the_simulator():
    """The paper's ESP cluster: 100 Hz; yaw rate 0.1 deg/s noise, 0.3 deg/s steps, +-100 deg/s;
    lateral acceleration 0.03 m/s^2 noise, 0.005 g steps, +-1.8 g; speed 0.02 m/s noise, 0.01 m/s
    steps; steering-wheel angle 0.1 deg steps, +-780 deg."""
    from roadbank.sim.sensors import SensorConfig

    g, deg = 9.81, math.pi / 180.0
    car, sim = SensorSpec(), SensorConfig()
    paper = {"rate": 100.0, "r_noise": 0.1 * deg, "r_resolution": 0.3 * deg, "r_range": 100.0 * deg,
             "ay_noise": 0.03, "ay_resolution": 0.005 * g, "ay_range": 1.8 * g, "speed_noise": 0.02,
             "speed_resolution": 0.01, "steering_noise": 0.0, "steering_resolution": 0.1 * deg,
             "steering_range": 780.0 * deg}
    for name, value in paper.items():
        assert getattr(car, name) == pytest.approx(value, rel=1e-15), name
    assert car.to_sim() == sim


def test_the_sensor_defaults_are_written_once():
    """Neither SensorSpec nor the simulator's SensorConfig writes a default number of its own but 0:
    both read roadbank.params' ESP_* (where the paper's numbers are)."""
    offenders = []
    for rel, cls in (("vehicle/sensors.py", "SensorSpec"), ("sim/sensors.py", "SensorConfig")):
        tree = ast.parse((SRC / rel).read_text())
        (node,) = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == cls]
        for field in node.body:
            if isinstance(field, ast.AnnAssign) and field.value is not None:
                offenders += [f"{rel}:{c.lineno} {c.value}" for c in ast.walk(field.value)
                              if isinstance(c, ast.Constant) and isinstance(c.value, float) and c.value != 0.0]
    assert not offenders, offenders


# ---- one units table --------------------------------------------------------------------------

def test_a_channel_maps_units_are_the_vehicle_files_units():
    """Every unit a channel map may declare is in the one table, with the same factor to SI and SI unit."""
    for kind, table in units.FACTORS.items():
        dim = units.dimension_of_kind(kind)
        assert units.CHANNEL_SI_UNIT[kind] == units.SI_UNIT[dim]
        for unit, f in table.items():
            assert parse_quantity(f"2 {unit}", dim) == pytest.approx(2.0 * f, rel=1e-15), (kind, unit)
            assert units.factor(kind, unit.upper() if unit != "g" else unit) == f


@pytest.mark.parametrize("text, dimension, si", [
    ("20 us", "time", 2e-5), ("5 ns", "time", 5e-9), ("60 mph", "speed", 60 * 1609.344 / 3600),
    ("100 kph", "speed", 100 / 3.6), ("0.002 km", "length", 2.0),
])
def test_a_vehicle_file_reads_every_unit_of_the_table(text, dimension, si):
    assert parse_quantity(text, dimension) == pytest.approx(si, rel=1e-12)


def test_a_unit_of_another_kind_is_still_an_error():
    from roadbank.vehicle import Vehicle

    with pytest.raises(VehicleFileError, match=r"\[sensors\] latency = \"20 mph\": unit 'mph' is a speed"):
        Vehicle.loads("[vehicle]\nm = 1687.0\nIz = 3401.0\nLf = 1.15\nLr = 1.47\nCf = 115000.0\nCr = 396820.0\n"
                      '[sensors]\nlatency = "20 mph"\n')
    with pytest.raises(ValueError, match=r"unit 'mg' is not a acceleration unit"):
        units.factor("acceleration", "mg")          # a channel map's kinds keep their own short lists


# ---- one road-wheel angle, two error models told apart ------------------------------------------

def test_the_log_readers_use_the_one_road_wheel_angle():
    """One function turns a steering-wheel angle into the road-wheel angle, and the log readers call it."""
    defs = [f"{p.relative_to(SRC)}" for p in SRC.rglob("*.py")
            if re.search(r"^\s*def road_wheel_angle\b", p.read_text(), re.M)]
    assert defs == ["signals.py"]
    users = [p.name for p in (SRC / "io").glob("*.py")
             if any(isinstance(n, ast.ImportFrom) and n.module == "signals" and n.level == 2
                    and "road_wheel_angle" in {a.name for a in n.names} for n in ast.walk(ast.parse(p.read_text())))]
    assert users, "no io module takes road_wheel_angle from roadbank.signals"


def test_a_channel_maps_steering_ratio_must_be_a_finite_number(tmp_path):
    """The map's ratio reaches :func:`roadbank.signals.road_wheel_angle` through a car's parameters:
    an infinite one is the map's error, not a road-wheel angle of 0."""
    from roadbank.io import LogError, read_channel_map

    p = tmp_path / "m.toml"
    p.write_text('steering_ratio = inf\n[channels]\ntime = { column = "t", unit = "s" }\n'
                 'speed = { column = "vx", unit = "m/s" }\n'
                 'lateral_acceleration = { column = "ay", unit = "m/s^2" }\n'
                 'yaw_rate = { column = "r", unit = "rad/s" }\n'
                 'steering_wheel_angle = { column = "swa", unit = "deg" }\n')
    with pytest.raises(LogError, match=r"m\.toml: steering_ratio must be a finite number > 0, got inf"):
        read_channel_map(p)


def test_the_simulators_channel_error_model_has_its_own_name():
    from roadbank.io import ChannelSpec as MapEntry
    from roadbank.sim import ChannelErrorModel, ChannelSpec

    assert ChannelSpec is ChannelErrorModel and MapEntry is not ChannelErrorModel
    cfg = SensorSpec().to_sim()
    assert isinstance(cfg.yaw_rate, ChannelErrorModel) and cfg.yaw_rate.resolution == math.radians(0.3)


# ---- one sensor-noise rule ---------------------------------------------------------------------

def test_noise_densities_are_the_sensor_at_the_log_rate_or_the_louder_log():
    car = SensorSpec(r_noise=math.radians(0.2), r_resolution=math.radians(0.1), ay_noise=0.05, ay_resolution=0.01)
    r_var = math.radians(0.2) ** 2 + math.radians(0.1) ** 2 / 12.0
    ay_var = 0.05 ** 2 + 0.01 ** 2 / 12.0
    R, Q_ay = noise_densities(car, 20.0)
    assert R == pytest.approx(r_var / 20.0, rel=1e-14) and Q_ay == pytest.approx(ay_var / 20.0, rel=1e-14)
    assert noise_densities(car) == pytest.approx((r_var / 100.0, ay_var / 100.0), rel=1e-14)  # the sensor's rate
    assert noise_densities(car, float("nan")) == noise_densities(car)
    quiet = noise_densities(car, 20.0, log_ay_noise=0.01, log_r_noise=1e-4)
    assert quiet == (R, Q_ay)
    loud = noise_densities(car, 20.0, log_ay_noise=0.4, log_r_noise=0.01)
    assert loud == pytest.approx((0.01 ** 2 / 20.0, 0.4 ** 2 / 20.0), rel=1e-14)
    assert noise_densities(car, 20.0, log_ay_noise=float("nan"), log_r_noise=None) == (R, Q_ay)


def test_make_estimator_designs_with_the_rule():
    car = SensorSpec(r_noise=math.radians(0.2))
    est = make_estimator("pif-modified", sensors=car, log_rate=20.0, log_ay_noise=0.4, v_max=30.0)
    R, Q_ay = noise_densities(car, 20.0, log_ay_noise=0.4)
    assert est.R[0, 0] == pytest.approx(R, rel=1e-12) and est.Q_ay == pytest.approx(Q_ay, rel=1e-12)
    assert np.isfinite(est.R).all()


def test_an_oversteering_car_is_refused_naming_its_critical_speed(tmp_path):
    """Cf 1.5 MN/rad with Cr 10 kN/rad, each plausible alone: the linear bicycle model diverges above 6.4 m/s (its
    critical speed, by hand: 2.7 sqrt(1.5e6 1e4 / (1500 (1.2 1.5e6 - 1.5 1e4))) = 6.39 m/s), and simulate drove it
    into a spin as a success. Refused on loading, naming the keys and the speed; the shipped cars understeer."""
    from roadbank.vehicle import VehicleFileError, load_vehicle

    f = tmp_path / "over.toml"
    f.write_text("[vehicle]\nm = 1500\nIz = 2500\nLf = 1.2\nLr = 1.5\nCf = 1500000\nCr = 10000\n")
    with pytest.raises(VehicleFileError, match=r"\[vehicle\] Cf, Cr, Lf, Lr, m: the car oversteers .* unstable above "
                                               r"6\.39 m/s"):
        load_vehicle(f)
    for car in ("suv-paper", "sedan", "compact", "van"):
        v = load_vehicle(car).params
        assert v.Lf * v.Cf < v.Lr * v.Cr, car


def test_a_zero_process_noise_is_named_not_th(tmp_path):
    """[tuning.pif-modified] Q = 0: the Kalman design (th = 0) has no positive definite solution; the message says the
    process noise must be positive definite (before: "lower th", which the user never set and cannot lower)."""
    from roadbank.vehicle import VehicleFileError, load_vehicle

    f = tmp_path / "q0.toml"
    f.write_text("[vehicle]\nm = 1500\nIz = 2500\nLf = 1.2\nLr = 1.5\nCf = 80000\nCr = 100000\n"
                 "[tuning.pif-modified]\nQ = 0\n")
    with pytest.raises((VehicleFileError, ValueError), match=r"W \(Q\) must be positive definite") as err:
        load_vehicle(f).check()
    assert "lower th" not in str(err.value)
