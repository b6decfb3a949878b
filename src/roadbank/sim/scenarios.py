"""The paper's simulation scenarios, conditions, and the run API.

``run_scenario(name, condition="nominal", seed=0)`` runs one of :data:`SCENARIOS`
under one of :data:`CONDITIONS`; :func:`run` runs any :class:`Scenario` (a road,
a driver, a duration and a start) with any plant and sensor configuration.

Every run starts in steady state: the initial state is a linear trim for the
start position (speed, bank, curvature), then ``pre_roll`` seconds (5 s) are
simulated on the approach to the start and discarded, so t = 0 has no start-up
transient.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..params import VehicleParams
from ..signals import Signals
from .driver import D_LATINT, D_SWA, D_VINT, ND, Driver
from .drives import identification_drive
from .integrate import outputs_at, simulate
from .params import PlantParams
from .plant import (A_AX, A_AY, A_DVY, A_FXW, A_FYW, A_FZW, NX, X_DPHI, X_FXL, X_FYL, X_N, X_OMEGA, X_PHI, X_PSI, X_R,
                    X_S, X_VX, X_VY)
from .road import Road, flat_road, straight_road, test_track, track_curve_start, truth_banks, two_lane_road
from .scenario import Scenario
from .sensors import SensorConfig, measure

DT_DEFAULT = 2e-3  #: longest integration step (s): RK4 at 500 Hz (see :func:`default_step`)
DRIVER_DT = 2e-3  #: the driver's sample time (s); it is a discrete controller, independent of the step


def default_step(sensors: SensorConfig) -> float:
    """Integration step (s) for the sensors: the longest step <= :data:`DT_DEFAULT` that divides
    the sensor period and the latency, so every sample and its delay fall on the integration grid
    (2 ms at 100 Hz, 1 ms at 1 kHz, 5/3 ms at 100 Hz with a 15 ms latency). Where no step down to
    0.1 ms divides both, the step divides the period and the latency is rounded to it.
    """
    period = 1.0 / sensors.rate
    first = math.ceil(period / DT_DEFAULT - 1e-9)
    for k in range(first, max(first, math.ceil(period / 1e-4)) + 1):
        h = period / k
        if abs(sensors.latency / h - round(sensors.latency / h)) < 1e-6:
            return h
    return period / first


def driver_every(dt: float) -> int:
    """Integration steps (of ``dt`` s) per driver update: the multiple closest to :data:`DRIVER_DT`, >= 1."""
    return max(1, int(round(DRIVER_DT / dt)))


@dataclass(frozen=True)
class Condition:
    """A variation of plant and sensors: friction, front tyre stiffness scale, ay misalignment."""

    name: str
    mu: float = 0.85
    cornering_scale_front: float = 1.0
    ay_misalignment: float = 0.0
    description: str = ""

    def apply(self, plant: PlantParams, sensors: SensorConfig) -> tuple[PlantParams, SensorConfig]:
        return (plant.replace(mu=self.mu, cornering_scale_front=self.cornering_scale_front),
                sensors.replace(ay_misalignment=self.ay_misalignment))


CONDITIONS: dict[str, Condition] = {
    "nominal": Condition("nominal", description="mu 0.85, Cf = Cf_ss, aligned sensors"),
    "low-mu": Condition("low-mu", mu=0.3, description="mu 0.3"),
    "misaligned": Condition("misaligned", ay_misalignment=math.radians(10.0),
                            description="accelerometer reads ay_real cos(10 deg)"),
    "cf120": Condition("cf120", cornering_scale_front=1.2, description="plant Cf = 1.2 Cf_ss"),
    "cf50": Condition("cf50", cornering_scale_front=0.5, description="plant Cf = 0.5 Cf_ss"),
    "cf150": Condition("cf150", cornering_scale_front=1.5, description="plant Cf = 1.5 Cf_ss"),
}

#: Conditions the paper runs per scenario (docs/simulator.md); run_scenario accepts any.
CONDITIONS_BY_SCENARIO: dict[str, tuple[str, ...]] = {
    "const-bank": ("nominal", "low-mu", "misaligned", "cf120"),
    "bank-lane-change": ("nominal", "low-mu", "misaligned", "cf120"),
    "s-curve": ("nominal", "low-mu", "cf50", "cf150"),
    "track-lane1": ("nominal", "cf120"),
    "track-lane-change": ("nominal", "cf50", "cf150"),
}


def _kmh(v):
    return v / 3.6


def _build_scenarios() -> dict[str, Scenario]:
    sc = {}
    sc["const-bank"] = Scenario(
        "const-bank", straight_road(math.atan(0.30), name="bank-30pct"),
        Driver(speed=_kmh(80.0), path=((0.0,), (0.0,))), 15.0,
        description="Fig 2: straight road banked 30 % (16.7 deg), 80 km/h, lane keeping, 15 s")
    two = two_lane_road(bank_left=math.atan(0.25), bank_right=0.0)
    nr, nl = two.lanes["right"], two.lanes["left"]
    sc["bank-lane-change"] = Scenario(
        "bank-lane-change", two,
        Driver(speed=_kmh(80.0), path=((50.0, 100.0, 190.0, 240.0), (nr, nl, nl, nr))), 15.0,
        start_n=nr,
        description="Fig 3: straight two-lane road, right lane flat, left lane 25 % (14 deg); "
                    "80 km/h, flat -> banked -> flat lane changes, 15 s")
    swa = np.radians([0.0, 0.0, 360.0, 360.0, -360.0, -360.0, 0.0, 0.0])
    sc["s-curve"] = Scenario(
        "s-curve", flat_road(),
        Driver(speed=_kmh(60.0), steering=((0.0, 2.0, 4.0, 8.0, 11.0, 15.0, 17.0, 25.0), swa)), 25.0,
        description="Fig 4: flat road, open-loop S-curve, steering wheel +-360 deg, 60 km/h, 25 s")
    track = test_track()
    s0 = track_curve_start(track) + 220.0
    sc["track-lane1"] = Scenario(
        "track-lane1", track, Driver(speed=_kmh(143.0), path=((0.0,), (track.lanes["lane1"],))), 15.0,
        start_s=s0, start_n=track.lanes["lane1"],
        description="Fig 6: banked curve of the high-speed track, lane 1 (10 deg), 143 km/h, 15 s")
    l2, l3 = track.lanes["lane2"], track.lanes["lane3"]
    knots_s = s0 + np.array([100.0, 180.0, 330.0, 410.0, 560.0, 640.0, 790.0, 870.0])
    knots_n = (l2, l3, l3, l2, l2, l3, l3, l2)
    sc["track-lane-change"] = Scenario(
        "track-lane-change", track, Driver(speed=_kmh(140.0), path=(knots_s, knots_n)), 25.0,
        start_s=s0, start_n=l2,
        description="Fig 7: high-speed track, 140 km/h, lane changes between lanes 2 (20 deg) "
                    "and 3 (30 deg) in the banked curve and out onto the straight, 25 s")
    return sc


SCENARIOS: dict[str, Scenario] = _build_scenarios()

#: further drives that :func:`run_scenario` and ``roadbank simulate`` know (not the paper's
#: study): ``identification-drive``, the test-track procedure ``roadbank identify`` needs
#: (:func:`roadbank.sim.drives.identification_drive`)
DRIVES = ("identification-drive",)


def drive_scenario(name: str) -> Scenario:
    """The :class:`Scenario` of one of :data:`DRIVES` (built on each call)."""
    if name == "identification-drive":
        return identification_drive()
    raise ValueError(f"unknown drive {name!r}; known: {', '.join(DRIVES)}")


#: sideslip (deg) beyond which a simulated car has lost control (spun, slid): its drive is reported apart (campaign)
#: or left out (tuning), as no estimator's model holds there
LOST_CONTROL_DEG = 10.0


@dataclass
class Truth:
    """True quantities on the sensor time base (SI; angles rad).

    Attributes: ``t, phi_b`` (contact-height bank), ``phi`` (body roll relative
    to the road), ``theta = phi_b + phi``, ``vy, dvy_dt, r, ay_true`` (specific
    force at the accelerometer), ``ax_true, vx, steering_wheel_angle, throttle,
    brake, s, n, psi``, ``Fz, Fx, Fy`` (N, shape (n, 4): FL, FR, RL, RR; Fx, Fy in
    the wheel frames) and the run's ``scenario, condition, seed, plant``.
    """

    t: np.ndarray
    phi_b: np.ndarray
    phi: np.ndarray
    theta: np.ndarray
    vy: np.ndarray
    dvy_dt: np.ndarray
    r: np.ndarray
    ay_true: np.ndarray
    ax_true: np.ndarray
    vx: np.ndarray
    steering_wheel_angle: np.ndarray
    throttle: np.ndarray
    brake: np.ndarray
    s: np.ndarray
    n: np.ndarray
    psi: np.ndarray
    Fz: np.ndarray
    Fx: np.ndarray
    Fy: np.ndarray
    scenario: str = ""
    condition: str = ""
    seed: int = 0
    plant: PlantParams | None = None

    def max_sideslip_deg(self, start: int = 0) -> float:
        """Largest sideslip angle ``|atan2(vy, |vx|)|`` (deg) from sample ``start`` on (NaN where none); above
        :data:`LOST_CONTROL_DEG` the car has lost control, which no estimator's model describes."""
        with np.errstate(all="ignore"):
            beta = np.degrees(np.abs(np.arctan2(self.vy[start:], np.abs(self.vx[start:]))))
        return float(np.nanmax(beta)) if np.isfinite(beta).any() else math.nan


