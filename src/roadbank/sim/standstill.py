"""A standstill before a simulated run: the car at rest at the run's start, then the run.

Real drives start with the car standing (engine started, belts fastened), which is when
ESP software learns its yaw-rate offset. :func:`with_standstill` puts ``seconds`` of
standstill in front of a :class:`~roadbank.sim.scenarios.SimResult`: the car at rest on the
road at the run's first position, with the static body roll the bank causes, measured by
the run's own sensor model (bias, noise, quantisation, misalignment, dropouts). The drive
that follows is the simulated run unchanged, shifted by ``seconds``: the drive-off is not
simulated (it would move the manoeuvre along the road), so the speed steps from rest to the
run's speed in one sample. The standstill's noise comes from a generator of its own
(``default_rng([seed, 1])``), so the drive's samples are exactly those of the run without it.

At rest on a bank :math:`\\phi_b` with grade :math:`\\theta_g` and heading :math:`\\psi` to the
road, the accelerometer reads the specific force of gravity (the plant's accelerometer model
with every motion zero): ``ay = -g_y cos(phi) + g cos(phi_b) cos(theta_g) sin(phi)``,
``ax = -g_x``, with the static roll ``phi = ms h g_l / (k_roll - ms h g_n)`` of the trim
(:func:`roadbank.sim.scenarios.trim_state`). The yaw rate and the wheel speeds are zero; the
steering wheel stays where the run starts. The standstill's tyre forces are not simulated
(NaN in ``truth.Fz``, ``Fx``, ``Fy``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..signals import Signals
from .scenarios import Scenario, SimResult, Truth
from .sensors import measure


def _at_rest(scenario: Scenario, result: SimResult) -> dict:
    """True channels of the car at rest at the run's first position (SI, rad)."""
    tr = result.truth
    v = result.plant.vehicle
    g = v.g
    bank, psi = float(tr.phi_b[0]), float(tr.psi[0])
    grade = float(scenario.road.grade_at(float(tr.s[0])))
    g_t, g_l = -g * math.sin(grade), -g * math.sin(bank) * math.cos(grade)
    g_n = g * math.cos(bank) * math.cos(grade)          # normal specific force at rest
    g_x = g_t * math.cos(psi) + g_l * math.sin(psi)
    g_y = -g_t * math.sin(psi) + g_l * math.cos(psi)
    h = v.h_roll
    phi = v.ms * h * (-g_y) / (v.k_roll - v.ms * h * g_n)
    return {"phi_b": bank, "phi": phi, "ay": -g_y * math.cos(phi) + g_n * math.sin(phi), "ax": -g_x,
            "swa": float(tr.steering_wheel_angle[0])}


def with_standstill(result: SimResult, scenario: Scenario, seconds: float) -> SimResult:
    """``result`` with ``seconds`` (s) of standstill before it (see the module docstring).

    Parameters
    ----------
    result : SimResult
        A run of ``scenario`` (its sensors and seed are used again).
    scenario : Scenario
        The scenario simulated (its road gives the grade at the start).
    seconds : float
        Length of the standstill (s), >= 0; 0 returns ``result`` itself.

    Returns
    -------
    SimResult
        Signals and truth with the standstill first; times start at 0, the drive at
        ``seconds`` (rounded to whole sensor samples).
    """
    if not (math.isfinite(seconds) and seconds >= 0):
        raise ValueError(f"standstill must be a finite number of seconds >= 0, got {seconds}")
    sens = result.sensors
    n = int(round(seconds * sens.rate))
    if n == 0:
        return result
    rest = _at_rest(scenario, result)
    zeros = np.zeros(n)
    rng = np.random.default_rng([result.seed, 1])
    sig = result.signals
    at_rest = {"r": zeros, "ay": np.full(n, rest["ay"]), "ax": np.full(n, rest["ax"]), "v_wheels": zeros,
               "swa": np.full(n, rest["swa"])}
    if sig.p is not None:               # a run with a roll-rate gyro: it reads its error alone at rest
        at_rest["p"] = zeros
    meas = measure(at_rest, sens, rng)
    v = result.plant.vehicle
    shift = n / sens.rate
    t = np.concatenate([np.arange(n) / sens.rate, result.signals.t + shift])
    signals = Signals(t, np.concatenate([meas["vx"], sig.vx]), np.concatenate([meas["ay"], sig.ay]),
                      np.concatenate([meas["r"], sig.r]),
                      np.concatenate([meas["swa"] / v.steering_ratio, sig.delta_f]),
                      p=None if sig.p is None else np.concatenate([meas["p"], sig.p]))
    tr = result.truth
    first = {"phi_b": rest["phi_b"], "phi": rest["phi"], "theta": rest["phi_b"] + rest["phi"], "vy": 0.0,
             "dvy_dt": 0.0, "r": 0.0, "ay_true": rest["ay"], "ax_true": rest["ax"], "vx": 0.0,
             "steering_wheel_angle": rest["swa"], "throttle": 0.0, "brake": 1.0, "s": float(tr.s[0]),
             "n": float(tr.n[0]), "psi": float(tr.psi[0])}
    changes: dict[str, Any] = {"t": t}
    for name, value in first.items():
        changes[name] = np.concatenate([np.full(n, value), getattr(tr, name)])
    for name in ("Fz", "Fx", "Fy"):
        arr = getattr(tr, name)
        changes[name] = np.concatenate([np.full((n,) + arr.shape[1:], np.nan), arr])
    truth: Truth = dataclasses.replace(tr, **changes)
    return dataclasses.replace(result, signals=signals, truth=truth,
                               steering_wheel_angle=np.concatenate([meas["swa"], result.steering_wheel_angle]))
