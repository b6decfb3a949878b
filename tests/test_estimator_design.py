"""Gain designs of the estimators against independent computations."""

import numpy as np
import pytest

from roadbank import VehicleParams
from roadbank import estimators as E
from roadbank.estimators.base import augmented_design_model
from roadbank.estimators.uio import uio_matrices
from roadbank.models import original_model

P = VehicleParams()


@pytest.mark.parametrize("model", ["modified", "original"])
@pytest.mark.parametrize("vx", [5.0, 12.0, 22.2, 45.0, 70.0])
def test_steady_pif_gain_against_python_control(model, vx):
    control = pytest.importorskip("control")
    est = E.make(f"pif-{model}", tuning="paper")
    Pr = est.riccati_solution(vx)
    A, B, C, Dy, Lw, Ew = augmented_design_model(P, vx, model)
    R = est.R
    # python-control's CARE on the dual problem, written independently of roadbank
    X, _, _ = control.care(A.T, np.hstack([C.T, Lw.T]), 0.1 * Ew @ Ew.T,
                           np.block([[R, np.zeros((R.shape[0], 1))], [np.zeros((1, R.shape[0])), -np.eye(1)]]))
    assert np.allclose(Pr, X, rtol=1e-7, atol=1e-10 * np.abs(X).max())
    # residual of eq 44 with Table 4 values
    M = C.T @ np.linalg.inv(R) @ C - 1.0 * Lw.T @ Lw
    res = A @ Pr + Pr @ A.T + 0.1 * Ew @ Ew.T - Pr @ M @ Pr
    scale = np.abs(A @ Pr).max() + np.abs(Pr @ M @ Pr).max()
    assert np.abs(res).max() / scale < 1e-9
    assert np.linalg.eigvalsh(Pr).min() > 0
    assert np.linalg.eigvals(est.error_dynamics(vx)).real.max() < 0


def test_pif_fast_pole_at_low_speed_matches_spec():
    est = E.make("pif-modified", v_min=2.5, tuning="paper")
    fastest = np.linalg.eigvals(est.error_dynamics(3.0)).real.min()
    assert -160 < fastest < -140           # SPEC 4: about -150 1/s at 3 m/s


def test_pif_reports_missing_stabilising_solution():
    with pytest.raises(E.NoStabilisingSolution, match=r"th=50.0 at vx="):
        E.make("pif-modified", th=50.0, tuning="paper")
    with pytest.raises(E.NoStabilisingSolution):
        E.make("pif-modified", th=50.0, variant="riccati", tuning="paper")


def test_pio_table3_error_dynamics_hurwitz_and_slow_pole():
    est = E.make("pio-original")
    for vx in np.linspace(5, 60, 45):
        assert np.linalg.eigvals(est.error_dynamics(vx)).real.max() < 0
    slow = np.linalg.eigvals(est.error_dynamics(22.0)).real.max()
    assert -0.05 < slow < -0.03             # SPEC 4.4: about -0.04 1/s at 22 m/s


@pytest.mark.parametrize("name", ["pio-modified", "pio-original"])
def test_placed_pio_poles(name):
    est = E.make(name, gains="placed", poles=(-1.5, -3.0, -5.0))
    for vx in (6.0, 20.0, 55.0):
        assert np.sort(np.linalg.eigvals(est.error_dynamics(vx)).real) == pytest.approx([-5, -3, -1.5])


@pytest.mark.parametrize("vx", [5.0, 22.2, 70.0])
def test_uio_decouples_disturbance_and_error_obeys_N(vx):
    A, B, Eo, C, D = original_model(P, vx)
    Eu, N, L, G, pinv = uio_matrices(P, vx)
    assert np.allclose((np.eye(2) + Eu @ C) @ Eo, 0, atol=1e-12)
    assert np.linalg.eigvals(N).real.max() < 0
    # e' = N e for any x, u, w: derivative of e = x - (z - E C x) with z' = N z + L C x + G u
    rng = np.random.default_rng(0)
    for _ in range(5):
        x, z, u, w = rng.normal(size=2), rng.normal(size=2), rng.normal(), rng.normal()
        xdot = A @ x + B[:, 0] * u + Eo[:, 0] * w
        zdot = N @ z + L @ (C @ x) + G[:, 0] * u
        e = x - (z - Eu @ C @ x)
        edot = xdot - (zdot - Eu @ C @ xdot)
        assert np.allclose(edot, N @ e, atol=1e-9)


def test_unknown_name_and_bad_tuning():
    with pytest.raises(ValueError, match="unknown estimator 'pif'"):
        E.make("pif")
    with pytest.raises(ValueError, match="bad tuning"):
        E.make("kinematic", Q=3)
    assert len(E.NAMES) == 17 and set(E.NAMES) == {
        "kinematic", "kinematic-lp", "kinematic-ff", "kinematic-pif", "dfc", "uio", "pio-original", "pio-modified",
        "pif-modified", "pif-original", "kalman",
        "pif-rate", "pif-adaptive", "pif-rate-adaptive", "pif-gated", "pif-smoother", "kinematic-smoother"}


@pytest.mark.parametrize("name", ["pif-rate", "pif-adaptive", "pif-rate-adaptive", "pif-smoother"])
def test_variants_on_the_modified_model_refuse_another_model_or_variant(name):
    for option in ({"model": "original"}, {"variant": "riccati"}):
        with pytest.raises(ValueError, match=f"{name}: model and variant are fixed"):
            E.make(name, **option)
