"""``roadbank identify``: recovery of known parameters, honest uncertainties, refusals, the CLI."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.signal import StateSpace as ScipySS
from scipy.signal import lsim

from roadbank import Signals, VehicleParams
from roadbank.cli import main
from roadbank.models import steady_roll_gain
from roadbank.identification import IdentifySettings, identify
from roadbank.identification.check import SimCase, simulate_case
from roadbank.identification.quantisation import mean_bias_bound
from roadbank.sim.drives import DriveSpec
from roadbank.io import Log
from roadbank.io.writers import write_table
from roadbank.sim import Driver, PlantParams, Scenario, SensorConfig, run, straight_road
from roadbank.vehicle import Vehicle, load_vehicle

CROWN = 0.02  # 2 % cross slope on the straights


@pytest.fixture(scope="module")
def drive():
    """~3 min of mixed driving, SUV with plant Cf x1.15 / Cr x0.9 and sensor offsets, crowned straights."""
    case = SimCase(drive=DriveSpec(crown=CROWN), seed=1)
    log, truth = simulate_case(case)
    return case, log, truth


@pytest.fixture(scope="module")
def result(drive):
    case, log, _ = drive
    return identify([log], case.params, IdentifySettings(straight_bank=CROWN))


def test_recovers_stiffness_within_10_percent(drive, result):
    _, _, truth = drive
    q = result.quantities
    for name in ("Cf", "Cr"):
        assert q[name].ok, q[name].refused
        assert abs(q[name].value / truth[name] - 1) < 0.10, (name, q[name].value, truth[name])
    assert abs(q["Kus"].value / truth["Kus"] - 1) < 0.03
    # the base vehicle's design values are far off: the data moved the estimate
    assert abs(q["Cf"].value / drive[0].params.Cf - 1) > 0.10
    assert result.params.Cr == q["Cr"].value


def test_every_quantity_within_its_uncertainty(drive, result):
    """Honest uncertainties: the truth lies within 3 sigma of every identified value (and the
    offsets are recovered to sensor-resolution accuracy)."""
    _, _, truth = drive
    assert set(result.quantities) == {"Cf", "Cr", "Kus", "steering_offset", "yaw_rate_offset", "ay_offset",
                                      "roll_gain"}
    for name, q in result.quantities.items():
        assert q.ok, (name, q.refused)
        assert q.std > 0
        assert abs(q.value - truth[name]) <= 3 * q.std, (name, q.value, truth[name], q.std)
    assert abs(result.quantities["yaw_rate_offset"].value - truth["yaw_rate_offset"]) < math.radians(0.02)
    assert abs(result.quantities["ay_offset"].value - truth["ay_offset"]) < 0.01


def test_the_identified_roll_gain_sets_the_roll_stiffness_of_the_result(drive):
    """A base car whose roll stiffness is twice too high: the roll gain found from the log's roll reference becomes the
    result's k_roll (it was only written to [identified.roll_gain], which nothing reads: the estimates kept the
    base's roll, 1.2 deg RMS against 0.5 on a simulated S-curve)."""
    case, log, truth = drive
    stiff = case.params.replace(k_roll=2.0 * case.params.k_roll)
    res = identify([log], stiff, IdentifySettings(straight_bank=CROWN))
    q = res.quantities["roll_gain"]
    assert q.ok, q.refused
    assert abs(steady_roll_gain(stiff) - truth["roll_gain"]) > 3 * q.std           # the base is far off
    assert steady_roll_gain(res.params) == pytest.approx(q.value, rel=1e-9)
    assert abs(steady_roll_gain(res.params) - truth["roll_gain"]) <= 3 * q.std
    assert (res.params.ms, res.params.h_roll) == (stiff.ms, stiff.h_roll)


def test_sporadic_dropouts_do_not_cut_the_log(drive, result):
    """2 % of the samples lost (NaN, as dropped CAN frames): short gaps are bridged, same result."""
    case, log, truth = drive
    s = log.signals
    lost = np.random.default_rng(5).random(len(s.t)) < 0.02
    holed = Log(signals=Signals(s.t, np.where(lost, np.nan, s.vx), np.where(lost, np.nan, s.ay), s.r, s.delta_f),
                reference_roll=log.reference_roll, source=Path("holed"))
    res = identify([holed], case.params, IdentifySettings(straight_bank=CROWN))
    assert res.logs[0].seconds["usable"] > 0.95 * result.logs[0].seconds["usable"]
    for name in ("Cf", "Cr", "Kus"):
        q0, q1 = result.quantities[name], res.quantities[name]
        assert abs(q1.value - q0.value) < q0.std, name


