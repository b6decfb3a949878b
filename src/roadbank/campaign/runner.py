"""The per-run work of a campaign: simulate one :class:`RunSpec`, run every estimator, score it.

:func:`run_one` returns flat rows, one per estimator, holding the run's
parameters (``RunSpec`` fields), the scores of the estimator's bank estimate
``phi_b`` against the plant's contact-height bank (degrees), timings (seconds)
and an ``error`` text. It never raises for a bad run: an exception in the
simulator or an estimator becomes rows with ``error`` set (type and message)
and NaN scores, so one failing run never stops a campaign.

Failure of an estimator in a run (:data:`FAIL_RMS_DEG`): any non-finite output,
a bank RMS error above 2 deg, or an error raised. ``failed`` is that flag.

Estimators are built once per process (:func:`estimators_for`) and reused with
``run(reset=True)``: they all keep the design parameters, only the plant varies, but for the rear cornering
stiffness, trimmed to each run as every command trims a described car's to its log
(:func:`roadbank.vehicle.rear_trim`, as ``RunOptions.rear_trim`` says, by default
:data:`roadbank.vehicle.conditions.REAR_TRIM`; never a vehicle's measured one, :func:`roadbank.vehicle.trims_rear`; the
column ``rear_trim``, the scale, 1 where not trimmed), one design per scale.

Runs start with ``RunOptions.standstill`` seconds (default 3 s) of the car at rest
(:func:`roadbank.sim.standstill.with_standstill`), as real drives do, and the estimators
learn their sensor offsets online (``RunOptions.offsets``,
:func:`roadbank.estimators.with_online_offsets`). Scores start ``settle`` seconds after the
standstill; ``min_vx`` and ``duration_s`` are those of the drive after it. The columns
``standstill_s``, ``offsets``, ``r_offset_err_dps`` (learnt minus true yaw-rate offset at
the end of the run, deg/s; NaN without learning) and ``r_offset_learnt_s`` (seconds from
the start until the yaw-rate offset is flagged learnt; NaN if never) say what was done.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
import traceback
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import defaults
from .. import estimators as E
from ..evaluation import error_metrics
from ..params import VehicleParams
from ..sim import SCENARIOS
from ..sim import run as sim_run
from ..sim.standstill import with_standstill
from ..vehicle import conditions, rear_trim, trims_rear
from .sampling import RunSpec

if TYPE_CHECKING:
    from ..vehicle import Vehicle

#: an estimator "fails" a run when its bank RMS error exceeds this (deg) ...
FAIL_RMS_DEG = 2.0
#: ... or when any output sample is non-finite, or it raised.

#: row columns besides the RunSpec fields
SCORE_COLUMNS = ("estimator", "rms_deg", "max_deg", "bias_deg", "steady_deg", "theta_rms_deg",
                 "valid_frac", "nonfinite", "failed", "max_beta_deg", "min_vx", "sim_s", "est_s",
                 "duration_s", "error", "standstill_s", "offsets", "r_offset_err_dps", "r_offset_learnt_s",
                 "rear_trim")


@dataclass(frozen=True)
class RunOptions:
    """How runs are simulated and scored (the same for every run of a campaign).

    Attributes
    ----------
    names : tuple of str
        Estimators to run (default: all of :data:`roadbank.estimators.NAMES`).
    duration_scale : float
        Factor on each scenario's duration (1 = the paper's 15/25 s). A value
        below 1 shortens the manoeuvres (truncates them) and is stated in the report.
    pre_roll : float or None
        Settling time simulated before t = 0 (s); None keeps the scenario's 5 s.
    sim_dt : float or None
        Integration step of the plant (s); None is the simulator's default
        (:func:`roadbank.sim.scenarios.default_step`: 2 ms at 100 Hz sensors).
    settle : float
        Seconds at the start excluded from the scores.
    vehicle : roadbank.vehicle.Vehicle or None
        The car: perturbed plant and sensors around it, estimators designed for it (its
        parameters and ``[tuning]`` tables). None: the paper's SUV.
    standstill : float
        Seconds of standstill before each run (s; 0: none).
    offsets : bool
        Run every estimator behind the online offset learner.
    rear_trim : bool or str
        Which trim of the design's rear cornering stiffness each run gets (one of
        :data:`roadbank.vehicle.conditions.REAR_TRIM_CHOICES`; default: the library's setting
        :data:`~roadbank.vehicle.conditions.REAR_TRIM` when the options are made, so it reaches every worker).
    """

    names: tuple = ()
    duration_scale: float = 1.0
    pre_roll: float | None = None
    sim_dt: float | None = None
    settle: float = 2.0
    vehicle: Vehicle | None = None
    standstill: float = 3.0
    offsets: bool = True
    rear_trim: bool | str = field(default_factory=lambda: conditions.REAR_TRIM)

    __hash__ = None  # type: ignore[assignment]  # a Vehicle holds dicts: not hashable

    def __post_init__(self) -> None:
        if not (0 < self.duration_scale <= 1.0):
            raise ValueError("duration_scale must be in (0, 1]")
        if self.sim_dt is not None and not (0 < self.sim_dt <= 0.01):
            raise ValueError("sim_dt must be in (0, 0.01] s")
        if self.pre_roll is not None and not self.pre_roll >= 0:
            raise ValueError("pre_roll must be >= 0")
        if not (math.isfinite(self.standstill) and self.standstill >= 0):
            raise ValueError("standstill must be >= 0 s")
        conditions.rear_trim_scales(self.rear_trim)         # a ValueError for none of the choices

    def estimator_names(self) -> tuple:
        return tuple(self.names) or E.NAMES

    def as_dict(self) -> dict:
        d = dataclasses.asdict(dataclasses.replace(self, vehicle=None))
        del d["vehicle"]  # absent for the paper SUV: campaigns stored before vehicles resume
        if not self.standstill and not self.offsets:   # as campaigns stored before standstill starts
            del d["standstill"], d["offsets"]
        if self.rear_trim is False:         # as campaigns stored before the trim (which ran untrimmed)
            del d["rear_trim"]
        if self.vehicle is not None:
            d["vehicle"] = self.vehicle.dumps()
        d["names"] = list(self.estimator_names())
        return d


_ESTIMATORS: dict = {}


def estimators_for(names, vehicle=None, offsets: bool = False, rear: float = 1.0) -> dict:
    """Estimators ``name -> Estimator`` with the design parameters, built once per process.

    ``vehicle`` (a :class:`roadbank.vehicle.Vehicle`): designed for it (``vehicle.make(name)``).
    ``offsets``: each behind the online offset learner (:func:`roadbank.estimators.with_online_offsets`).
    ``rear``: the scale (-) of the design's rear cornering stiffness (a run's :func:`roadbank.vehicle.rear_trim`).
    """
    out = {}
    car = None if vehicle is None else vehicle.dumps()
    base = VehicleParams() if vehicle is None else vehicle.params
    params = base if rear == 1.0 else base.replace(Cr=base.Cr * rear)
    for name in names:
        key = (name, car, bool(offsets), float(rear))
        if key not in _ESTIMATORS:
            est = _make(name, vehicle, params)
            _ESTIMATORS[key] = E.with_online_offsets(est) if offsets else est
        out[name] = _ESTIMATORS[key]
    return out


def _make(name: str, vehicle, params: VehicleParams):
    """``name`` for ``params`` as this module builds every estimator: the data sheet's sensors, or ``vehicle``'s
    sensors and tuning."""
    return E.make(name, params) if vehicle is None else vehicle.replace(params=params).make(name)


def _trial(vehicle, car: VehicleParams):
    """The default (:data:`roadbank.defaults.ESTIMATOR`) for ``car`` (a trial of :func:`roadbank.vehicle.rear_trim`),
    built once per process as :func:`_make` builds every estimator."""
    key = ("trial", car, None if vehicle is None else vehicle.dumps())
    if key not in _ESTIMATORS:
        _ESTIMATORS[key] = _make(defaults.ESTIMATOR, vehicle, car)
    return _ESTIMATORS[key]


def _scenario(spec: RunSpec, options: RunOptions):
    sc = SCENARIOS[spec.scenario]
    changes: dict[str, Any] = {}
    if options.duration_scale != 1.0:
        changes["duration"] = sc.duration * options.duration_scale
    if options.pre_roll is not None:
        changes["pre_roll"] = options.pre_roll
    return dataclasses.replace(sc, **changes) if changes else sc


def _error_text(exc: BaseException) -> str:
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
    return f"{type(exc).__name__}: {exc}{where}"


def run_one(spec: RunSpec, options: RunOptions | None = None) -> list[dict]:
    """Simulate ``spec``, run and score every estimator; one row per estimator. Never raises
    for a failing run (see the module docstring). ``options``: default ``RunOptions()`` made now."""
    options = options or RunOptions()
    names = options.estimator_names()
    base = spec.as_dict()
    t0 = time.perf_counter()
    setup = {"offsets": bool(options.offsets)}
    try:
        plant, sensors = spec.plant_and_sensors(options.vehicle)
        scenario = _scenario(spec, options)
        sim = sim_run(scenario, plant, sensors, seed=spec.noise_seed, dt=options.sim_dt)
        n_drive = len(sim.signals)
        sim = with_standstill(sim, scenario, options.standstill)
    except Exception as exc:  # a failing run is data, not a crash
        err = f"simulation: {_error_text(exc)}"
        return [_row(base, name, error=err, sim_s=time.perf_counter() - t0, **setup) for name in names]
    sim_s = time.perf_counter() - t0
    tr, sig = sim.truth, sim.signals
    k0 = len(sig) - n_drive                         # first sample of the drive
    still = float(sig.t[k0] - sig.t[0])
    extra = {"max_beta_deg": tr.max_sideslip_deg(k0), "min_vx": float(np.nanmin(tr.vx[k0:])),
             "duration_s": float(sig.t[-1] - sig.t[k0]), "sim_s": sim_s, "standstill_s": still, **setup}
    true_r_offset = sensors.yaw_rate.bias
    rear = (rear_trim(sig, VehicleParams() if options.vehicle is None else options.vehicle.params,
                      build=functools.partial(_trial, options.vehicle),
                      scales=conditions.rear_trim_scales(options.rear_trim))
            if trims_rear(options.vehicle) else 1.0)
    extra["rear_trim"] = rear
    rows = []
    for name, est in estimators_for(names, options.vehicle, options.offsets, rear).items():
        t1 = time.perf_counter()
        try:
            e = est.run(sig)
            nonfinite = not (np.all(np.isfinite(e.phi_b)) and np.all(np.isfinite(e.theta)))
            m = error_metrics(sig.t, e.phi_b, tr.phi_b, e.valid, settle=options.settle + still)
            mt = error_metrics(sig.t, e.theta, tr.theta, e.valid, settle=options.settle + still)
        except Exception as exc:
            rows.append(_row(base, name, error=f"estimator: {_error_text(exc)}",
                             est_s=time.perf_counter() - t1, **extra))
            continue
        failed = bool(nonfinite or not (m.rms_deg <= FAIL_RMS_DEG))
        rows.append(_row(base, name, rms_deg=m.rms_deg, max_deg=m.max_deg, bias_deg=m.bias_deg,
                         steady_deg=m.steady_deg, theta_rms_deg=mt.rms_deg,
                         valid_frac=float(np.mean(e.valid[k0:])), nonfinite=nonfinite, failed=failed,
                         est_s=time.perf_counter() - t1, **extra, **_offset_scores(e, true_r_offset)))
    return rows


def _offset_scores(e, true_r_offset: float) -> dict:
    """``r_offset_err_dps`` (deg/s) and ``r_offset_learnt_s`` (s) of an estimate with learnt offsets."""
    if "r_offset" not in e.states or not len(e.t):
        return {}
    learnt = np.flatnonzero(e.states["r_offset_learnt"] > 0)
    return {"r_offset_err_dps": math.degrees(float(e.states["r_offset"][-1]) - true_r_offset),
            "r_offset_learnt_s": float(e.t[learnt[0]] - e.t[0]) if learnt.size else math.nan}


def _row(base: dict, name: str, **values) -> dict:
    nan = math.nan
    row = dict(base)
    row.update({"estimator": name, "rms_deg": nan, "max_deg": nan, "bias_deg": nan, "steady_deg": nan,
                "theta_rms_deg": nan, "valid_frac": nan, "nonfinite": False, "failed": True,
                "max_beta_deg": nan, "min_vx": nan, "sim_s": nan, "est_s": nan, "duration_s": nan,
                "error": "", "standstill_s": nan, "offsets": False, "r_offset_err_dps": nan,
                "r_offset_learnt_s": nan, "rear_trim": nan})
    row.update(values)
    return row


def warm_up(options: RunOptions | None = None) -> float:
    """Build the estimators and run a 0.5 s simulation in this process, so the numba
    kernels are loaded (or compiled) before a campaign is timed. Returns seconds spent."""
    options = options or RunOptions()
    t0 = time.perf_counter()
    sc = dataclasses.replace(SCENARIOS["const-bank"], duration=0.5, pre_roll=0.1)
    sim = sim_run(sc, dt=options.sim_dt)
    for est in estimators_for(options.estimator_names(), options.vehicle, options.offsets).values():
        est.run(sim.signals)
    return time.perf_counter() - t0


def run_batch(specs, options: RunOptions | None = None) -> list[dict]:
    """:func:`run_one` over a batch of specs (one Dask task); rows of all of them."""
    options = options or RunOptions()
    rows = []
    for spec in specs:
        rows.extend(run_one(spec, options))
    return rows
