"""Plant physics against independent truth: linear bicycle model, statics on a bank, coasting."""

import math

import numpy as np
import pytest

from roadbank import G, VehicleParams
from roadbank.sim import Driver, PlantParams, Scenario, SensorConfig, flat_road, run, straight_road, two_lane_road
from roadbank.sim.plant import NX, X_OMEGA, X_VX, f, outputs, A_FYW
from roadbank.sim.road import truth_bank
from roadbank.sim.tyres import fast_atan, fast_sin, fast_sincos, tyre_forces


def test_fast_kernels_accuracy():
    x = np.linspace(-50, 50, 200001)
    assert max(abs(fast_atan(v) - math.atan(v)) for v in x[::97]) < 3e-9
    y = np.linspace(-2.6, 2.6, 10001)
    assert max(abs(fast_sin(v) - math.sin(v)) for v in y) < 1e-7
    # the libm-free sine/cosine pair used for heading, roll and steer angle
    z = np.concatenate([np.linspace(-1000.0, 1000.0, 20001), np.linspace(-1.0, 1.0, 2001), [0.0, math.pi]])
    err = max(max(abs(fast_sincos(v)[0] - math.sin(v)), abs(fast_sincos(v)[1] - math.cos(v))) for v in z)
    assert err < 1e-15


def test_tyre_linear_stiffness_matches_axle_stiffness():
    """Per tyre: dFy/dalpha at static load = scale * Cf/2 (front), Cr/2 (rear)."""
    pp = PlantParams(cornering_scale_front=1.2)
    t = pp.tyre
    fz0f, fz0r = pp.static_loads
    for ky0, fz0, expected in ((1.2 * pp.vehicle.Cf / 2, fz0f, 1.2 * 115_000 / 2),
                               (pp.vehicle.Cr / 2, fz0r, 396_820 / 2)):
        a = 1e-5
        _, fy = tyre_forces(math.tan(a), 0.0, fz0, 0.85, ky0, fz0, t.pky2, t.Cy, t.Ey, t.pdy2,
                            t.kx_per_fz, t.Cx, t.Ex, t.pdx2, t.rby1, t.rby2, t.rbx1, t.rbx2)
        assert fy / a == pytest.approx(expected, rel=1e-4)


def test_tyre_saturates_at_mu_fz_and_combined_slip_reduces_fy():
    pp = PlantParams()
    t = pp.tyre
    fz0 = pp.static_loads[0]
    args = (t.pky2, t.Cy, t.Ey, t.pdy2, t.kx_per_fz, t.Cx, t.Ex, t.pdx2, t.rby1, t.rby2, t.rbx1, t.rbx2)
    peak = max(tyre_forces(math.tan(a), 0.0, fz0, 0.85, 57500.0, fz0, *args)[1]
               for a in np.radians(np.linspace(0, 30, 301)))
    assert peak == pytest.approx(0.85 * fz0, rel=1e-3)
    fy_pure = tyre_forces(0.05, 0.0, fz0, 0.85, 57500.0, fz0, *args)[1]
    fy_comb = tyre_forces(0.05, 0.05, fz0, 0.85, 57500.0, fz0, *args)[1]
    assert 0 < fy_comb < fy_pure


def test_rhs_is_pure():
    pp = PlantParams()
    x = np.zeros(NX)
    x[X_VX] = 20.0
    x[X_OMEGA:X_OMEGA + 4] = 20.0 / pp.vehicle.wheel_radius
    x0 = x.copy()
    u = np.array([0.3, 0.1, 0.0])
    road = flat_road().pack()
    d1 = f(x, u, road, pp.pack())
    d2 = f(x, u, road, pp.pack())
    assert np.array_equal(x, x0) and np.array_equal(d1, d2)
    # a left steer produces a left (positive) front lateral force and positive yaw acceleration
    assert d1[5] > 0 and outputs(x, u, road, pp.pack())[A_FYW] > 0


def _steady_circle(v, swa, plant=None, T=8.0):
    sc = Scenario("circle", flat_road(), Driver(speed=v, steering=((0.0, 1.0, T), (0.0, swa, swa))), T,
                  pre_roll=1.0)
    return run(sc, plant=plant or PlantParams(), sensors=SensorConfig.ideal())


def _linear_bicycle_ss(p: VehicleParams, vx, delta):
    """Steady state of SPEC 3.1's state-space model: x = -Ao^-1 Bo delta."""
    m, Iz, Lf, Lr, Cf, Cr = p.m, p.Iz, p.Lf, p.Lr, p.Cf, p.Cr
    A = np.array([[-(Cf + Cr) / (m * vx), -vx - (Lf * Cf - Lr * Cr) / (m * vx)],
                  [-(Lf * Cf - Lr * Cr) / (Iz * vx), -(Lf ** 2 * Cf + Lr ** 2 * Cr) / (Iz * vx)]])
    B = np.array([Cf / m, Lf * Cf / Iz])
    return -np.linalg.solve(A, B * delta)


