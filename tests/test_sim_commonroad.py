"""Cross-check of the plant against an independent one: CommonRoad's multi-body model (MB).

CommonRoad's ``vehicle_dynamics_mb`` (commonroad-vehicle-models, test extra) is a
29-state multi-body car with Pacejka tyres. Its tyre data are shared by all four
tyres, so instead of forcing the paper's Cf_ss/Cr_ss on it we give *our* plant
CommonRoad's vehicle 2 (BMW 320i): its masses, inertias, geometry, roll
stiffness/damping (springs and anti-roll torsion) and its tyre (our Magic Formula
with its C, E, peak friction and its cornering stiffness ``-p_ky1 * Fz``, i.e.
linear in load, no camber). Both run on a flat road at constant speed.

Agreement found when this test was written (see docs/simulator.md):

* steady-state circle 15 m/s, road-wheel angle 0.05 rad (ay ~ 0.45 g): yaw rate
  within 1.8 %, sideslip within 0.14 deg, roll angle magnitude ours/CR = 1.38
  (CommonRoad's roll sign is opposite to ISO 8855 and its roll model differs);
* step steer 20 m/s, 0.02 rad in 0.2 s: steady yaw rate within 3.4 %, 90 % rise
  time within 0.03 s, RMS yaw-rate difference 3 % of the steady value.

The assertions below keep the plant there (bands just outside those numbers).
"""

import math

import numpy as np
import pytest

pytest.importorskip("vehiclemodels")
from scipy.integrate import solve_ivp  # noqa: E402
from vehiclemodels.init_mb import init_mb  # noqa: E402
from vehiclemodels.parameters_vehicle2 import parameters_vehicle2  # noqa: E402
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb  # noqa: E402

from roadbank import VehicleParams  # noqa: E402
from roadbank.sim import Driver, PlantParams, Scenario, SensorConfig, TyreParams, flat_road, run  # noqa: E402

G = 9.81


@pytest.fixture(scope="module")
def models():
    P = parameters_vehicle2()
    P.steering.v_max, P.steering.v_min = 20.0, -20.0  # let the steering follow our ramp
    tp = P.tire
    L = P.a + P.b
    fz0f = (P.m_s * G * P.b / L + P.m_uf * G) / 2
    fz0r = (P.m_s * G * P.a / L + P.m_ur * G) / 2
    h = P.h_s  # roll axis at the ground (h_raf = h_rar = 0): roll arm = sprung CG height
    vp = VehicleParams(
        m=P.m, Iz=P.I_z, Lf=P.a, Lr=P.b, Cf=2 * -tp.p_ky1 * fz0f, Cr=2 * -tp.p_ky1 * fz0r,
        h_cg=h, h_roll=h, ms=P.m_s, Ixx=P.I_Phi_s + P.m_s * h * h,
        k_roll=P.K_sf * P.T_f ** 2 / 2 + P.K_tsf + P.K_sr * P.T_r ** 2 / 2 + P.K_tsr,
        c_roll=P.K_sdf * P.T_f ** 2 / 2 + P.K_sdr * P.T_r ** 2 / 2, roll_stiffness_front_share=0.5,
        track_f=P.T_f, track_r=P.T_r, wheel_radius=P.R_w, wheel_inertia=P.I_y_w)
    ty = TyreParams(Cy=tp.p_cy1, Ey=tp.p_ey1, Cx=tp.p_cx1, Ex=tp.p_ex1, pky2=1e6, pdy2=0.0, pdx2=0.0,
                    kx_per_fz=tp.p_kx1, rby1=tp.r_by1, rby2=tp.r_by2, rbx1=tp.r_bx1, rbx2=abs(tp.r_bx2),
                    rolling_resistance=0.0)
    return P, PlantParams(vehicle=vp, tyre=ty, mu=tp.p_dy1, CdA=0.0)


def _ramp(t, t0, t1, a):
    if t <= t0:
        return 0.0
    if t >= t1:
        return a
    return a * (0.5 - 0.5 * math.cos(math.pi * (t - t0) / (t1 - t0)))


def _dramp(t, t0, t1, a):
    if t <= t0 or t >= t1:
        return 0.0
    return a * 0.5 * math.pi * math.sin(math.pi * (t - t0) / (t1 - t0)) / (t1 - t0)


def _both(models, v0, delta, T=6.0, t0=0.5, t1=0.7):
    P, pp = models
    x0 = init_mb([0, 0, 0.0, v0, 0, 0, 0], P)

    def rhs(t, x):
        return vehicle_dynamics_mb(list(x), [_dramp(t, t0, t1, delta), 3.0 * (v0 - x[3])], P)

    sol = solve_ivp(rhs, (0, T), x0, method="RK45", rtol=1e-7, atol=1e-8, max_step=0.005, dense_output=True)
    assert sol.success
    ts = np.linspace(0, T, 601)
    cr = sol.sol(ts)
    tk = np.linspace(t0, t1, 41)
    swa = np.array([_ramp(t, t0, t1, delta) for t in tk]) * pp.vehicle.steering_ratio
    sc = Scenario("step", flat_road(), Driver(speed=v0, steering=(np.r_[0.0, tk, T], np.r_[0.0, swa, swa[-1]])),
                  T, pre_roll=1.0)
    res = run(sc, plant=pp, sensors=SensorConfig.ideal())
    X = res.raw["X"]
    ours = {k: np.interp(ts, res.raw["t"], X[:, i]) for k, i in (("vx", 3), ("vy", 4), ("r", 5), ("phi", 6))}
    crd = {"vx": cr[3], "vy": cr[10], "r": cr[5], "phi": -cr[6]}  # CommonRoad roll is left side down
    return ts, ours, crd


@pytest.mark.slow
def test_steady_state_circle_agrees_with_commonroad(models):
    ts, ours, cr = _both(models, 15.0, 0.05)
    k = ts > 5.0
    r_o, r_c = ours["r"][k].mean(), cr["r"][k].mean()
    assert np.ptp(cr["r"][k]) < 1e-3 * r_c and np.ptp(ours["r"][k]) < 1e-3 * r_o  # steady
    assert r_o * 15.0 > 0.4 * G  # well into the nonlinear range
    assert r_o == pytest.approx(r_c, rel=0.03)
    beta_o = (ours["vy"][k] / ours["vx"][k]).mean()
    beta_c = (cr["vy"][k] / cr["vx"][k]).mean()
    assert abs(beta_o - beta_c) < math.radians(0.25)
    ratio = ours["phi"][k].mean() / cr["phi"][k].mean()
    assert 1.2 < ratio < 1.55


@pytest.mark.slow
def test_step_steer_agrees_with_commonroad(models):
    ts, ours, cr = _both(models, 20.0, 0.02)
    k = ts > 5.0
    r_o, r_c = ours["r"][k].mean(), cr["r"][k].mean()
    assert r_o == pytest.approx(r_c, rel=0.05)

    def t90(r):
        return ts[np.argmax(r >= 0.9 * r[-1])]

    assert abs(t90(ours["r"]) - t90(cr["r"])) < 0.06
    rms = np.sqrt(np.mean((ours["r"] - cr["r"]) ** 2))
    assert rms < 0.05 * r_c
    # neither overshoots much (both well damped at 20 m/s)
    assert ours["r"].max() < 1.05 * r_o and cr["r"].max() < 1.05 * r_c