def test_without_straights_the_yaw_offset_comes_from_the_speed_spread(drive):
    """No straight accepted: the yaw-rate offset is the coefficient of L/vx (speeds 19-29 m/s here);
    the steering offset, mixed with the ay offset in the constant, is refused."""
    case, log, truth = drive
    res = identify([log], case.params, IdentifySettings(straight_bank=CROWN, min_straight=1e6))
    q = res.quantities
    assert q["yaw_rate_offset"].ok, q["yaw_rate_offset"].refused
    assert abs(q["yaw_rate_offset"].value - truth["yaw_rate_offset"]) <= 3 * q["yaw_rate_offset"].std
    assert q["yaw_rate_offset"].std < math.radians(0.05)
    assert not q["steering_offset"].ok and not q["ay_offset"].ok
    assert abs(q["Cr"].value / truth["Cr"] - 1) < 0.10


def test_one_speed_without_straights_refuses_the_yaw_offset():
    case = SimCase(drive=DriveSpec(n_corners=4, speeds=(20.0, 20.0)), seed=3, with_roll=False)
    log, _ = simulate_case(case)
    q = identify([log], case.params, IdentifySettings(min_straight=1e6)).quantities
    assert not q["yaw_rate_offset"].ok
    assert "speed spread" in q["yaw_rate_offset"].refused
    assert q["Kus"].ok  # the understeer gradient needs no speed spread


def test_wrong_bank_assumption_shows_up_in_the_ay_offset(drive, result):
    """The ay offset is relative to the assumed mean bank of the straights: assuming flat roads
    moves it by about g sin(crown) (1 + g k_roll)."""
    case, log, _ = drive
    flat = identify([log], case.params, IdentifySettings(straight_bank=0.0))
    shift = flat.quantities["ay_offset"].value - result.quantities["ay_offset"].value
    p = case.params
    assert shift == pytest.approx(p.g * math.sin(CROWN) * (1.0 + p.g * steady_roll_gain(p)), rel=0.02)


@pytest.mark.parametrize("car, scales", [("compact", (0.85, 1.10)), ("van", (1.15, 0.90))])
def test_other_cars(car, scales):
    """Shipped cars with plant tyres off their vehicle file: Cr within 10 %, Cf and Kus within 2 sigma."""
    v = load_vehicle(car)
    case = SimCase(name=car, params=v.params, sensors=v.sensors.to_sim(), scale_front=scales[0],
                   scale_rear=scales[1], seed=2, drive=DriveSpec(n_corners=6), with_roll=False)
    log, truth = simulate_case(case)
    q = identify([log], v.params).quantities
    assert abs(q["Cr"].value / truth["Cr"] - 1) < 0.10
    for name in ("Cf", "Kus"):
        assert abs(q[name].value - truth[name]) <= 2 * q[name].std, (name, q[name].value, truth[name])