@pytest.mark.parametrize("v,ay_target", [(15.0, 1.5), (20.0, 1.8), (25.0, 1.2)])
def test_linear_range_matches_bicycle_model(v, ay_target):
    p = VehicleParams()
    # choose the steering from the linear model so that |ay| ~ ay_target < 0.2 g
    gain = _linear_bicycle_ss(p, v, 1.0)[1]
    delta = ay_target / v / gain
    res = _steady_circle(v, delta * p.steering_ratio)
    tr = res.truth
    k = slice(-100, None)  # last second, steady
    assert np.all(np.abs(tr.ay_true[k]) < 0.2 * G)
    vx = tr.vx[k].mean()
    vy_lin, r_lin = _linear_bicycle_ss(p, vx, delta)
    r, vy = tr.r[k].mean(), tr.vy[k].mean()
    assert np.ptp(tr.r[k]) < 1e-3 * abs(r)  # steady
    assert r / delta == pytest.approx(r_lin / delta, rel=0.05)
    assert (vy / vx) == pytest.approx(vy_lin / vx, rel=0.05)


def test_coasting_straight_stays_straight():
    sc = Scenario("coast", flat_road(), Driver(speed=20.0, steering=((0.0,), (0.0,)), coast=True),
                  10.0, pre_roll=0.0)
    res = run(sc, sensors=SensorConfig.ideal())
    tr = res.truth
    assert np.all(np.isfinite(res.raw["X"]))
    assert np.max(np.abs(tr.n)) < 1e-9 and np.max(np.abs(tr.psi)) < 1e-9
    assert np.max(np.abs(tr.r)) < 1e-9 and np.max(np.abs(tr.ay_true)) < 1e-9
    # decelerates (drag, rolling resistance), never speeds up once coasting
    v = tr.vx
    assert np.all(np.diff(v) < 0) and v[-1] < v[0] - 1.0 and v[-1] > 10.0
    assert np.all(tr.throttle == 0) and np.all(tr.brake == 0)


@pytest.mark.parametrize("bank_deg", [5.0, 16.7, -10.0])
def test_bank_steady_state_accelerometer_reads_g_sin_theta(bank_deg):
    """Lane keeping straight on a bank: steady state has dvy/dt = r = 0, so ay = g sin(phi_b + phi)."""
    bank = math.radians(bank_deg)
    sc = Scenario("bank", straight_road(bank), Driver(speed=22.0, path=((0.0,), (0.0,))), 6.0)
    tr = run(sc, sensors=SensorConfig.ideal()).truth
    k = slice(-100, None)
    # truth bank equals the road bank, up to the car's small crab angle psi (the
    # contact points, a track t apart, differ in height by t cos(psi) sin(bank) over a
    # horizontal distance t sqrt(cos^2(psi) cos^2(bank) + sin^2(psi)))
    c, s = np.cos(tr.psi), np.sin(tr.psi)
    seen = np.arctan2(c * np.sin(bank), np.sqrt((c * np.cos(bank)) ** 2 + s ** 2))
    np.testing.assert_allclose(tr.phi_b, seen, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(tr.phi_b, bank, atol=2e-5)
    np.testing.assert_allclose(tr.ay_true[k], G * np.sin(tr.theta[k]), rtol=2e-3)
    assert np.max(np.abs(tr.r[k])) < 1e-4
    # the body rolls further downhill: phi has the bank's sign, ~0.57 deg per m/s^2 of ay
    assert np.sign(tr.phi[-1]) == np.sign(bank)
    v = VehicleParams()
    phi_expected = v.ms * v.h_roll * G * math.sin(bank) / (v.k_roll - v.ms * v.h_roll * G * math.cos(bank))
    assert tr.phi[-1] == pytest.approx(phi_expected, rel=0.05)


def test_bank_no_steering_correction_obeys_eq2():
    """Open-loop zero steering on a bank: the car drifts, and in steady state ay = vx r + g sin(theta)."""
    bank = math.radians(8.0)
    sc = Scenario("drift", straight_road(bank), Driver(speed=22.0, steering=((0.0,), (0.0,))), 6.0,
                  pre_roll=0.0)
    tr = run(sc, sensors=SensorConfig.ideal()).truth
    k = slice(-50, None)
    assert np.max(np.abs(tr.dvy_dt[k])) < 2e-3
    lhs = tr.ay_true[k]
    rhs = tr.dvy_dt[k] + tr.vx[k] * tr.r[k] + G * np.sin(tr.theta[k])
    np.testing.assert_allclose(lhs, rhs, atol=0.02)
    assert np.all(tr.n[-10:] < -0.5)  # slid downhill (bank left side up -> to the right)


def test_truth_bank_from_contact_heights_across_a_crease():
    road = two_lane_road(bank_left=math.radians(14), bank_right=0.0, transition=1.0)
    rp = road.pack()
    v = VehicleParams()
    args = (v.Lf, v.Lr, v.track_f, v.track_r)
    assert truth_bank(rp, 0.0, -1.75, 0.0, *args) == pytest.approx(0.0, abs=1e-12)
    assert truth_bank(rp, 0.0, 1.75, 0.0, *args) == pytest.approx(math.radians(14), rel=1e-9)
    # straddling the crease: the left/right height difference gives an intermediate bank
    mid = truth_bank(rp, 0.0, 0.0, 0.0, *args)
    # independent check: heights by numerical quadrature of sin(bank(n)) and cos(bank(n))
    nn = np.linspace(-v.track_f / 2, v.track_f / 2, 200001)
    b = road.bank(0.0, nn)
    dz = np.trapezoid(np.sin(b), nn)
    dh = np.trapezoid(np.cos(b), nn)
    assert mid == pytest.approx(math.atan2(dz, dh), rel=1e-6)
    # heading reversed: the bank seen by the car changes sign
    assert truth_bank(rp, 0.0, 1.75, math.pi, *args) == pytest.approx(-math.radians(14), rel=1e-9)