@dataclass
class SimResult:
    """Result of a run: sensor ``signals`` (a :class:`roadbank.Signals`) and ``truth``.

    ``steering_wheel_angle`` is the measured steering-wheel angle (rad) the
    signals' ``delta_f`` was derived from. ``raw`` holds the states at the integration step and
    inputs after the pre-roll (``t``, ``X`` (n, 18), ``U`` (n, 3)).
    """

    signals: Signals
    steering_wheel_angle: np.ndarray
    truth: Truth
    scenario: str
    condition: str
    seed: int
    plant: PlantParams
    sensors: SensorConfig
    raw: dict = field(default_factory=dict, repr=False)

    #: file columns in order (see :meth:`table`)
    COLUMNS = ("t", "vx", "ay", "r", "delta_f", "steering_wheel_angle", "true_phi_b", "true_phi",
               "true_theta", "true_vy", "true_dvy_dt", "true_r", "true_ay", "true_vx")

    def table(self) -> dict[str, np.ndarray]:
        """Columns of the file format written by ``roadbank simulate`` (SI)."""
        s, tr = self.signals, self.truth
        return {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f,
                "steering_wheel_angle": self.steering_wheel_angle,
                "true_phi_b": tr.phi_b, "true_phi": tr.phi, "true_theta": tr.theta, "true_vy": tr.vy,
                "true_dvy_dt": tr.dvy_dt, "true_r": tr.r, "true_ay": tr.ay_true, "true_vx": tr.vx}


