"""Faults injected into a clean ESP sample stream.

A :class:`Stream` is the five channels as plain arrays (SI, ISO 8855) with no
validation, so it can hold what real logs hold and :class:`roadbank.Signals`
refuses: repeated or decreasing time stamps. Each fault of :data:`FAULTS`
maps a clean stream and a fault window ``[t0, t1)`` (s) to a faulty stream; the
window is where the fault acts, after ``t1`` the signals are clean again.

:func:`feed` runs an estimator over a stream: batch ``run()`` when the time
base is strictly increasing, else sample by sample through ``step()`` (the same
compiled recursion), so every fault reaches the estimator as a real log would.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..signals import Signals


@dataclass(frozen=True)
class Stream:
    """Raw samples: ``t`` (s), ``vx`` (m/s), ``ay`` (m/s^2), ``r`` (rad/s), ``delta_f`` (rad)."""

    t: np.ndarray
    vx: np.ndarray
    ay: np.ndarray
    r: np.ndarray
    delta_f: np.ndarray

    @classmethod
    def from_signals(cls, s: Signals) -> "Stream":
        return cls(*(np.array(getattr(s, c), dtype=float) for c in ("t", "vx", "ay", "r", "delta_f")))

    def take(self, idx) -> "Stream":
        return Stream(*(a[idx] for a in (self.t, self.vx, self.ay, self.r, self.delta_f)))

    def with_(self, **channels) -> "Stream":
        return replace(self, **channels)

    def __len__(self) -> int:
        return len(self.t)


@dataclass(frozen=True)
class Fault:
    """One fault: a name, what it does, and ``func(stream, t0, t1, rng) -> Stream``."""

    name: str
    description: str
    func: Callable[..., Stream]

    def __call__(self, stream: Stream, t0: float, t1: float, seed: int = 0) -> Stream:
        return self.func(stream, float(t0), float(t1), np.random.default_rng(seed))


def _win(s: Stream, t0, t1):
    return (s.t >= t0) & (s.t < t1)


def _set(s: Stream, name: str, t0, t1, value) -> Stream:
    a = getattr(s, name).copy()
    w = _win(s, t0, t1)
    a[w] = value(a[w]) if callable(value) else value
    return s.with_(**{name: a})


def _nan_samples(s, t0, t1, rng):
    """10 % of the samples in the window have NaN in ay or r (chosen at random)."""
    idx = np.flatnonzero(_win(s, t0, t1))
    pick = idx[rng.random(len(idx)) < 0.1]
    ay, r = s.ay.copy(), s.r.copy()
    half = rng.random(len(pick)) < 0.5
    ay[pick[half]] = np.nan
    r[pick[~half]] = np.nan
    return s.with_(ay=ay, r=r)


def _inf_samples(s, t0, t1, rng):
    """+-inf in yaw rate and steering on 10 % of the window's samples."""
    idx = np.flatnonzero(_win(s, t0, t1))
    pick = idx[rng.random(len(idx)) < 0.1]
    r, d = s.r.copy(), s.delta_f.copy()
    r[pick] = np.inf
    d[pick[::2]] = -np.inf
    return s.with_(r=r, delta_f=d)


def _dropout(s, t0, t1, rng):
    """No samples at all in the window (a gap in time of t1 - t0)."""
    return s.take(~_win(s, t0, t1))


def _repeated(s, t0, t1, rng):
    """Every sample in the window is sent twice with the same time stamp, the copy with ay + 2 m/s^2."""
    idx = np.arange(len(s))
    w = _win(s, t0, t1)
    order = np.concatenate([idx, idx[w]])
    pos = np.concatenate([idx.astype(float), idx[w] + 0.5])
    out = s.take(order[np.argsort(pos, kind="stable")])
    dup = np.zeros(len(out), bool)
    dup[np.flatnonzero(np.diff(out.t) == 0) + 1] = True
    ay = out.ay.copy()
    ay[dup] += 2.0
    return out.with_(ay=ay)


def _decreasing(s, t0, t1, rng):
    """Time stamps in the window run 0.3 s behind (a clock jump back at t0, forward at t1)."""
    return _set(s, "t", t0, t1, lambda t: t - 0.3)


def _irregular(s, t0, t1, rng):
    """In the window, samples at irregular instants (period 5-25 ms, random), linearly interpolated."""
    w = _win(s, t0, t1)
    ts = [t0]
    while ts[-1] < t1:
        ts.append(ts[-1] + rng.uniform(0.005, 0.025))
    ts = np.array(ts[:-1])
    chans = {c: np.interp(ts, s.t, getattr(s, c)) for c in ("vx", "ay", "r", "delta_f")}
    before, after = s.take(s.t < t0), s.take(~w & (s.t >= t1))
    return Stream(np.concatenate([before.t, ts, after.t]),
                  *(np.concatenate([getattr(before, c), chans[c], getattr(after, c)])
                    for c in ("vx", "ay", "r", "delta_f")))


