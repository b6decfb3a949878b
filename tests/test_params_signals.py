import numpy as np
import pytest

from roadbank import Signals, VehicleParams, road_wheel_angle


def test_defaults_are_paper_table1():
    p = VehicleParams()
    assert (p.m, p.Iz, p.Lf, p.Lr, p.Cf, p.Cr) == (1687, 3401, 1.15, 1.47, 115000, 396820)


@pytest.mark.parametrize("field,value,msg", [
    ("m", -1.0, "m must be > 0"), ("Lf", 0.0, "Lf must be > 0"), ("Cr", -5.0, "Cr must be > 0"),
    ("Iz", float("nan"), "Iz must be finite"), ("ms", 5000.0, "cannot exceed"),
    ("k_roll", 100.0, "roll stiffness"),
])
def test_invalid_params_raise_clear_errors(field, value, msg):
    with pytest.raises(ValueError, match=msg):
        VehicleParams(**{field: value})


def test_replace_scales_and_validates():
    p = VehicleParams()
    q = p.replace(Cf=1.2 * p.Cf)
    assert q.Cf == pytest.approx(138000) and q.Cr == p.Cr and p.Cf == 115000
    with pytest.raises(ValueError):
        p.replace(m=-3)
    with pytest.raises(TypeError, match="no field"):
        p.replace(mass=3)


def test_signals_validation_messages():
    t = np.arange(5) * 0.01
    ok = np.zeros(5)
    with pytest.raises(ValueError, match="not strictly increasing"):
        Signals(t[::-1], ok, ok, ok, ok)
    with pytest.raises(ValueError, match="mismatched lengths"):
        Signals(t, ok[:4], ok, ok, ok)
    with pytest.raises(ValueError, match="empty"):
        Signals([], [], [], [], [])
    with pytest.raises(ValueError, match="non-finite time"):
        Signals(np.array([0, np.nan, 1, 2, 3.0]), ok, ok, ok, ok)
    s = Signals(t, ok, np.array([0, np.nan, np.inf, 0, 0]), ok, ok)   # NaN data is allowed
    assert len(s) == 5 and len(s[1:3]) == 2


def test_road_wheel_angle_uses_steering_ratio():
    p = VehicleParams(steering_ratio=16.0)
    assert road_wheel_angle(np.deg2rad(160.0), p) == pytest.approx(np.deg2rad(10.0))
    s = Signals.from_steering_wheel([0.0], [20.0], [0.0], [0.0], [np.deg2rad(32.0)], p)
    assert s.delta_f[0] == pytest.approx(np.deg2rad(2.0))


def test_a_log_without_a_steering_angle_is_given_as_none():
    """``Signals(t, vx, ay, r, None)``: the steering angle NaN throughout, as a KITTI drive is read (before: "mismatched
    lengths ... delta_f: 1"); the default estimator runs on it as on the same log with a NaN column."""
    from roadbank import estimators

    t = np.arange(300) * 0.01
    vx, ay, r = np.full(300, 20.0), 0.2 * np.sin(t), 0.01 * np.sin(t)
    s = Signals(t, vx, ay, r, None)
    assert s.delta_f.shape == (300,) and np.isnan(s.delta_f).all()
    same = Signals(t, vx, ay, r, np.full(300, np.nan))
    est = estimators.make("kinematic-pif")
    np.testing.assert_array_equal(est.run(s).theta, est.run(same).theta)


def test_for_log_wants_signals():
    """``for_log(name, a_tuple)``: a TypeError saying what it expects, as ``run()`` gives (before: an AttributeError
    on ``.t`` deep in the design)."""
    from roadbank.vehicle import for_log

    with pytest.raises(TypeError, match=r"for_log\(\) expects a roadbank.Signals, got tuple"):
        for_log("kinematic-pif", (np.arange(3.0), np.ones(3)))
