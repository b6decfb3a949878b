"""What a log tells the estimator design about its sensors, and the one rule that turns it into weights.

:func:`log_conditions` measures a log's sample rate and the road noise of its ``ay`` and yaw rate;
:func:`noise_densities` turns a car's sensors and those conditions into the noise densities of a
sensor-weighted PIF; :func:`make_estimator` builds an estimator with them. Which estimators take
the sensors' weights, and how explicit options override them, is
:func:`roadbank.estimators.pif.with_sensor_noise`.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np

from ..constants import MAX_GAP_S, G
from ..models.attitude import euler_pitch_rate, kinematic_roll
from ..params import VehicleParams
from ..signals import (DYNAMICS_BAND_HZ, band_inner, band_windows, bridged, concat_signals, diff_noise_std,
                       driving_s, held_copies, integral_band_fit, is_held, noise_band_hz, road_noise_floor_std,
                       road_noise_std, running_integral, sample_rate, source_step, stretch_index)
from ..io.errors import LogError
from .sensors import SensorSpec

# roadbank.estimators and roadbank.sim (numba) are imported inside the functions that use
# them: loading a car (load_vehicle, --vehicle) loads neither

__all__ = ["DESIGN_SPAN_S", "DESIGN_MAX_S", "QUIET_RATIO", "QUIET_FILTER", "QUIET_MODELS", "GYRO_FILTER",
           "GYRO_MODELS", "design_span", "has_design_span", "log_conditions", "noise_densities", "is_quiet",
           "quiet_noise_ratio", "roll_rate_slope", "roll_rate_usable", "default_reads_roll_rate", "ax_slope",
           "pitch_rate_slope", "esp_conditions", "make_estimator"]


#: seconds of driving (``vx >= v_min``) at the start of a log on which :func:`log_conditions` measures it (s)
DESIGN_SPAN_S = 60.0
#: ... read at most this far into the log (s): a log that stands still longer is measured on what it has
DESIGN_MAX_S = 600.0
#: a log is quiet (:func:`is_quiet`) when its ``ay`` road-noise density is at most this many times
#: the accelerometer's data-sheet density (-; chosen by the rule of :mod:`roadbank.tuning.real`,
#: its third stage), and ``kinematic-pif`` is then :data:`QUIET_FILTER`
QUIET_RATIO = 1.5
#: the filter that ``kinematic-pif`` is on a quiet log: the car's model, with the tyre's fall-off
#: near the friction limit (the rule's fourth stage, over :data:`roadbank.tuning.real.QUIET_FILTERS`)
QUIET_FILTER = "pif-adaptive"
#: what each real-road estimator (the low-pass of the kinematic estimate) is on a quiet log: the car's
#: model (``kinematic-pif``: :data:`QUIET_FILTER`; the offline ``kinematic-smoother``: the offline PIF)
QUIET_MODELS = {"kinematic-pif": QUIET_FILTER, "kinematic-smoother": "pif-smoother"}
#: what ``kinematic-pif`` is on a loud log that carries a usable roll rate (:func:`roll_rate_usable`): the
#: complementary filter of the kinematic estimate and the roll-rate gyro, chosen by the twenty-fourth stage of
#: :mod:`roadbank.tuning.real`
GYRO_FILTER = "kinematic-gyro"
#: what each real-road estimator is on such a log (the offline ``kinematic-smoother`` of ``roadbank map``: the same
#: filter forward and backward, the twenty-fifth stage)
GYRO_MODELS = {"kinematic-pif": GYRO_FILTER, "kinematic-smoother": "kinematic-gyro-smoother"}
#: share (-) of the design span's samples at speed where an optional channel (roll rate, ax) must be finite for a log
#: to count as having it
ROLL_RATE_SHARE = 0.5
#: the roll rate is used only where it follows the roll that ``ay`` shows: the least-squares slope (-) of the
#: kinematic estimate on the integrated roll rate, both band-passed over the design span (centred moving averages
#: of :data:`ROLL_CHECK_WINDOWS_S` (s), the shorter less the longer: about 0.05-0.5 Hz), within
#: :data:`ROLL_SLOPE_RANGE`. On the design spans of the 16 shared KITTI drives and comma2k19 it is 1.0-1.5; negated,
#: -1.0 to -1.5; the yaw rate in its place -0.22 to 0.10; deg/s read as rad/s 0.017-0.027.
#: The longitudinal acceleration likewise corrects the roll rate for the grade only where it follows the speed: the
#: slope (-) of ``vx`` on the integrated ``ax``, band-passed in the same way, within the same range (:func:`ax_slope`).
ROLL_CHECK_WINDOWS_S = (1.0, 10.0)
ROLL_SLOPE_RANGE = (0.5, 2.0)
#: a channel whose meaning the log's format documents (``Signals.fixed``: KITTI's OXTS files, comma2k19) is taken as it
#: is, whatever its check reads, and reads :data:`FIXED_SLOPE` (the thirty-third stage of :mod:`roadbank.tuning.real`:
#: on short logs the checks cannot decide or misread a right channel, and no map can be wrong); False: judged as a
#: map's (the stages before)
TRUST_FIXED_CHANNELS = True
#: what a format's own roll rate or ``ax`` reads in :func:`log_conditions`: the slope of a right channel (-)
FIXED_SLOPE = 1.0
#: a roll rate whose check slope reads the opposite sign (:data:`ROLL_SLOPE_RANGE` mirrored) may be inverted alone
#: or belong to a log in the FRD convention declared ISO (ay and the yaw and pitch rates flipped; a roll rate reads the
#: same in both): the pitch rate tells them apart. Its check slope (:func:`pitch_rate_slope`) below this (-) reads as
#: FRD, and the log is refused (:func:`frd_error`): the 16 KITTI drives as recorded read 0.56-1.08, with ay, the yaw
#: rate and the pitch rate flipped -1.12-0.13 (the kinematic roll in the Euler pitch rate flips too)
FRD_PITCH_MAX = 0.35
#: low-passes whose update is limited by default (their ``clip``), given the log's noise densities ``Q_ay`` and ``R``
#: (:func:`noise_densities`) by :func:`make_estimator`, as a sensor-weighted PIF is
LIMITED_LOWPASSES = ("kinematic-smoother",)
#: the options of ``kinematic-pif`` that set its gate: given one, the caller's gate is kept
_GATE_OPTIONS = ("gate_on", "gate_span", "gate_tf", "gate_release")
#: ``kinematic-pif``'s options of its low-pass and gate, which its quiet filter does not take
_BLEND_OPTIONS = ("cutoff", "kappa", "bank_rate", "bank_speed_exp", "lead", "clip", "noise_tau", "noise_ref",
                  "limit_tau") + _GATE_OPTIONS


def design_span(signals, v_min: float = 5.0) -> int:
    """Samples of ``signals`` on which :func:`log_conditions` measures the log: up to the sample at
    which :data:`DESIGN_SPAN_S` seconds of driving (``vx >= v_min``, m/s; each moving sample counts
    the interval before it) have passed, or :data:`DESIGN_MAX_S` seconds of the log; all of a
    shorter log. A log that starts at a standstill (ignition on, the car parked) is measured on
    its first minute of driving, not on the idle. An interval longer than :data:`~roadbank.constants.MAX_GAP_S`
    (a dropout, a pause of the logger, a stray first time stamp) is a gap the estimators start again after: it
    counts as neither driving nor time of the log."""
    t = np.asarray(signals.t, dtype=np.float64)
    if len(t) < 2:
        return len(t)
    with np.errstate(invalid="ignore"):
        moving = np.asarray(signals.vx, dtype=np.float64)[1:] >= v_min
        dt = np.diff(t)
        gaps = np.where(dt > MAX_GAP_S, dt, 0.0)
    driven = np.cumsum(np.where(moving, dt - gaps, 0.0))
    closed = t - np.concatenate(([0.0], np.cumsum(gaps)))       # the time with the gaps closed (t where none is)
    n = min(int(np.searchsorted(driven, DESIGN_SPAN_S, side="left")) + 2,
            int(np.searchsorted(closed, t[0] + DESIGN_MAX_S, side="right")))
    return min(n, len(t))


def has_design_span(signals, v_min: float = 5.0) -> bool:
    """Whether ``signals`` (the start of a log) already hold all of :func:`design_span`'s samples, so
    that reading more of the log would not change :func:`log_conditions`."""
    return design_span(signals, v_min) < len(signals)


#: the road noise a design reads is at most this many times the channel's noise floor (:func:`log_conditions`)
NOISE_FLOOR_CAP = 3.0
#: the rate (Hz) at which :func:`log_conditions` reads the ``ay`` noise floor that :func:`is_quiet` compares
#: (:func:`roadbank.signals.road_noise_floor_std`'s ``at_rate``; 0: the log's own rate). The eighteenth stage of
#: :mod:`roadbank.tuning.real` chooses it
QUIET_FLOOR_RATE = 0.0
#: the channel whose floor :func:`log_conditions` reads for :func:`is_quiet`: ``"ay"``, or ``"ay - vx r"`` (m/s^2, the
#: kinematic acceleration: ``ay`` without the centripetal part of a manoeuvre). The nineteenth stage of
#: :mod:`roadbank.tuning.real` chooses it
QUIET_FLOOR_SIGNAL = "ay"
#: the channels :data:`QUIET_FLOOR_SIGNAL` may name
QUIET_FLOOR_SIGNALS = ("ay", "ay - vx r")
#: which noise readings of :func:`log_conditions` take a channel at its source's rate where a logger wrote it faster
#: (:func:`roadbank.signals.source_step`): ``"none"``, ``"floor"`` (the ``ay`` floor that :func:`is_quiet` reads) or
#: ``"all"`` (every reading of ``ay`` and the yaw rate). The twentieth stage of :mod:`roadbank.tuning.real` chooses it
NOISE_AT_SOURCE = "all"
#: the values :data:`NOISE_AT_SOURCE` may take
NOISE_AT_SOURCE_CHOICES = ("none", "floor", "all")
#: where :func:`log_conditions` reads a channel's noise density just above the dynamics band only (``band ..
#: NOISE_OCTAVE_TOP band`` Hz, :func:`roadbank.signals.noise_band_hz`), taken as the whole band's: ``"none"``
#: (white over the whole band above it), ``"fast"`` (on logs of 30 Hz or more, whose band is the dynamics band),
#: ``"all"``. The twenty-first stage of :mod:`roadbank.tuning.real` chooses it
NOISE_OCTAVE = "all"
#: the values :data:`NOISE_OCTAVE` may take
NOISE_OCTAVES = ("none", "fast", "all")
#: whether the blend's gate (``kinematic-pif``) filters the yaw rate over at least its source's interval where a
#: logger wrote the yaw rate faster than its sensor (``log_r_source``, Hz; a held yaw rate's steps otherwise read as
#: yaw accelerations). The fifty-third stage of :mod:`roadbank.tuning.real` chooses it
GATE_AT_SOURCE = True
#: the values :data:`GATE_AT_SOURCE` may take
GATE_AT_SOURCE_CHOICES = (False, True)
#: whether a log written by holding a slower sensor's frames (:func:`roadbank.signals.is_held`) is read at its
#: source's rate: designed for the rows that bring new values and run on them alone (``log_held``,
#: :class:`roadbank.estimators.AtSource`). The fifty-fifth stage of :mod:`roadbank.tuning.real` chooses it
READ_AT_SOURCE = True
#: the values :data:`READ_AT_SOURCE` may take
READ_AT_SOURCE_CHOICES = (False, True)
#: whether a usable roll rate makes the default the gyro-aided filter on a quiet log too (False: a quiet log keeps the
#: car's model whatever its roll rate; ``"unbiased"``: only a roll rate documented free of offset, an INS's). The
#: fifty-sixth stage of :mod:`roadbank.tuning.real` kept False against True (an ESP-class gyro), the sixtieth chose
#: ``"unbiased"``
QUIET_READS_ROLL_RATE: bool | str = "unbiased"
#: the values :data:`QUIET_READS_ROLL_RATE` may take
QUIET_READS_ROLL_RATE_CHOICES = (False, True, "unbiased")
#: whether a channel written with few decimals is read as written faster than its sensor where its rounding, not its
#: source, bends it between the source's samples (:func:`roadbank.signals.source_step`'s ``rounding``): the
#: fifty-seventh stage of :mod:`roadbank.tuning.real` chooses it
SOURCE_ROUNDING = True
SOURCE_ROUNDING_CHOICES = (False, True)
#: whether a log designed quiet is handed to the design of its first loud stretch when its roads turn loud
#: (:func:`loud_stretch`, :class:`roadbank.estimators.HandOver`): the fifty-eighth stage of :mod:`roadbank.tuning.real`
#: chooses it; ``"esp"``, only a log without a usable roll rate (the fifty-ninth stage's candidate)
ROAD_CHANGE: bool | str = True
ROAD_CHANGE_CHOICES = (False, True, "esp")
#: whether the default's design for a loud log (the low-pass blend, or the gyro-aided filter with a roll rate that a
#: quiet log would not read) is handed back to the car's model where a stretch of its roads reads quiet
#: (:func:`quiet_stretch`), and that design handed over again where its roads turn loud: the sixty-first stage of
#: :mod:`roadbank.tuning.real` chooses it (False: one way, quiet to loud, as the fifty-eighth shipped)
ROAD_CHANGE_BACK = False
ROAD_CHANGE_BACK_CHOICES = (False, True)
#: whether the default keeps the car's model on a quiet log whose car nobody described (``described=False``: the car
#: :func:`roadbank.vehicle.undescribed_params` chose for the log); False: such a log is designed as a loud one (the
#: low-pass blend, or the gyro-aided filter with a usable roll rate). The sixty-second stage of
#: :mod:`roadbank.tuning.real` chooses it; a car described (a vehicle file, parameters given) keeps its model either way
UNDESCRIBED_KEEPS_MODEL = False
UNDESCRIBED_KEEPS_MODEL_CHOICES = (True, False)
#: the same for the offline ``kinematic-smoother`` (``roadbank map``'s default): the sixty-third stage chooses it
UNDESCRIBED_SMOOTHER_KEEPS_MODEL = False
#: whether ``kinematic-smoother``, where its design is the low-pass both ways, moves to ``pif-smoother`` (the same log
#: and car) where an offline gate on the yaw part of the lateral jerk is open
#: (:class:`roadbank.estimators.GatedSmoother`, :data:`SMOOTHER_GATE_HOLD_S`): the sixty-fourth stage of
#: :mod:`roadbank.tuning.real` chose it (False before)
SMOOTHER_GATE = True
SMOOTHER_GATE_CHOICES = (False, True)
#: how long (s) that gate stays open before and after each ramp of its measure: the causal blend's release time
#: constant (:data:`roadbank.estimators.gated.KINEMATIC_PIF_GATE`), fixed before the sixty-fourth stage ran; the
#: sixty-seventh chooses it among :data:`SMOOTHER_GATE_HOLD_S_CHOICES`
SMOOTHER_GATE_HOLD_S = 8.0
SMOOTHER_GATE_HOLD_S_CHOICES = (8.0, 4.0, 2.0, 1.0)
#: whether a described car's rear cornering stiffness is trimmed to the log (:func:`roadbank.vehicle.rear_trim`: the
#: misfit of the undescribed car's rule over :data:`REAR_TRIM_SCALES` of it, the described value kept unless another
#: fits :data:`~roadbank.vehicle.CAR_MARGIN` times better; ``"softer"``: over those scales at most 1 only): the
#: sixty-eighth stage of :mod:`roadbank.tuning.real` kept it off against True, the sixty-ninth chose ``"softer"``
REAR_TRIM: bool | str = "softer"
REAR_TRIM_CHOICES = (False, True, "softer")
#: the scales (-) of the described ``Cr`` that the trim tries (1: as described)
REAR_TRIM_SCALES = (0.5, 0.6, 0.7, 0.85, 1.0, 1.2, 1.4)
#: the lowest speed (m/s) at which that gate's measure counts (0: every speed, as the sixty-fourth stage shipped): the
#: sixty-fifth stage of :mod:`roadbank.tuning.real` chose it among :data:`SMOOTHER_GATE_V_MIN_CHOICES`
SMOOTHER_GATE_V_MIN = 10.0
SMOOTHER_GATE_V_MIN_CHOICES = (0.0, 10.0, 15.0, 20.0)
#: the lowest speed (m/s) at which the causal blend's gate counts where ``kinematic-pif`` is the blend (None: the
#: estimator's own, :data:`roadbank.estimators.gated.KINEMATIC_PIF_GATE_V_MIN`); the sixty-sixth stage of
#: :mod:`roadbank.tuning.real` runs its candidates through it
BLEND_GATE_V_MIN: float | None = None
BLEND_GATE_V_MIN_CHOICES = (None, 0.0, 10.0, 15.0, 20.0)
#: the top of that band as a multiple of its lower edge (-; 2: one octave, as the twenty-first stage ran; 1.5: half of
#: one, 3-4.5 Hz at 100 Hz, 1-1.5 Hz at 10 Hz). The twenty-second stage of :mod:`roadbank.tuning.real` chooses it
NOISE_OCTAVE_TOP = 1.5


def _at_most(noise: float, floor: float) -> float:
    """``noise`` capped at :data:`NOISE_FLOOR_CAP` times ``floor`` (same unit; a NaN floor caps nothing)."""
    return min(noise, NOISE_FLOOR_CAP * floor) if math.isfinite(floor) else noise


def log_conditions(signals, v_min: float = 5.0) -> dict[str, float | None]:
    """What a log tells :func:`make_estimator` about its sensors: ``{"log_rate": Hz,
    "log_ay_noise": m/s^2, "log_r_noise": rad/s, "log_ay_floor": m/s^2, "log_diff_noise": m/s^2, "log_roll_rate": -,
    "log_ax": -, "log_gyro_unbiased": 1 or None, "log_pitch_rate": -}`` (``log_roll_rate``, ``log_ax`` and
    ``log_pitch_rate`` :func:`roll_rate_slope`, :func:`ax_slope` and :func:`pitch_rate_slope`, None for a log without
    the channel (and for a pitch rate not documented free of offset), :data:`FIXED_SLOPE` for a channel its format
    documents: ``Signals.fixed``, :data:`TRUST_FIXED_CHANNELS`; ``log_gyro_unbiased`` 1 where the log's roll rate is
    documented free of offset, ``Signals.unbiased``) — the
    sample rate of its time base (:func:`roadbank.signals.sample_rate`), the road noise of its ``ay`` and
    yaw rate on the samples at ``vx >= v_min`` (m/s): what they carry above the vehicle's dynamics band, taken
    as white (:func:`roadbank.signals.road_noise_std`, the noise model of real roads; NaN when
    too few samples), at most :data:`NOISE_FLOOR_CAP` times the channel's noise floor (its median over 4 s
    windows: a few glitches in the first minute, one ``ay`` sample of 2.5 g, would otherwise set the design for
    the whole log; on every log the project has, real or simulated, the road noise is within 1.7 times the
    floor, so the cap changes none of them), the noise floor of its ``ay``
    (:func:`roadbank.signals.road_noise_floor_std`, read at :data:`QUIET_FLOOR_RATE` on
    :data:`QUIET_FLOOR_SIGNAL`: what :func:`is_quiet` reads), and the noise that the first
    differences of the kinematic acceleration ``ay - vx r`` read (:func:`roadbank.signals.diff_noise_std`: what a
    limited low-pass's running noise estimate is relative to, ``noise_ref``). Measured on the log's first
    :data:`DESIGN_SPAN_S` of driving (:func:`design_span`), so that a streamed log gets the same design whatever
    its chunk size. :data:`NOISE_AT_SOURCE` says which of these readings take a channel that a logger wrote faster
    than its sensor at the sensor's rate (:func:`_at_source`), :data:`NOISE_OCTAVE` in which band the density is
    read (:func:`_octave_top`: just above the dynamics band, taken as the whole band's).
    """
    signals, vx, moving, held = _read_part(signals, v_min)
    steps = _source_steps(signals, moving)
    k_quiet = steps["ay"]
    k_ay = k_quiet if NOISE_AT_SOURCE == "all" else 1
    k_r = steps["r"]
    cap_floor, ay_floor = _ay_floors(signals, vx, moving, k_quiet, k_ay)
    ay_noise = _at_most(_at_source(_noise, signals.ay, signals.t, moving, k_ay), cap_floor)
    r_noise = _at_most(_at_source(_noise, signals.r, signals.t, moving, k_r),
                       _at_source(_floor, signals.r, signals.t, moving, k_r))
    with np.errstate(invalid="ignore"):
        diff_noise = diff_noise_std(np.asarray(signals.ay, np.float64) - vx * np.asarray(signals.r, np.float64), moving)
    # two significant digits: logs of one car and road share a design (the design cache)
    rate = sample_rate(signals.t)
    source = {"log_r_source": float(f"{rate / k_r:.3g}")} if GATE_AT_SOURCE and k_r > 1 else {}
    if held is not None:
        source["log_held"] = 1.0
    return {**source, "log_rate": rate, "log_ay_noise": float(f"{ay_noise:.2g}"),
            "log_r_noise": float(f"{r_noise:.2g}"), "log_ay_floor": float(f"{ay_floor:.2g}"),
            "log_diff_noise": float(f"{diff_noise:.2g}"),
            "log_roll_rate": frd_error(signals, vx, moving, _checked(signals, "p", vx, moving, roll_rate_slope)),
            "log_ax": _checked(signals, "ax", vx, moving, ax_slope),
            "log_gyro_unbiased": 1.0 if "p" in signals.unbiased and has_channel(signals, "p", moving) else None,
            "log_pitch_rate": (_checked(signals, "q", vx, moving, pitch_rate_slope) if "q" in signals.unbiased
                               else None)}


def _read_part(signals, v_min: float):
    """``(signals, vx m/s, moving, held rows or None)``: the part of a log its conditions are read on, the log's first
    :data:`DESIGN_SPAN_S` of driving (:func:`_design_part`), its rows that bring new values alone where it was written
    by holding its sensors' frames (:func:`_held_rows`)."""
    signals, vx, moving = _design_part(signals, v_min)
    held = _held_rows(signals, moving)
    if held is not None:            # the rows that bring new values: the log as its sensors wrote it
        signals, vx, moving = signals.take(held), vx[held], moving[held]
    return signals, vx, moving, held


def _ay_floors(signals, vx, moving, k_quiet: int, k_ay: int) -> tuple[float, float]:
    """``(the ay floor that caps its noise, the floor the quiet decision reads)`` (m/s^2) of a log's read part, its
    ``ay`` source ``k_quiet`` rows per sample (``k_ay`` as :data:`NOISE_AT_SOURCE` reads it for the noise)."""
    cap = _at_source(_floor, signals.ay, signals.t, moving, k_ay)
    if QUIET_FLOOR_RATE > 0.0 or QUIET_FLOOR_SIGNAL != "ay":   # what the quiet decision reads; the cap keeps ay's
        return cap, road_noise_floor_std(_floor_signal(signals, vx), signals.t, moving, at_rate=QUIET_FLOOR_RATE)
    if k_quiet != k_ay:
        return cap, _at_source(_floor, signals.ay, signals.t, moving, k_quiet)
    return cap, cap


def quiet_floor_of(signals, v_min: float = 5.0) -> float:
    """``log_conditions(signals, v_min)["log_ay_floor"]`` (m/s^2, two significant digits) alone, without reading the
    rest of the conditions."""
    return floor_and_rate(signals, v_min)[0]


def floor_and_rate(signals, v_min: float = 5.0) -> tuple[float, float]:
    """``(log_ay_floor m/s^2, log_rate Hz)`` of ``log_conditions(signals, v_min)`` alone: what :func:`is_quiet` reads,
    without reading the rest of the conditions."""
    signals, vx, moving, _ = _read_part(signals, v_min)
    k_quiet = _source_steps(signals, moving, ("ay",))["ay"]
    k_ay = k_quiet if NOISE_AT_SOURCE == "all" else 1
    return float(f"{_ay_floors(signals, vx, moving, k_quiet, k_ay)[1]:.2g}"), sample_rate(signals.t)


def _held_rows(signals, moving) -> np.ndarray | None:
    """The rows of ``signals`` that bring new values (indices), where :data:`READ_AT_SOURCE` and the log was written
    by holding a slower sensor's frames (:func:`roadbank.signals.is_held` on its ``moving`` rows); else None."""
    if not _setting("READ_AT_SOURCE"):
        return None
    copies = held_copies(signals)
    return np.flatnonzero(~copies) if is_held(copies, moving) else None


def frd_error(signals, vx, moving, roll: float | None) -> float | None:
    """``roll`` (the roll rate's check slope, -), or LogError where it reads the opposite sign and the pitch rate's
    check slope is below :data:`FRD_PITCH_MAX`: a log in the FRD convention declared ISO, whose bank would come out
    mirrored (``vx`` m/s and ``moving`` as :func:`roll_rate_slope`'s)."""
    lo, hi = ROLL_SLOPE_RANGE
    if roll is None or not -hi <= roll <= -lo:
        return roll
    pitch = pitch_rate_slope(signals, vx, moving)
    if pitch is None or pitch >= FRD_PITCH_MAX:
        return roll
    raise LogError(f"the log reads as FRD declared as ISO 8855: its roll rate follows the roll in its ay with the "
                   f"opposite sign (check slope {roll:.2f}) and its pitch rate does not follow the pitch of its ax "
                   f"(slope {pitch:.2f}; 0.56-1.08 on real drives in ISO): ay and the yaw and pitch rates are "
                   "positive the other way, and the bank would come out mirrored. Give convention = \"FRD\" in a "
                   "channel map (`roadbank channels LOG -o map.toml`), or, if ay is right (positive in a left turn), "
                   "invert = true on the roll rate alone")


def _checked(signals, name: str, vx, moving, check) -> float | None:
    """What the log's optional channel ``name`` reads (-, two digits; None without it): :data:`FIXED_SLOPE` for a
    channel its format documents (``signals.fixed``, while :data:`TRUST_FIXED_CHANNELS`), else its ``check``
    (:func:`roll_rate_slope` or :func:`ax_slope`) on the design span (speed ``vx`` m/s, its samples ``moving``)."""
    if TRUST_FIXED_CHANNELS and name in signals.fixed and has_channel(signals, name, moving):
        return FIXED_SLOPE
    return _two_digits(check(signals, vx, moving))


def esp_conditions(cond: dict) -> dict:
    """The log's conditions ``cond`` (:func:`log_conditions`) as for the same log without its roll rate and ``ax``:
    what the estimators of its ESP channels alone are built for."""
    return {**cond, "log_roll_rate": None, "log_ax": None, "log_gyro_unbiased": None, "log_pitch_rate": None}


def _two_digits(x: float | None) -> float | None:
    """``x`` to two significant digits (None stays None)."""
    return None if x is None else float(f"{x:.2g}")


def has_channel(signals, name: str, moving) -> bool:
    """Whether ``signals`` carry the optional channel ``name`` (``"p"``, ``"ax"``) finite on at least
    :data:`ROLL_RATE_SHARE` of the samples ``moving`` (bool mask; none at speed: of all samples)."""
    if getattr(signals, name, None) is None:
        return False
    finite = np.isfinite(np.asarray(getattr(signals, name), dtype=np.float64))
    part = finite[moving] if np.any(moving) else finite
    return bool(part.size) and float(np.mean(part)) >= ROLL_RATE_SHARE


def roll_rate_slope(signals, vx, moving, windows=ROLL_CHECK_WINDOWS_S) -> float | None:
    """How the log's roll rate follows the roll that its ``ay`` shows: the least-squares slope (-) of the kinematic
    estimate ``(ay - vx r)/g`` on the integrated roll rate (rad), both band-passed (:data:`ROLL_CHECK_WINDOWS_S`) and
    read on the samples ``moving`` (at speed, away from the span's ends); 1 for a gyro about the car's forward axis.
    None when the log has no roll rate (:func:`has_channel`), too few samples at speed for the band (a tenth of
    the longer window's) or a roll rate whose integral never moves in the band."""
    if not has_channel(signals, "p", moving):
        return None
    k = (np.asarray(signals.ay, np.float64) - vx * np.asarray(signals.r, np.float64)) / G
    return _slope_on_integral(signals.t, k, signals.p, moving, windows)


def yaw_correlation(signals, moving) -> float:
    """The magnitude (-) of the correlation of the log's roll rate with its yaw rate over the samples ``moving`` where
    both are finite (NaN without a roll rate, with fewer than three such samples or a constant channel): near 1 when
    the roll-rate channel is the yaw rate itself."""
    if getattr(signals, "p", None) is None:
        return math.nan
    p, r = np.asarray(signals.p, np.float64), np.asarray(signals.r, np.float64)
    use = moving & np.isfinite(p) & np.isfinite(r)
    if np.count_nonzero(use) < 3 or np.std(p[use]) == 0 or np.std(r[use]) == 0:
        return math.nan
    return float(abs(np.corrcoef(p[use], r[use])[0, 1]))


def ax_slope(signals, vx, moving) -> float | None:
    """How the log's longitudinal acceleration follows its speed: the slope (-) of ``vx`` (m/s) on the integrated
    ``ax`` (m/s), band-passed and read as :func:`roll_rate_slope`; 1 for an accelerometer along the car's forward
    axis (the grade's slow part of ``ax`` falls out of the band). None as there, for ``ax``."""
    if not has_channel(signals, "ax", moving):
        return None
    return _slope_on_integral(signals.t, vx, signals.ax, moving)


def pitch_rate_slope(signals, vx, moving) -> float | None:
    r"""How the log's pitch rate follows the pitch that its ``ax`` and speed show: the slope (-) of
    :math:`(v_x - \int a_x)/g` (s) on the integral of the pitch from the integrated rate of the Euler pitch
    (:func:`roadbank.models.attitude.euler_pitch_rate` with the kinematic roll), band-passed and read as
    :func:`roll_rate_slope`; 1 for a gyro about the car's left axis. None without a pitch rate or ``ax``
    (:func:`has_channel`) or as there."""
    if not (has_channel(signals, "q", moving) and has_channel(signals, "ax", moving)):
        return None
    t = np.asarray(signals.t, dtype=np.float64)
    level = (vx - running_integral(t, signals.ax)) / G
    rate = euler_pitch_rate(signals.q, signals.r, kinematic_roll(vx, signals.ay, signals.r))
    return _slope_on_integral(t, level, running_integral(t, rate), moving)


def _slope_on_integral(t, level, rate, moving, windows=ROLL_CHECK_WINDOWS_S) -> float | None:
    """The least-squares slope of ``level`` on the time integral of ``rate`` (trapezoidal, non-finite samples as
    0), both band-passed by centred means over ``windows`` (s; the shorter less the longer) and read on the samples
    ``moving`` away from the ends where ``level`` is finite; None with too few (a tenth of the longer window's) or an
    integral that never moves in the band."""
    t = np.asarray(t, dtype=np.float64)
    level = np.asarray(level, np.float64)
    in_samples = band_windows(t, windows)
    use = band_inner(moving & np.isfinite(level), in_samples)
    fit = None if use is None else integral_band_fit(t, level, rate, use, in_samples)
    return None if fit is None else fit[0]


def roll_rate_usable(slope: float | None) -> bool:
    """Whether a log whose :func:`roll_rate_slope` is ``slope`` (the ``log_roll_rate`` of :func:`log_conditions`)
    has a roll rate that the default may use: within :data:`ROLL_SLOPE_RANGE`. The same for :func:`ax_slope`
    (``log_ax``)."""
    return slope is not None and ROLL_SLOPE_RANGE[0] <= slope <= ROLL_SLOPE_RANGE[1]


def default_reads_roll_rate(cond: dict, sensors: SensorSpec | None = None) -> bool:
    """Whether the default (:data:`roadbank.defaults.ESTIMATOR`, ``kinematic-pif``) built for a log's conditions
    ``cond`` (:func:`log_conditions`) with ``sensors`` (default the data sheet's) is :data:`GYRO_FILTER`: a log whose
    roll rate is usable (:func:`roll_rate_usable`), loud (not :func:`is_quiet`) or, with :data:`QUIET_READS_ROLL_RATE`,
    quiet too. That filter has no car model."""
    if not roll_rate_usable(cond.get("log_roll_rate")):
        return False
    quiet = is_quiet(sensors if sensors is not None else SensorSpec(), cond.get("log_rate"), cond.get("log_ay_noise"),
                     QUIET_RATIO, cond.get("log_ay_floor"))
    return not keeps_cars_model(quiet, cond.get("log_roll_rate"), bool(cond.get("log_gyro_unbiased")))


def keeps_cars_model(quiet: bool, roll_rate: float | None, unbiased: bool = False) -> bool:
    """Whether the default (and its offline form, :data:`QUIET_MODELS`) keeps the car's model for a log: a ``quiet`` one
    (:func:`is_quiet`), unless its roll rate (check slope ``roll_rate``, -: :func:`roll_rate_usable`) is usable and
    :data:`QUIET_READS_ROLL_RATE` is True, or ``"unbiased"`` and the roll rate is documented free of offset
    (``unbiased``: an INS's, ``Signals.unbiased``)."""
    choice = _setting("QUIET_READS_ROLL_RATE")
    reads = choice is True or (choice == "unbiased" and bool(unbiased))
    return bool(quiet) and not (reads and roll_rate_usable(roll_rate))


def _octave_top(t) -> float:
    """The top (Hz) of the band in which :func:`log_conditions` reads the noise of samples at times ``t`` (s):
    :data:`NOISE_OCTAVE_TOP` times :func:`roadbank.signals.noise_band_hz` of their rate where :data:`NOISE_OCTAVE`
    says so, else none."""
    if NOISE_OCTAVE not in NOISE_OCTAVES:
        raise ValueError(f"NOISE_OCTAVE must be one of {NOISE_OCTAVES}, got {NOISE_OCTAVE!r}")
    band = noise_band_hz(sample_rate(t))
    if NOISE_OCTAVE == "none" or (NOISE_OCTAVE == "fast" and band < DYNAMICS_BAND_HZ):
        return math.inf
    return NOISE_OCTAVE_TOP * band


def _noise(x, t, valid) -> float:
    """:func:`roadbank.signals.road_noise_std` (unit of ``x``) in the band :func:`_octave_top` says."""
    return road_noise_std(x, t, valid, top_hz=_octave_top(t))


def _floor(x, t, valid) -> float:
    """:func:`roadbank.signals.road_noise_floor_std` (unit of ``x``) in the band :func:`_octave_top` says."""
    return road_noise_floor_std(x, t, valid, top_hz=_octave_top(t))


def _design_part(signals, v_min: float):
    """``(signals, vx m/s, moving)``: the log's first :data:`DESIGN_SPAN_S` of driving (:func:`design_span`) with each
    single dropout bridged (:func:`~roadbank.signals.bridged`), its speed and where it is at least ``v_min`` (m/s)."""
    n = design_span(signals, v_min)
    signals = bridged(signals[:n] if n < len(signals) else signals)      # a single dropout does not move the design
    vx = np.asarray(signals.vx, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return signals, vx, vx >= v_min


def _source_steps(signals, moving, channels=("ay", "r")) -> dict[str, int]:
    """``{"ay": k, "r": k}`` (of ``channels``): the log samples per sample of each channel's source
    (:func:`roadbank.signals.source_step` on the ``moving`` samples) that :data:`NOISE_AT_SOURCE` reads at the source's
    rate, 1 for the others."""
    at, rounding = _setting("NOISE_AT_SOURCE"), _setting("SOURCE_ROUNDING")
    read = {"ay": at != "none", "r": at == "all"}
    return {c: source_step(getattr(signals, c), moving, rounding) if read[c] else 1 for c in channels}


def source_rates(signals, v_min: float = 5.0) -> dict[str, float]:
    """The channels of ``signals`` whose noise :func:`log_conditions` reads at their source's rate, because a logger
    wrote them faster than their sensor: ``{"ay" or "r": the source's rate (Hz)}`` (empty for a log at its sensors'
    rate), on the same samples as :func:`log_conditions`."""
    signals, _, moving = _design_part(signals, v_min)
    rate = sample_rate(signals.t)
    return {ch: rate / k for ch, k in _source_steps(signals, moving).items() if k > 1}


def _at_source(read, x, t, valid, k: int) -> float:
    """``read(x, t, valid)`` (a noise standard deviation, unit of ``x``; ``t`` s) of a channel whose source is ``k``
    times slower than the log (:func:`roadbank.signals.source_step`): read on every ``k``-th sample, where the
    source's noise is, and returned as the standard deviation that white noise of the same density has at the
    log's rate (times ``sqrt(k)``)."""
    if k < 2:
        return read(x, t, valid)
    return math.sqrt(k) * read(np.asarray(x)[::k], np.asarray(t)[::k], np.asarray(valid)[::k])


#: how many times the ay noise floor (standard deviation) of the minute a log was designed on a later stretch of its
#: driving must read for :class:`RoadCheck` to count it as loud: a log designed quiet whose roads turn rough keeps the
#: car's model (a long drive's test: a smooth first minute, then rough roads, 2.5 times the error of the same drives
#: designed on their own)
LOUDER_FACTOR = 3.0
#: the stretches of log time (s) :class:`RoadCheck` and the hand-over (:class:`roadbank.estimators.HandOver`) read, and
#: the driving (s at 5 m/s or more) a stretch needs
ROAD_CHECK_WINDOW_S = 60.0
ROAD_CHECK_MIN_S = 30.0


def ay_floor_of(signals, v_min: float = 5.0) -> float:
    """The noise floor (m/s^2) of the ``ay`` of ``signals`` on its samples at ``vx >= v_min`` (m/s), read at the log's
    own rate in the band the design reads (:func:`_floor`), each single dropout bridged
    (:func:`~roadbank.signals.bridged`); NaN where too few."""
    signals = bridged(signals)
    with np.errstate(invalid="ignore"):
        moving = np.asarray(signals.vx, dtype=np.float64) >= v_min
    return _floor(np.asarray(signals.ay, dtype=np.float64), np.asarray(signals.t, dtype=np.float64), moving)


def design_ay_floor(signals, v_min: float = 5.0) -> float:
    """:func:`ay_floor_of` (m/s^2) of the part of ``signals`` the design reads (its first :data:`DESIGN_SPAN_S` of
    driving, :func:`design_span`)."""
    return ay_floor_of(_design_part(signals, v_min)[0], v_min)


class RoadCheck:
    """Whether a log's roads stay as quiet as the minute it was designed on: fed the log chunk by chunk
    (:meth:`add`; the same result whatever the chunks), it reads :func:`ay_floor_of` on each stretch of
    :data:`ROAD_CHECK_WINDOW_S` s of log time with at least :data:`ROAD_CHECK_MIN_S` s of driving, and counts the
    driving of those louder than :data:`LOUDER_FACTOR` times ``design_floor`` (m/s^2, :func:`ay_floor_of` of the
    design's minute). :meth:`finish` returns ``(loud s, driving s)``."""

    def __init__(self, design_floor: float, v_min: float = 5.0):
        self.design_floor, self.v_min = float(design_floor), float(v_min)
        self._t0 = math.nan
        self._window = -1
        self._parts: list = []
        self.loud_s = self.driving_s = 0.0

    def add(self, signals) -> None:
        """The log's next chunk (:class:`~roadbank.signals.Signals`)."""
        t = np.asarray(signals.t, dtype=np.float64)
        if math.isnan(self._t0) and np.isfinite(t).any():
            self._t0 = float(t[np.isfinite(t)][0])
        w = stretch_index(t, self._t0, ROAD_CHECK_WINDOW_S)
        for win in np.unique(w):
            if win != self._window:
                self._close()
                self._window = int(win)
            self._parts.append(signals.take(np.flatnonzero(w == win)))

    def _close(self) -> None:
        if not self._parts:
            return
        part = concat_signals(self._parts)
        self._parts = []
        driving = driving_s(part, self.v_min)
        if driving < ROAD_CHECK_MIN_S:
            return
        self.driving_s += driving
        if ay_floor_of(part, self.v_min) > LOUDER_FACTOR * self.design_floor:
            self.loud_s += driving

    def finish(self) -> tuple[float, float]:
        """``(loud s, driving s)`` over the log (after its last chunk)."""
        self._close()
        return self.loud_s, self.driving_s


def loud_stretch(stretch, *, design_floor: float, sensors: SensorSpec, ratio: float = QUIET_RATIO,
                 v_min: float = 5.0) -> dict | None:
    """The conditions (:func:`log_conditions`) of a stretch of a log designed quiet, where its roads have turned loud:
    it drives :data:`ROAD_CHECK_MIN_S` or more at ``vx >= v_min`` (m/s), its ``ay`` floor as the design reads it
    (``log_ay_floor``, m/s^2) is at least :data:`LOUDER_FACTOR` times ``design_floor`` (the design's, m/s^2), and its
    own conditions would not keep the car's model (:func:`is_quiet` with ``sensors`` and ``ratio``,
    :func:`keeps_cars_model`); else None (a stretch whose conditions cannot be read too)."""
    if driving_s(stretch, v_min) < ROAD_CHECK_MIN_S:
        return None
    if not quiet_floor_of(stretch, v_min) >= LOUDER_FACTOR * design_floor:     # (the rest read only where it is)
        return None
    read = _stretch_design(stretch, sensors, ratio, v_min)
    return read[0] if read is not None and not read[1] else None


def quiet_stretch(stretch, *, sensors: SensorSpec, ratio: float = QUIET_RATIO, v_min: float = 5.0) -> dict | None:
    """The conditions (:func:`log_conditions`) of a stretch of a log designed loud, where its roads have turned quiet:
    it drives :data:`ROAD_CHECK_MIN_S` or more at ``vx >= v_min`` (m/s) and its own conditions keep the car's model
    (:func:`is_quiet` with ``sensors`` and ``ratio``, :func:`keeps_cars_model`), as a log's first minute would; else
    None (a stretch whose conditions cannot be read too)."""
    if driving_s(stretch, v_min) < ROAD_CHECK_MIN_S:
        return None
    floor, rate = floor_and_rate(stretch, v_min)
    if not is_quiet(sensors, rate, None, ratio, floor):        # (the rest read only where it is)
        return None
    read = _stretch_design(stretch, sensors, ratio, v_min)
    return read[0] if read is not None and read[1] else None


def _stretch_design(stretch, sensors: SensorSpec, ratio: float, v_min: float) -> tuple[dict, bool] | None:
    """A stretch's conditions (:func:`log_conditions`) and whether they would keep the car's model (:func:`is_quiet`
    with ``sensors`` and ``ratio``, :func:`keeps_cars_model`); None where they cannot be read."""
    try:
        cond = log_conditions(stretch, v_min)
    except LogError:
        return None
    quiet = is_quiet(sensors, cond["log_rate"], cond["log_ay_noise"], ratio, cond["log_ay_floor"])
    return cond, keeps_cars_model(quiet, cond["log_roll_rate"], bool(cond["log_gyro_unbiased"]))


def handed_over_warnings(source: str, handed: dict, t0: float) -> list[str]:
    """What ``roadbank estimate`` and ``map`` say of the estimators of ``handed`` (name -> (the log time, s, of the
    first sample of the handed-over design's outputs, that design); ``t0``: the log's first stamp, s) that a log
    designed quiet handed to the design of its first loud stretch (:class:`roadbank.estimators.HandOver`)."""
    def what(est) -> str:
        return (f"{GYRO_FILTER}, the gyro-aided filter (the log has a roll rate)"
                if getattr(est, "first_input", None) == "p" else "the low-pass blend")
    return [f"{source}: designed on its first minute of driving, which reads quiet ({n} is "
            f"{QUIET_MODELS.get(n, n)}: the car's model), but its roads turned loud: from {at - t0:.1f} s on {n} is "
            f"{what(to)}, designed for its first loud minute" for n, (at, to) in handed.items()]


def louder_warnings(path: str, names, roll_rate: float | None, loud_s: float, driving_s: float) -> list[str]:
    """A warning (a list of at most one) where a log designed quiet reads loud on at least half of its driving
    (``loud_s`` of ``driving_s`` s, :class:`RoadCheck`): the estimators of ``names`` that keep the car's model there
    hold it over roads where the low-pass blend does better (``roll_rate``: the log's roll-rate check slope,
    ``log_roll_rate``, -; a usable one is said not read). None of them among ``names`` (those handed over to another
    design, :class:`roadbank.estimators.HandOver`, are left out by the caller): no warning."""
    which = ", ".join(f"{n} is {QUIET_MODELS[n]}" for n in names if n in QUIET_MODELS)
    if not (which and driving_s > 0 and loud_s >= 0.5 * driving_s):
        return []
    unread = ", its roll rate not read" if roll_rate_usable(roll_rate) else ""
    return [f"{path}: designed on its first minute of driving, which reads quiet (so {which}: the car's model"
            f"{unread}), but {loud_s / 60:.1f} of its {driving_s / 60:.1f} minutes of driving read at least "
            f"{LOUDER_FACTOR:g} times that ay noise, where the car's model does worse than the low-pass blend (a "
            "drive onto rougher roads): split the log where the road changes, so that each piece is designed on "
            "its own first minute"]


def _floor_signal(signals, vx: np.ndarray) -> np.ndarray:
    """The channel :data:`QUIET_FLOOR_SIGNAL` names (m/s^2) of ``signals``, speed ``vx`` (m/s)."""
    if QUIET_FLOOR_SIGNAL not in QUIET_FLOOR_SIGNALS:
        raise ValueError(f"QUIET_FLOOR_SIGNAL must be one of {QUIET_FLOOR_SIGNALS}, got {QUIET_FLOOR_SIGNAL!r}")
    ay = np.asarray(signals.ay, dtype=np.float64)
    if QUIET_FLOOR_SIGNAL == "ay":
        return ay
    with np.errstate(invalid="ignore"):
        return ay - vx * np.asarray(signals.r, dtype=np.float64)


def noise_densities(sensors: SensorSpec, log_rate: float | None = None, log_ay_noise: float | None = None,
                    log_r_noise: float | None = None) -> tuple[float, float]:
    """The noise densities ``(R, Q_ay)`` of a sensor-weighted PIF for a log: the one rule.

    * ``R`` ((rad/s)^2 s), the yaw-rate noise density: the yaw-rate sensor's noise and
      resolution at the rate of the log it will run on (:meth:`SensorSpec.r_noise_density`);
    * ``Q_ay`` ((m/s^2)^2 s), the noise density of the ``ay`` input: the accelerometer's at that
      rate (:meth:`SensorSpec.ay_noise_density`), or the road noise measured on the log's own
      ``ay`` (``log_ay_noise``, :func:`log_conditions`) where that is larger — vibration of the
      road, the body or the mount that no data sheet knows (a phone IMU, a 10 Hz INS that
      samples without an anti-alias filter);
    * likewise ``R`` from the road noise of the log's yaw rate (``log_r_noise``) where that is
      larger than the sensor's.

    Parameters
    ----------
    sensors : SensorSpec
        The car's sensor cluster; its yaw-rate noise or resolution must not both be 0.
    log_rate : float, optional
        Sample rate of the log (Hz); None or not a positive finite number: ``sensors.rate``.
    log_ay_noise, log_r_noise : float, optional
        Road-noise standard deviation of the log's ``ay`` (m/s^2) and yaw rate (rad/s); None
        or NaN: not measured.

    Returns
    -------
    tuple of float
        ``(R, Q_ay)``.
    """
    rate = sensors.rate_for(log_rate)
    Q_ay, R = sensors.ay_noise_density(rate), sensors.r_noise_density(rate)
    if log_ay_noise is not None and math.isfinite(log_ay_noise):
        Q_ay = max(Q_ay, log_ay_noise ** 2 / rate)
    if log_r_noise is not None and math.isfinite(log_r_noise):
        R = max(R, log_r_noise ** 2 / rate)
    return R, Q_ay


def is_quiet(sensors: SensorSpec, log_rate: float | None = None, log_ay_noise: float | None = None,
             ratio: float = QUIET_RATIO, log_ay_floor: float | None = None) -> bool:
    """Whether a log's ``ay`` is quiet: its noise floor (``log_ay_floor``, m/s^2, at ``log_rate`` Hz:
    :func:`log_conditions`; not given or NaN: its road noise ``log_ay_noise``), as a density, at most
    ``ratio`` times the accelerometer's data-sheet density at that rate (:meth:`SensorSpec.ay_noise_density`).

    The floor, not the road noise over the whole span, because the question is the sensor's and the
    road's: a manoeuvre at the tyres' limit reaches past the dynamics band for a few seconds, and a
    limit drive on the data sheet's sensors would read loud by its mean (the ninth stage of
    :mod:`roadbank.tuning.real`, docs/estimators.md). The design's weights keep the road noise.

    A car's ESP sensor on a smooth road (and every simulated drive: 0.93-1.13 times) is quiet; a
    road that shakes the accelerometer, a 10 Hz INS that samples without an anti-alias filter, a
    phone is not (the KITTI training drives: 15-190 times the paper's ESP accelerometer).
    Not measured (None or NaN) or ``ratio <= 0``: False.
    """
    return ratio > 0 and quiet_noise_ratio(sensors, log_rate, log_ay_noise, log_ay_floor) <= ratio


def quiet_noise_ratio(sensors: SensorSpec, log_rate: float | None = None, log_ay_noise: float | None = None,
                      log_ay_floor: float | None = None) -> float:
    """The number :func:`is_quiet` compares with its ratio (-): the density of the log's ``ay`` noise floor
    (``log_ay_floor``, m/s^2; not given or NaN: its road noise ``log_ay_noise``) at ``log_rate`` Hz over the
    accelerometer's data-sheet density at that rate. NaN when neither is measured; 0 for a noiseless log,
    infinite for a noisy one on a sensor without noise."""
    noise = log_ay_floor if log_ay_floor is not None and math.isfinite(log_ay_floor) else log_ay_noise
    if noise is None or not math.isfinite(noise):
        return math.nan
    rate = sensors.rate_for(log_rate)
    density, sheet = noise ** 2 / rate, sensors.ay_noise_density(rate)
    if density == 0.0:
        return 0.0
    return density / sheet if sheet > 0 else math.inf


def make_estimator(name: str, params: VehicleParams | None = None, *, sensors: SensorSpec | None = None,
                   log_rate: float | None = None, log_ay_noise: float | None = None,
                   log_r_noise: float | None = None, log_ay_floor: float | None = None,
                   log_diff_noise: float | None = None, log_roll_rate: float | None = None,
                   log_ax: float | None = None, log_gyro_unbiased: float | None = None,
                   log_pitch_rate: float | None = None, log_r_source: float | None = None,
                   log_held: float | None = None, **options):
    """``estimators.make(name, params, **options)`` for a log sampled at ``log_rate`` by ``sensors``.

    A default-tuned PIF (:func:`roadbank.estimators.pif.with_sensor_noise`) gets the weights
    :func:`noise_densities` of ``sensors`` at the log's conditions; a sensor without yaw-rate
    noise or resolution leaves the estimator's own weights.

    ``roadbank estimate``/``map`` (:mod:`roadbank.fleet`, :mod:`roadbank.mapping`),
    :meth:`Vehicle.make` and the real-data validation all build their estimators here.

    Parameters
    ----------
    name : str
        One of :data:`roadbank.estimators.NAMES`.
    params : VehicleParams, optional
        The car (default the paper's SUV).
    sensors : SensorSpec, optional
        Its sensor cluster (default the paper's ESP sensors).
    log_rate : float, optional
        Sample rate (Hz) of the log (:func:`roadbank.signals.sample_rate` of its time
        base). Default (or NaN): ``sensors.rate``.
    log_ay_noise, log_r_noise : float, optional
        Road-noise standard deviation of the log's ``ay`` (m/s^2) and yaw rate (rad/s)
        (:func:`roadbank.signals.road_noise_std`); None or NaN: not measured.
    log_ay_floor : float, optional
        Noise floor of the log's ``ay`` (m/s^2, :func:`roadbank.signals.road_noise_floor_std`), what
        :func:`is_quiet` reads; None or NaN: ``log_ay_noise``.
    log_diff_noise : float, optional
        Noise of the log's kinematic acceleration ``ay - vx r`` by its first differences (m/s^2,
        :func:`roadbank.signals.diff_noise_std`): the blend's low-pass (``kinematic-pif``) follows a running
        estimate of it (``noise_ref``, its square), unless ``noise_ref`` is given; None or NaN: it does not.
    log_roll_rate : float, optional
        How the log's roll rate follows its ``ay`` (:func:`roll_rate_slope`; None or NaN: it has none). Where it does
        (:func:`roll_rate_usable`), ``kinematic-pif`` is :data:`GYRO_FILTER` on a loud log (named ``kinematic-pif``, as
        on a quiet one; unless the options set the gate), ``kinematic-smoother`` its offline form
        (:data:`GYRO_MODELS`), with the options every estimator takes
        (:data:`roadbank.estimators.base.ESTIMATOR_OPTIONS`).
    log_ax : float, optional
        How the log's longitudinal acceleration follows its speed (:func:`ax_slope`; None or NaN: it has none). Where
        it does (:func:`roll_rate_usable`), that gyro-aided filter corrects the roll rate for the grade (its
        ``grade_window``, :data:`roadbank.estimators.gyro.GRADE_WINDOW_S`); where not, it does not.
    log_gyro_unbiased : float, optional
        1 (truthy) where the log's roll rate is documented free of offset (``Signals.unbiased``): that gyro-aided
        filter takes :data:`roadbank.estimators.gyro.UNBIASED_GYRO_CUTOFF_HZ` and ``UNBIASED_GYRO_BIAS_TAU_S`` (the
        thirty-sixth stage of :mod:`roadbank.tuning.real`).
    log_pitch_rate : float, optional
        How the log's pitch rate, documented free of offset, follows the pitch its ``ax`` shows
        (:func:`pitch_rate_slope`; None: it has none, or one not so documented). Where it does
        (:func:`roll_rate_usable`) and the grade is corrected, that filter reads the pitch from the pitch rate
        (``pitch_bandwidth`` :data:`roadbank.estimators.gyro.UNBIASED_PITCH_BANDWIDTH`, ``pitch_start``
        ``UNBIASED_PITCH_START`` and ``pitch_anchor`` ``UNBIASED_PITCH_ANCHOR``, the thirty-ninth to forty-fifth
        stages).
    log_r_source : float, optional
        The rate (Hz) of the yaw rate's sensor where a logger wrote it faster (:data:`GATE_AT_SOURCE`): the blend's
        gate then filters the yaw rate over at least that sensor's interval (``gate_tf``), unless given.
    log_held : float, optional
        1 (truthy) where the log was written by holding a slower sensor's frames (:data:`READ_AT_SOURCE`; the other
        conditions then read on the rows that bring new values): the estimator reads those rows alone
        (:class:`roadbank.estimators.AtSource`).
    **options
        The estimator's keyword options; an explicit ``R``, ``Q_ay`` or ``tuning`` keeps the
        sensor out of that weight. ``kinematic-pif`` also takes ``quiet_ratio`` (-, default
        :data:`QUIET_RATIO`; 0: never) and ``quiet_filter`` (default :data:`QUIET_FILTER`): on a
        quiet log (:func:`is_quiet` with that ratio) it is that filter, with the car's model,
        built from the same options less those of the low-pass and the gate and
        named ``kinematic-pif`` (its outputs keep their columns); unless the options set the
        gate themselves, or the log's usable roll rate is documented free of offset (``log_gyro_unbiased``,
        :data:`QUIET_READS_ROLL_RATE`: then the gyro-aided filter). ``kinematic-smoother`` likewise
        (:data:`QUIET_MODELS`: ``pif-smoother``). The causal one is handed over to the design of the log's
        first loud stretch where its roads turn loud (:class:`roadbank.estimators.HandOver`,
        :func:`loud_stretch`, :data:`ROAD_CHANGE`), needing ``log_ay_floor``.
        ``described`` (bool, default True): False for a car nobody described (the one
        :func:`roadbank.vehicle.undescribed_params` chose for the log), whose quiet log the causal default then designs
        as a loud one unless :data:`UNDESCRIBED_KEEPS_MODEL` (:func:`models_car`).
        The blend's low-pass gets the sampled-data lead of the log's rate:
        ``lead = lead_samples / rate`` (s; ``lead_samples`` default
        :data:`~roadbank.estimators.gated.KINEMATIC_PIF_LEAD_SAMPLES`), unless ``lead`` is given.
    """
    from .. import estimators
    from ..estimators.pif import with_sensor_noise

    sensors = sensors if sensors is not None else SensorSpec()
    label = name
    given = dict(options)                   # what a design for another stretch of the log is built with
    described = bool(options.pop("described", True))
    handover = None
    if name in QUIET_MODELS:
        ratio = float(options.pop("quiet_ratio", QUIET_RATIO))
        ratio = ratio if models_car(name, described) else 0.0
        quiet_filter = options.pop("quiet_filter", QUIET_MODELS[name])
        lead_samples = (float(options.pop("lead_samples", estimators.gated.KINEMATIC_PIF_LEAD_SAMPLES))
                        if name == "kinematic-pif" else None)        # the blend's option only
        own_gate = any(k in options for k in _GATE_OPTIONS)
        if not own_gate and keeps_cars_model(is_quiet(sensors, log_rate, log_ay_noise, ratio, log_ay_floor),
                                             log_roll_rate, bool(log_gyro_unbiased)):
            name, options = quiet_filter, {k: v for k, v in options.items() if k not in _BLEND_OPTIONS}
            if hands_over(log_roll_rate) and label not in estimators.OFFLINE and log_ay_floor is not None:
                handover = (partial(loud_stretch, design_floor=log_ay_floor, sensors=sensors, ratio=ratio),
                            partial(make_estimator, label, params, sensors=sensors, **given))
        elif not own_gate and roll_rate_usable(log_roll_rate):
            # the default's roll separation (its PIF's tuning chose the roll model) unless the options name one
            roll = estimators.pif.DEFAULT_TUNING["roll"]
            window = estimators.gyro.GRADE_WINDOW_S if roll_rate_usable(log_ax) else 0.0
            name, options = GYRO_MODELS[name], {"roll": roll, "grade_window": window,
                                                **{k: v for k, v in options.items()
                                                   if k in estimators.base.ESTIMATOR_OPTIONS}}
            if log_gyro_unbiased:
                options = {**estimators.gyro.UNBIASED_GYRO, **options}
            if window > 0 and roll_rate_usable(log_pitch_rate):
                options = {**estimators.gyro.UNBIASED_PITCH, **options}
        elif lead_samples is not None:
            options.setdefault("lead", lead_samples / sensors.rate_for(log_rate))
            if _setting("BLEND_GATE_V_MIN") is not None:
                options.setdefault("gate_v_min", BLEND_GATE_V_MIN)
            if log_r_source is not None and log_r_source > 0:
                options.setdefault("gate_tf", max(estimators.gated.GATED_TUNING["gate_tf"], 1.0 / log_r_source))
            if log_diff_noise is not None and math.isfinite(log_diff_noise) and log_diff_noise > 0:
                options.setdefault("noise_ref", log_diff_noise ** 2)
        if (name != quiet_filter and not own_gate and ratio > 0
                and hands_back(label not in estimators.OFFLINE, log_roll_rate, bool(log_gyro_unbiased))):
            handover = (partial(quiet_stretch, sensors=sensors, ratio=ratio),
                        partial(make_estimator, label, params, sensors=sensors, **given))
    if sensors.r_variance > 0:
        R, Q_ay = noise_densities(sensors, log_rate, log_ay_noise, log_r_noise)
        options = with_sensor_noise(name, options, R, Q_ay)
        if name in LIMITED_LOWPASSES:       # the noise its update's limit is measured in
            options = {"Q_ay": Q_ay, "R": R, **options}
    est = estimators.make(name, params, **options)
    est.name = label
    out: Any = est
    if name == "kinematic-smoother" and _setting("SMOOTHER_GATE"):
        model = make_estimator("pif-smoother", params, sensors=sensors, log_rate=log_rate, log_ay_noise=log_ay_noise,
                               log_r_noise=log_r_noise, **{k: v for k, v in given.items()
                                                           if k in estimators.base.ESTIMATOR_OPTIONS})
        gate = estimators.gated.KINEMATIC_PIF_GATE
        out = estimators.GatedSmoother(est, model, gate_tf=gate["gate_tf"], gate_on=gate["gate_on"],
                                       gate_span=gate["gate_span"], hold=_setting("SMOOTHER_GATE_HOLD_S"),
                                       v_gate=_setting("SMOOTHER_GATE_V_MIN"))
    out = out if handover is None else estimators.HandOver(out, *handover, stretch_s=ROAD_CHECK_WINDOW_S)
    return estimators.AtSource(out) if log_held else out


def hands_over(roll_rate: float | None) -> bool:
    """Whether a log designed quiet whose check slope of the roll rate is ``roll_rate`` (-, None: it has none) is handed
    over when its roads turn loud (:data:`ROAD_CHANGE`)."""
    choice = _setting("ROAD_CHANGE")
    return choice is True or (choice == "esp" and not roll_rate_usable(roll_rate))


def hands_back(causal: bool, roll_rate: float | None, unbiased: bool) -> bool:
    """Whether the default's loud design of a log (a ``causal`` estimator; check slope ``roll_rate`` of its roll rate,
    -, None: it has none; ``unbiased``: documented free of offset) is handed back to the car's model where its roads
    turn quiet (:data:`ROAD_CHANGE_BACK`): where a quiet log would keep the car's model and a log designed quiet would
    be handed over (:func:`hands_over`)."""
    return (_setting("ROAD_CHANGE_BACK") and causal and keeps_cars_model(True, roll_rate, unbiased)
            and hands_over(roll_rate))


def _setting(name: str, choices: str | None = None):
    """The module setting ``name`` (one of this module's constants that the stages of :mod:`roadbank.tuning.real`
    choose, :func:`~roadbank.tuning.real.design_settings` sets), checked against its choices (the constant
    ``choices``, default ``<name>_CHOICES``) when a design reads it: a ValueError where it is none of them."""
    value, allowed = globals()[name], globals()[choices or f"{name}_CHOICES"]
    if value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    return value


def rear_trim_scales(choice=None) -> tuple:
    """The scales (-) of a described car's rear cornering stiffness that the trim to each log tries for ``choice``
    (one of :data:`REAR_TRIM_CHOICES`; default :data:`REAR_TRIM`): none where it is off, those of
    :data:`REAR_TRIM_SCALES` at most 1 where ``"softer"``."""
    if choice is None:
        choice = _setting("REAR_TRIM")
    elif choice not in REAR_TRIM_CHOICES:
        raise ValueError(f"the rear trim must be one of {REAR_TRIM_CHOICES}, got {choice!r}")
    if choice is False:
        return ()
    return tuple(k for k in REAR_TRIM_SCALES if choice is True or k <= 1.0)


def models_car(name: str, described: bool) -> bool:
    """Whether ``name`` (one of :data:`QUIET_MODELS`) may keep the car's model on a quiet log, its car ``described``
    (a vehicle file, parameters given) or not (:data:`UNDESCRIBED_KEEPS_MODEL` for the causal default,
    :data:`UNDESCRIBED_SMOOTHER_KEEPS_MODEL` for the offline ``kinematic-smoother``)."""
    setting = "UNDESCRIBED_SMOOTHER_KEEPS_MODEL" if name == "kinematic-smoother" else "UNDESCRIBED_KEEPS_MODEL"
    return described or _setting(setting, "UNDESCRIBED_KEEPS_MODEL_CHOICES")