def _stuck(name):
    def f(s, t0, t1, rng):
        k = int(np.searchsorted(s.t, t0))
        return _set(s, name, t0, t1, getattr(s, name)[max(k - 1, 0)])
    f.__doc__ = f"{name} stuck at its last value before the window."
    return f


def _bias(name, value):
    def f(s, t0, t1, rng):
        return _set(s, name, t0, t1, lambda a: a + value)
    return f


def _saturate(name, limit):
    def f(s, t0, t1, rng):
        return _set(s, name, t0, t1, lambda a: np.clip(a, -limit, limit))
    return f


def _through_zero(s, t0, t1, rng):
    """Speed ramps from its value down through zero to -3 m/s (reversing) and back, over the window."""
    w = _win(s, t0, t1)
    t = s.t[w]
    v0 = float(s.vx[np.flatnonzero(w)[0]]) if w.any() else 0.0
    x = (t - t0) / (t1 - t0)
    prof = np.where(x < 0.5, v0 + (-3.0 - v0) * 2 * x, -3.0 + (v0 + 3.0) * (2 * x - 1))
    vx = s.vx.copy()
    vx[w] = prof
    return s.with_(vx=vx)


def _extreme_steer(s, t0, t1, rng):
    """Road-wheel angle reads +0.7 rad (about 640 deg at the steering wheel) in the window."""
    return _set(s, "delta_f", t0, t1, 0.7)


#: the faults of the robustness study (``roadbank robustness``, docs/robustness.md), by name
FAULTS: dict[str, Fault] = {f.name: f for f in (
    Fault("nan-samples", "NaN in ay or r on 10 % of the samples", _nan_samples),
    Fault("inf-samples", "+inf yaw rate (and -inf steering) on 10 % of the samples", _inf_samples),
    Fault("dropout", "no samples during the window (gap in time)", _dropout),
    Fault("repeated-time", "every sample repeated with the same time stamp (copy has ay + 2 m/s^2)", _repeated),
    Fault("decreasing-time", "time stamps jump 0.3 s back at the start of the window", _decreasing),
    Fault("irregular-sampling", "sample period random in 5-25 ms", _irregular),
    Fault("stuck-r", "yaw rate stuck at a constant", _stuck("r")),
    Fault("stuck-ay", "lateral acceleration stuck at a constant", _stuck("ay")),
    Fault("bias-step-r", "yaw-rate bias step of +2 deg/s", _bias("r", math.radians(2.0))),
    Fault("bias-step-ay", "ay bias step of +0.5 m/s^2", _bias("ay", 0.5)),
    Fault("saturation-ay", "ay saturated at +-1 m/s^2 (a low-range sensor)", _saturate("ay", 1.0)),
    Fault("speed-through-zero", "speed ramps through zero to -3 m/s (reversing) and back", _through_zero),
    Fault("extreme-steering", "road-wheel angle 0.7 rad (~640 deg steering wheel)", _extreme_steer),
)}


def apply(stream: Stream, fault: str, t0: float, t1: float, seed: int = 0) -> Stream:
    """Apply the fault named ``fault`` (a key of :data:`FAULTS`) on ``[t0, t1)`` s."""
    try:
        f = FAULTS[fault]
    except KeyError:
        raise ValueError(f"unknown fault {fault!r}; known: {', '.join(FAULTS)}") from None
    if not t1 > t0:
        raise ValueError("fault window: t1 must be after t0")
    return f(stream, t0, t1, seed)


@dataclass
class StreamEstimate:
    """Outputs of :func:`feed`: per sample ``t, w, theta, phi_b, valid``."""

    t: np.ndarray
    w: np.ndarray
    theta: np.ndarray
    phi_b: np.ndarray
    valid: np.ndarray


def feed(estimator, stream: Stream) -> StreamEstimate:
    """Run ``estimator`` from reset over ``stream``; ``run()`` if the time base is strictly
    increasing and finite, else ``step()`` sample by sample."""
    t = stream.t
    if len(t) and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0):
        e = estimator.run(Signals(t, stream.vx, stream.ay, stream.r, stream.delta_f))
        return StreamEstimate(e.t, e.w, e.theta, e.phi_b, e.valid)
    estimator.reset()
    n = len(t)
    out = {k: np.empty(n) for k in ("w", "theta", "phi_b")}
    valid = np.empty(n, bool)
    for k in range(n):
        res = estimator.step(t[k], stream.vx[k], stream.ay[k], stream.r[k], stream.delta_f[k])
        out["w"][k], out["theta"][k], out["phi_b"][k], valid[k] = res.w, res.theta, res.phi_b, res.valid
    return StreamEstimate(t.copy(), out["w"], out["theta"], out["phi_b"], valid)
