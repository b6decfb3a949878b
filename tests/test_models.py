import numpy as np
import pytest

from roadbank import VehicleParams
from roadbank.models import (augmented_model, is_observable, modified_model, original_model,
                             steady_roll_gain, steady_state_gains, understeer_gradient)

P = VehicleParams()
SPEEDS = [1.0, 5.0, 22.2, 40.0, 70.0]


@pytest.mark.parametrize("vx", SPEEDS)
def test_original_model_entries(vx):
    A, B, E, C, D = original_model(P, vx)
    # hand-derived entries (docs/models.md, original model) with the numbers of paper Table 1
    # substituted: m, Iz, Lf, Lr, Cf, Cr = 1687, 3401, 1.15, 1.47, 115000, 396820
    assert A[0, 0] == pytest.approx(-(115000 + 396820) / (1687 * vx))
    assert A[0, 1] == pytest.approx(-vx - (1.15 * 115000 - 1.47 * 396820) / (1687 * vx))
    assert A[1, 0] == pytest.approx(-(132250 - 583325.4) / (3401 * vx))
    assert A[1, 1] == pytest.approx(-(1.3225 * 115000 + 2.1609 * 396820) / (3401 * vx))
    assert B.ravel() == pytest.approx([115000 / 1687, 1.15 * 115000 / 3401])
    assert E.ravel() == pytest.approx([-9.81, 0.0])
    assert C[0] == pytest.approx([A[0, 0], A[0, 1] + vx])
    assert C[1] == pytest.approx([0.0, 1.0])
    assert D.ravel() == pytest.approx([115000 / 1687, 0.0])


@pytest.mark.parametrize("vx", SPEEDS)
def test_modified_model_has_no_front_stiffness(vx):
    A, B, E, C, D = modified_model(P, vx)
    assert A == pytest.approx(np.array([[0, -vx], [2.62 * 396820 / (3401 * vx), -2.62 * 1.47 * 396820 / (3401 * vx)]]))
    assert B.ravel() == pytest.approx([1.0, 1.15 * 1687 / 3401])
    assert C.ravel() == pytest.approx([0, 1])
    A2 = modified_model(P.replace(Cf=2 * P.Cf), vx)
    assert np.array_equal(A, A2.A) and np.array_equal(B, A2.B)


def test_modified_model_agrees_with_original_when_fed_true_ay():
    """Derivative of [vy, r] from both models must agree when ay = (Fyf+Fyr)/m of the original."""
    rng = np.random.default_rng(1)
    for vx in (8.0, 30.0):
        o, mo = original_model(P, vx), modified_model(P, vx)
        for _ in range(5):
            x, d, w = rng.normal(size=2) * [0.5, 0.2], rng.normal() * 0.05, 0.1
            xdot = o.A @ x + o.B[:, 0] * d + o.E[:, 0] * w
            ay = (o.C @ x + o.D[:, 0] * d)[0]
            xdot_m = mo.A @ x + mo.B[:, 0] * ay + mo.E[:, 0] * w
            assert xdot_m == pytest.approx(xdot, rel=1e-10, abs=1e-12)


def test_steady_state_gains_match_eq15_closed_forms():
    L = 2.62
    kus = understeer_gradient(P)
    assert kus == pytest.approx(1.47 * 1687 / (2.62 * 115000) - 1.15 * 1687 / (2.62 * 396820))
    for vx in (10.0, 22.2, 35.0):
        h = steady_state_gains(P, vx)
        assert h.Haw0 == pytest.approx(9.81 * L / (L + kus * vx**2), rel=1e-12)
        assert vx * h.Hrw0 == pytest.approx(-9.81 * kus * vx**2 / (L + kus * vx**2), rel=1e-12)
        assert h.Haw0 - vx * h.Hrw0 == pytest.approx(9.81)          # ay = vx r + g w
        assert h.Hau0 == pytest.approx(vx * h.Hru0)                  # no bank: ay = vx r
        assert h.Hru0 == pytest.approx(vx / (L + kus * vx**2))      # classic yaw-rate gain
    h = steady_state_gains(P, 22.2)
    assert (h.Haw0, 22.2 * h.Hrw0) == pytest.approx((4.4647, -5.3453), abs=1e-4)   # Table 1 at 22.2 m/s


@pytest.mark.parametrize("vx", np.linspace(1.0, 70.0, 24))
def test_augmented_model_observable(vx):
    A, B, E, C, D = augmented_model(P, vx)
    O = np.vstack([C, C @ A, C @ A @ A])
    assert np.linalg.matrix_rank(O) == 3
    assert is_observable(A, C)


def test_unobservable_pair_detected():
    assert not is_observable(np.diag([1.0, 2.0]), np.array([[1.0, 0.0]]))


def test_roll_gain_is_the_static_balance_and_the_dynamic_models_steady_state():
    """The static gain is the roll-moment balance ms h ay = (k_roll - ms g h) phi, and the dynamic roll model's
    steady state D - H F^-1 G; for the paper's SUV about 0.57 deg per m/s^2 (an SUV: about 0.5-1)."""
    from roadbank.models import roll_state_space
    k = steady_roll_gain(P)
    assert k == pytest.approx(P.ms * P.h_roll / (P.k_roll - P.ms * P.g * P.h_roll), rel=1e-12)
    F, G, H, D = (np.atleast_2d(a) for a in roll_state_space(P, "dynamic"))
    assert (D - H @ np.linalg.solve(F, G))[0, 0] == pytest.approx(k, rel=1e-9)
    assert 0.5 <= np.rad2deg(k) <= 1.0


def test_models_reject_zero_speed():
    with pytest.raises(ValueError, match="vx"):
        original_model(P, 0.0)
