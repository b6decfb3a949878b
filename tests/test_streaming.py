"""step() and run() are the same computation; chunked streaming equals one run."""

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E

from conftest import linear_plant_run


def noisy_log(seed=0):
    signals, _ = linear_plant_run(__import__("roadbank").VehicleParams(), T=8.0)
    rng = np.random.default_rng(seed)
    n = len(signals)
    t = signals.t + rng.uniform(-2e-3, 2e-3, n) * (np.arange(n) > 0)   # irregular sampling
    vx = signals.vx + np.linspace(0, 10, n)
    ay = signals.ay + 0.05 * rng.normal(size=n)
    r = signals.r + 0.002 * rng.normal(size=n)
    ay[300:304] = np.nan                                     # a short dropout
    vx[500:520] = 2.0                                        # below v_min
    return Signals(t, vx, ay, r, signals.delta_f)


ALL = list(E.NAMES) + ["pif-riccati"]
#: run() of these equals their step()s; an offline estimator's run() also uses later samples
CAUSAL = [n for n in ALL if n not in E.OFFLINE]


def build(name):
    if name == "pif-riccati":
        return E.make("pif-modified", variant="riccati", roll="dynamic")
    return E.make(name, roll="dynamic")


@pytest.mark.parametrize("name", CAUSAL)
def test_step_equals_run(name):
    s = noisy_log()
    batch = build(name).run(s)
    est = build(name)
    out = [est.step(s.t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]) for k in range(len(s))]
    assert np.array_equal(batch.w, [o.w for o in out])
    assert np.array_equal(batch.phi_b, [o.phi_b for o in out])
    assert np.array_equal(batch.valid, [o.valid for o in out])


@pytest.mark.parametrize("name", CAUSAL)
def test_chunked_run_equals_one_run(name):
    s = noisy_log(1)
    whole = build(name).run(s)
    est = build(name)
    cuts = [0, 1, 2, 157, 301, 302, 777, len(s)]
    parts = [est.run(s[a:b], reset=(a == 0)) for a, b in zip(cuts[:-1], cuts[1:])]
    for field in ("w", "theta", "phi_b", "valid"):
        assert np.array_equal(getattr(whole, field), np.concatenate([getattr(p, field) for p in parts]))


def test_smoother_steps_are_the_filter_and_its_run_ends_on_it():
    """The smoothed estimate of the newest sample given the samples so far is the filtered one:
    step() of pif-smoother is pif-modified's, and its run() meets the filter's last estimate
    at the end of the log (and nowhere else in general)."""
    s = noisy_log(3)
    est = build("pif-smoother")
    out = np.array([est.step(s.t[k], s.vx[k], s.ay[k], s.r[k], s.delta_f[k]).w for k in range(len(s))])
    filt = build("pif-modified").run(s)
    assert np.array_equal(out, filt.w)
    smooth = build("pif-smoother").run(s)
    assert smooth.w[-1] == filt.w[-1] and smooth.valid[-1]
    assert np.max(np.abs(smooth.w - filt.w)[smooth.valid]) > 1e-3
    assert np.array_equal(smooth.valid, filt.valid)


def test_reset_restarts():
    s = noisy_log(2)
    est = E.make("pif-modified")
    a = est.run(s)
    b = est.run(s)              # run() resets by default
    assert np.array_equal(a.w, b.w)


@pytest.mark.parametrize("build_one", [lambda: E.make("pif-modified"), lambda: E.make("kinematic-gyro"),
                                       lambda: E.with_online_offsets(E.make("pif-modified"))],
                         ids=["pif-modified", "kinematic-gyro", "online-offsets"])
def test_step_with_arrays_says_it_takes_one_sample(build_one):
    """step() given arrays (a whole log) or None is told to take one number per channel, or run() for arrays; the
    estimator's state is untouched, so the next sample is processed as if the call had not been made."""
    est, clean = build_one(), build_one()
    est.step(0.0, 20.0, 0.5, 0.02, 0.0, **({"p": 0.0} if est.name == "kinematic-gyro" else {}))
    clean.step(0.0, 20.0, 0.5, 0.02, 0.0, **({"p": 0.0} if clean.name == "kinematic-gyro" else {}))
    for bad in (np.arange(3.0), None):
        with pytest.raises(TypeError, match=r"step\(\) takes one sample.*run\(Signals"):
            est.step(0.01, 20.0, bad, 0.02, 0.0)
    extra = {"p": 0.001} if est.name == "kinematic-gyro" else {}
    assert est.step(0.01, 20.0, 0.5, 0.02, 0.0, **extra) == clean.step(0.01, 20.0, 0.5, 0.02, 0.0, **extra)