def _linear_log(p: VehicleParams, vx=20.0, T=150.0, fs=100.0, seed=3):
    """Original bicycle model (SPEC 3.1, written out here, scipy lsim) driven by held steering steps."""
    m, Iz, Lf, Lr, Cf, Cr = p.m, p.Iz, p.Lf, p.Lr, p.Cf, p.Cr
    A = np.array([[-(Cf + Cr) / (m * vx), -vx - (Lf * Cf - Lr * Cr) / (m * vx)],
                  [-(Lf * Cf - Lr * Cr) / (Iz * vx), -(Lf**2 * Cf + Lr**2 * Cr) / (Iz * vx)]])
    B = np.array([[Cf / m], [Lf * Cf / Iz]])
    C = np.array([[-(Cf + Cr) / (m * vx), -(Lf * Cf - Lr * Cr) / (m * vx)], [0.0, 1.0]])
    D = np.array([[Cf / m], [0.0]])
    t = np.arange(0.0, T, 1.0 / fs)
    rng = np.random.default_rng(seed)
    levels = rng.choice([-0.02, -0.012, 0.0, 0.0, 0.012, 0.02], size=int(T / 6) + 1)
    steps = levels[(t // 6).astype(int)]
    delta = np.convolve(steps, np.ones(50) / 50, mode="same")  # 0.5 s ramps
    _, y, _ = lsim(ScipySS(A, B, C, D), delta, t)
    return Log(signals=Signals(t, np.full_like(t, vx), y[:, 0], y[:, 1], delta), source=Path("linear"))


def test_linear_bicycle_model_is_recovered_exactly():
    p = VehicleParams(h_roll=0.0)  # no body roll: the accelerometer reads the tyre forces
    res = identify([_linear_log(p)], p)
    q = res.quantities
    assert q["Cf"].value == pytest.approx(p.Cf, rel=5e-3)
    assert q["Cr"].value == pytest.approx(p.Cr, rel=5e-3)
    kus = p.m / p.L * (p.Lr / p.Cf - p.Lf / p.Cr)
    assert q["Kus"].value == pytest.approx(kus, rel=2e-3)


@pytest.fixture(scope="module")
def straight_log():
    res = run(Scenario("straight", straight_road(), Driver(speed=25.0, path=((0.0,), (0.0,))), 40.0), seed=2)
    return res


def test_straight_only_refuses_stiffness_but_gives_offsets(straight_log):
    res = identify([Log(signals=straight_log.signals, source=Path("straight"))])
    for name in ("Cf", "Cr", "Kus"):
        assert not res.quantities[name].ok
        assert "quasi-steady corners" in res.quantities[name].refused
        assert res.quantities[name].value is None
    assert res.quantities["yaw_rate_offset"].ok and res.quantities["ay_offset"].ok
    assert not res.complete


def test_too_slow_log_is_not_used_and_others_are(drive):
    case, log, truth = drive
    n = 3000
    t = np.arange(n) * 0.01
    slow = Log(signals=Signals(t, np.full(n, 4.0), np.zeros(n), np.zeros(n), np.zeros(n)), source=Path("slow"))
    res = identify([slow, log], case.params, IdentifySettings(straight_bank=CROWN))
    assert not res.logs[0].used and "too slow" in res.logs[0].problem
    assert res.logs[1].used
    assert abs(res.quantities["Cr"].value / truth["Cr"] - 1) < 0.10


def test_quantisation_bias_bound_holds():
    """Widrow's bound on the mean error of a quantised constant (with and without dither noise)."""
    q, rng = 0.1, np.random.default_rng(0)
    for sigma in (0.0, 0.02, 0.04):
        worst = 0.0
        for x in np.linspace(0.0, q, 21):
            y = q * np.round((x + sigma * rng.standard_normal(200_000)) / q)
            worst = max(worst, abs(y.mean() - x))
        parts = [q * np.round((0.37 * q + sigma * rng.standard_normal(5000)) / q)]
        bound = mean_bias_bound(parts, q)
        assert worst <= bound * 1.1 + 3 * sigma / math.sqrt(200_000), (sigma, worst, bound)


def test_cli_writes_vehicle_file_and_reports_bad_logs(tmp_path, drive, straight_log):
    _, log, truth = drive
    good = tmp_path / "drive.parquet"
    s = log.signals
    write_table(good, {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}, {})
    slow = tmp_path / "slow.csv"
    n = 3000
    write_table(slow, {"t": np.arange(n) * 0.01, "vx": np.full(n, 3.0), "ay": np.zeros(n), "r": np.zeros(n),
                       "delta_f": np.zeros(n)}, {})
    out = tmp_path / "car.toml"
    res = CliRunner().invoke(main, ["identify", str(good), str(slow), str(tmp_path / "missing.csv"),
                                    "--straight-bank", str(math.degrees(CROWN)), "-o", str(out)])
    assert res.exit_code == 1, res.output  # one log missing, one too slow
    assert "Traceback" not in res.output
    assert "missing.csv" in res.output and "too slow" in res.output
    car = Vehicle.from_toml(out)
    assert car.params.Cr == pytest.approx(car.identified["Cr"]["value"])
    assert abs(car.identified["Cr"]["value"] / truth["Cr"] - 1) < 0.10
    assert car.identified["Cr"]["std"] > 0 and car.identified["Cr"]["unit"] == "N/rad"
    assert car.rear_measured        # used as measured: never trimmed to a log (docs/vehicles.md)


def test_cli_straight_only_refuses_and_exits_nonzero(tmp_path, straight_log):
    p = tmp_path / "straight.csv"
    write_table(p, straight_log.table(), {})
    res = CliRunner().invoke(main, ["identify", str(p), "-o", str(tmp_path / "car.toml")])
    assert res.exit_code == 1
    assert "REFUSED" in res.output and "quasi-steady corners" in res.output
    assert "Traceback" not in res.output


def test_cli_only_unusable_logs_writes_nothing(tmp_path):
    p = tmp_path / "slow.csv"
    n = 3000
    write_table(p, {"t": np.arange(n) * 0.01, "vx": np.full(n, 3.0), "ay": np.zeros(n), "r": np.zeros(n),
                    "delta_f": np.zeros(n)}, {})
    out = tmp_path / "car.toml"
    res = CliRunner().invoke(main, ["identify", str(p), "-o", str(out)])
    assert res.exit_code == 1 and not out.exists()
    assert "too slow" in res.output and "Traceback" not in res.output


COMMA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "comma2k19-example"


@pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 example segment absent at {COMMA}")
def test_comma2k19_near_straight_highway_refuses_stiffness():
    """One minute of near-straight highway: the stiffnesses are refused (no corners), the offsets are
    read from the straights with small uncertainties."""
    from roadbank.io import load_log

    res = identify([load_log(COMMA)])
    q = res.quantities
    for name in ("Cf", "Cr", "Kus"):
        assert "quasi-steady corners" in q[name].refused
    assert q["yaw_rate_offset"].ok and q["yaw_rate_offset"].std < math.radians(0.05)
    assert q["ay_offset"].ok and q["ay_offset"].std < 0.05
    assert not q["roll_gain"].ok  # a roll reference is there, but no cornering


def test_the_vehicle_file_knows_every_quantity_identify_writes():
    from roadbank.identification.identify import ORDER
    from roadbank.vehicle.plausibility import IDENTIFIED_OFFSETS, IDENTIFIED_QUANTITIES

    assert ORDER == IDENTIFIED_QUANTITIES
    assert set(IDENTIFIED_OFFSETS) <= set(ORDER)


def test_a_copy_of_a_log_adds_no_evidence(drive, result):
    """The same samples under another name are not used again (four copies of a one-corner log had passed the
    three-corner minimum and shrunk every uncertainty by about 2)."""
    case, log, _ = drive
    copy = Log(signals=log.signals, reference_roll=log.reference_roll, source=Path("copy.parquet"))
    res = identify([log, copy], case.params, IdentifySettings(straight_bank=CROWN))
    assert [r.used for r in res.logs] == [True, False]
    assert "the same samples as" in res.logs[1].problem
    for name, q in result.quantities.items():
        assert res.quantities[name].value == q.value and res.quantities[name].std == q.std, name


NOISY_GYRO = math.radians(0.7)  # white yaw-rate noise (rad/s std at 100 Hz) that once broke every corner


def _yaw_noise(std: float) -> SensorConfig:
    """The default ESP cluster (100 Hz) with ``std`` (rad/s) of white noise on the yaw rate."""
    sens = SensorConfig()
    return sens.replace(yaw_rate=dataclasses.replace(sens.yaw_rate, noise_std=std))


def _corners(log: Log) -> int:
    """The quasi-steady corners ``identify`` reports for ``log`` (few bootstrap replicates: only the count)."""
    return identify([log], settings=IdentifySettings(n_boot=20)).logs[0].n_corners


def test_a_noisy_yaw_rate_finds_the_same_corners():
    """The simulator drives 10 constant-radius corners; a gyro with 0.7 deg/s of white noise (the count read 0
    with the yaw acceleration of the 2 Hz low-pass, whose noise is near the 0.02 rad/s^2 steadiness limit) sees
    the same 10 as the ESP gyro."""
    quiet, _ = simulate_case(SimCase(drive=DriveSpec(n_corners=10), seed=1, with_roll=False))
    noisy, _ = simulate_case(SimCase(drive=DriveSpec(n_corners=10), seed=1, with_roll=False,
                                     sensors=_yaw_noise(NOISY_GYRO)))
    assert np.std(noisy.signals.r - quiet.signals.r) > 0.8 * NOISY_GYRO  # the noise is there
    assert _corners(quiet) == _corners(noisy) == 10


def test_a_noisy_yaw_rate_on_a_straight_makes_no_corner():
    res = run(Scenario("straight", straight_road(), Driver(speed=25.0, path=((0.0,), (0.0,))), 90.0),
              sensors=_yaw_noise(NOISY_GYRO), seed=4)
    assert _corners(Log(signals=res.signals, source=Path("straight"))) == 0


@pytest.mark.parametrize("front_scale", [0.6, 1.0])
def test_straight_steering_offset_covers_the_base_cars_understeer(front_scale):
    """On crowned straights alone the steering offset is the mean angle less the base car's ``Kus g sin(bank)``:
    a base car whose Kus is not the plant's (front tyres at 0.6 of the file's) moved it by 0.062 deg road wheel
    with a stated sigma of 0.00005 (and by 0.0005 with the right car: 9 sigma); the term's size (0.072 deg) is now
    in the uncertainty, so the injected offset (3 deg at the steering wheel) is within 3 sigma either way."""
    crown = math.atan(0.02)
    sens = SensorConfig()
    sens = sens.replace(steering=dataclasses.replace(sens.steering, noise_std=math.radians(0.05),
                                                     bias=math.radians(3.0)))
    plant = PlantParams(vehicle=VehicleParams(), cornering_scale_front=front_scale)
    res = run(Scenario("crowned", straight_road(bank=crown), Driver(speed=25.0, path=((0.0,), (0.0,))), 60.0),
              plant=plant, sensors=sens, seed=4)
    q = identify([Log(signals=res.signals, source=Path("crowned"))], VehicleParams(),
                 IdentifySettings(straight_bank=crown)).quantities["steering_offset"]
    true = math.radians(3.0) / VehicleParams().steering_ratio
    assert q.ok and abs(q.value - true) < 3 * q.std, (math.degrees(q.value), math.degrees(q.std), math.degrees(true))