# ---- initial trim ------------------------------------------------------------------------

def trim_state(road: Road, plant: PlantParams, driver: Driver, s: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear steady-state estimate of plant and driver state at ``(s, n)`` and the driver's start speed.

    Lane following at constant speed: ``r = vx kappa_lane``; the axle forces that
    balance ``m (vx r + g sin(bank))`` and the yaw moment give the slip angles
    through the plant's axle stiffnesses; roll from the steady roll equation.
    """
    v: VehicleParams = plant.vehicle
    vx = driver.initial_speed()
    kap = float(road.curvature_at(s))
    kap_lane = kap / (1.0 - n * kap)
    bank = float(road.bank(s, n))
    grade = float(road.grade_at(s))
    swa0 = 0.0
    if not driver.closed_loop:
        swa0 = float(driver.steering[1][0])
        kap_lane = 0.0  # open loop: start straight (the profiles start at zero steering)
    r = vx * kap_lane
    fy = vx * r + v.g * math.sin(bank)
    fz = v.g * math.cos(bank) - vx * vx * kap_lane * math.tan(bank)
    cf, cr = plant.axle_cornering_stiffness
    alpha_f = v.m * fy * v.Lr / v.L / cf
    alpha_r = v.m * fy * v.Lf / v.L / cr
    vy = v.Lr * r - alpha_r * vx
    delta = alpha_f + (vy + v.Lf * r) / vx
    h = v.h_roll
    phi = v.ms * h * fy / (v.k_roll - v.ms * h * fz)
    x = np.zeros(NX)
    x[X_S], x[X_N], x[X_VX], x[X_VY], x[X_R], x[X_PHI] = s, n, vx, vy, r, phi
    x[X_PSI] = -math.atan2(vy, vx) if driver.closed_loop else 0.0
    if not driver.closed_loop:
        x[X_VY] = x[X_R] = x[X_PHI] = 0.0
        fy = v.g * math.sin(bank)
    half = (v.track_f / 2.0, -v.track_f / 2.0, v.track_r / 2.0, -v.track_r / 2.0)
    for i in range(4):
        x[X_OMEGA + i] = (vx - half[i] * x[X_R]) / v.wheel_radius
    fx = v.g * math.sin(grade) - x[X_VY] * x[X_R]
    x[X_FXL], x[X_FYL] = fx, fy
    d = np.zeros(ND)
    f_aero = 0.5 * plant.air_density * plant.CdA * vx * vx
    d[D_VINT] = fx + (f_aero + plant.tyre.rolling_resistance * v.m * fz) / v.m
    kus = v.m / v.L * (v.Lr / v.Cf - v.Lf / v.Cr)
    if driver.closed_loop:
        d[D_LATINT] = delta - (v.L + kus * vx * vx) * kap_lane
        d[D_SWA] = v.steering_ratio * delta
    else:
        d[D_SWA] = swa0
    return x, d


# ---- running --------------------------------------------------------------------------------

def _integrate(scenario: Scenario, plant: PlantParams, dt: float):
    road_p = scenario.road.pack()
    drv_p = scenario.driver.pack(plant)
    p = plant.pack()
    v0 = scenario.driver.initial_speed()
    s_pre = scenario.start_s - v0 * scenario.pre_roll if scenario.driver.closed_loop else scenario.start_s
    x0, d0 = trim_state(scenario.road, plant, scenario.driver, s_pre, scenario.start_n)
    t, X, U, _ = simulate(x0, d0, -scenario.pre_roll, scenario.pre_roll + scenario.duration, dt,
                          road_p, drv_p, p, driver_every(dt))
    return t, X, U, road_p, p


def roll_rate(X: np.ndarray, rows: np.ndarray, road_p, v, dt: float) -> np.ndarray:
    """The rate (rad/s) of bank + body roll at the integration ``rows`` of the plant's states ``X``: the body's
    roll rate plus the rate at which the contact-height bank under the car changes (a central difference over
    the integration step ``dt``, s; one-sided at the ends), what a roll-rate gyro on the body reads."""
    rows = np.asarray(rows, dtype=np.int64)
    a, b = np.maximum(rows - 1, 0), np.minimum(rows + 1, len(X) - 1)
    ends = np.concatenate([a, b])
    bank = truth_banks(road_p, X[ends, X_S], X[ends, X_N], X[ends, X_PSI], v.Lf, v.Lr, v.track_f, v.track_r)
    return X[rows, X_DPHI] + (bank[len(rows):] - bank[:len(rows)]) / ((b - a) * dt)


def run(scenario: Scenario, plant: PlantParams | None = None, sensors: SensorConfig | None = None,
        seed: int = 0, condition: Condition | str | None = None, dt: float | None = None) -> SimResult:
    """Simulate ``scenario`` and sample the sensors.

    Parameters
    ----------
    scenario : Scenario
    plant : PlantParams, optional (default :class:`PlantParams()`)
    sensors : SensorConfig, optional (default :class:`SensorConfig()`)
    seed : int
        Seed of the sensor noise/dropouts (the plant is deterministic).
    condition : Condition or name, optional
        Applied on top of ``plant`` and ``sensors``.
    dt : float, optional
        Integration step (s) of the RK4 plant; default :func:`default_step` of the
        sensors (2 ms at 100 Hz). The driver keeps its own sample time
        (:data:`DRIVER_DT`, held to a multiple of ``dt``), so a finer step refines
        the same simulated system.
    """
    plant = plant or PlantParams()
    sensors = sensors or SensorConfig()
    cond_name = ""
    if condition is not None:
        if isinstance(condition, str):
            if condition not in CONDITIONS:
                raise ValueError(f"unknown condition {condition!r}; known: {', '.join(CONDITIONS)}")
            condition = CONDITIONS[condition]
        plant, sensors = condition.apply(plant, sensors)
        cond_name = condition.name
    if dt is None:
        dt = default_step(sensors)
    if not (0 < dt <= 0.01):
        raise ValueError("dt must be in (0, 0.01] s")
    t, X, U, road_p, p = _integrate(scenario, plant, dt)
    n_pre = int(round(scenario.pre_roll / dt))
    # sensor instants (t >= 0) and the integration rows they read (delayed by the latency)
    step = 1.0 / sensors.rate
    n_samp = int(math.floor(scenario.duration / step + 1e-9)) + 1
    ts = np.arange(n_samp) * step
    rows = n_pre + np.rint(ts / dt).astype(np.int64)
    lag = int(round(sensors.latency / dt))
    rows_meas = np.maximum(rows - lag, 0)
    allrows = np.concatenate([rows, rows_meas])
    Y = outputs_at(X, U, allrows, road_p, p)
    Yt, Ym = Y[:n_samp], Y[n_samp:]
    v = plant.vehicle
    rng = np.random.default_rng(seed)
    true = {"r": X[rows_meas, X_R], "ay": Ym[:, A_AY], "ax": Ym[:, A_AX],
            "v_wheels": 0.5 * (X[rows_meas, X_OMEGA + 2] + X[rows_meas, X_OMEGA + 3]) * v.wheel_radius,
            "swa": U[rows_meas, 0]}
    if sensors.roll_rate is not None:
        true["p"] = roll_rate(X, rows_meas, road_p, v, dt)
    meas = measure(true, sensors, rng)
    signals = Signals(ts, meas["vx"], meas["ay"], meas["r"], meas["swa"] / v.steering_ratio, meas.get("p"))
    Xt = X[rows]
    phib = truth_banks(road_p, Xt[:, X_S], Xt[:, X_N], Xt[:, X_PSI], v.Lf, v.Lr, v.track_f, v.track_r)
    phi = Xt[:, X_PHI].copy()
    truth = Truth(t=ts, phi_b=phib, phi=phi, theta=phib + phi, vy=Xt[:, X_VY].copy(), dvy_dt=Yt[:, A_DVY].copy(),
                  r=Xt[:, X_R].copy(), ay_true=Yt[:, A_AY].copy(), ax_true=Yt[:, A_AX].copy(),
                  vx=Xt[:, X_VX].copy(), steering_wheel_angle=U[rows, 0].copy(), throttle=U[rows, 1].copy(),
                  brake=U[rows, 2].copy(), s=Xt[:, X_S].copy(), n=Xt[:, X_N].copy(), psi=Xt[:, X_PSI].copy(),
                  Fz=Yt[:, A_FZW:A_FZW + 4].copy(), Fx=Yt[:, A_FXW:A_FXW + 4].copy(),
                  Fy=Yt[:, A_FYW:A_FYW + 4].copy(), scenario=scenario.name, condition=cond_name, seed=seed,
                  plant=plant)
    raw = {"t": t[n_pre:] , "X": X[n_pre:], "U": U[n_pre:]}
    return SimResult(signals=signals, steering_wheel_angle=meas["swa"], truth=truth, scenario=scenario.name,
                     condition=cond_name, seed=seed, plant=plant, sensors=sensors, raw=raw)


def run_scenario(name: str, condition: str = "nominal", seed: int = 0, plant: PlantParams | None = None,
                 sensors: SensorConfig | None = None) -> SimResult:
    """Run one of the paper's scenarios (:data:`SCENARIOS`) or of the :data:`DRIVES` under a
    condition (:data:`CONDITIONS`).

    ``plant`` and ``sensors`` (optional) are the base the condition is applied to.
    """
    if name not in SCENARIOS and name not in DRIVES:
        raise ValueError(f"unknown scenario {name!r}; known: {', '.join((*SCENARIOS, *DRIVES))}")
    if condition not in CONDITIONS:
        raise ValueError(f"unknown condition {condition!r}; known: {', '.join(CONDITIONS)}")
    sc = SCENARIOS[name] if name in SCENARIOS else drive_scenario(name)
    return run(sc, plant=plant, sensors=sensors, seed=seed, condition=condition)


def measure_realtime_factor(repeats: int = 5, dt: float = DT_DEFAULT) -> float:
    """Simulated seconds per wall-clock second of the 25 s S-curve (RK4, step ``dt`` s).

    Times the compiled integration (plant + driver + RK4, including the 5 s
    pre-roll, which is counted as simulated time) after a warm-up run that
    triggers compilation; returns the best of ``repeats``.
    """
    sc = SCENARIOS["s-curve"]
    plant = PlantParams()
    _integrate(sc, plant, dt)  # warm-up / compile
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        _integrate(sc, plant, dt)
        best = min(best, time.perf_counter() - t0)
    return (sc.duration + sc.pre_roll) / best
