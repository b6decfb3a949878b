"""The paper's robustness claims on a linear plant simulated by scipy (eq 14, 24, 32)."""

import numpy as np
import pytest

from roadbank import VehicleParams
from roadbank import estimators as E

from conftest import linear_plant_run

P = VehicleParams()


@pytest.mark.parametrize("name", ["pif-modified", "pio-modified", "pif-modified-riccati"])
@pytest.mark.parametrize("fc,fr", [(1.0, 1.0), (1.3, 1.0), (0.7, 1.0), (1.0, 1.3), (1.0, 0.7), (1.3, 0.7), (0.7, 1.3)])
def test_modified_model_estimators_have_zero_steady_state_error(name, fc, fr):
    signals, w = linear_plant_run(P.replace(Cf=fc * P.Cf, Cr=fr * P.Cr))
    est = E.make("pif-modified", variant="riccati") if name.endswith("riccati") else E.make(name)
    est_w = est.run(signals).w
    assert abs(est_w[-1] - w) < 1e-4
    assert np.abs(est_w[-200:] - w).max() < 1e-4


@pytest.mark.parametrize("name", ["dfc", "uio"])
def test_dfc_and_uio_error_grows_with_front_stiffness_error(name):
    """Paper eq 14 / 24: zero error with the exact model, a steady-state error that grows
    (about linearly) with |Cf error|, for stiffer and for softer front tyres."""
    def error(fc):
        signals, w = linear_plant_run(P.replace(Cf=fc * P.Cf))
        return abs(E.make(name).run(signals).w[-1] - w)

    assert error(1.0) < 1e-4
    for side in (+1, -1):
        errs = np.array([error(1.0 + side * k * 0.1) for k in (1, 2, 3)])
        assert errs[0] > 1e-3                          # 10 % Cf error: > 0.06 deg
        assert np.all(np.diff(errs) > 0.5 * errs[0])   # each further 10 % adds to it


def test_pif_original_is_not_robust_to_cf_but_modified_is():
    signals, w = linear_plant_run(P.replace(Cf=1.3 * P.Cf))
    err_orig = abs(E.make("pif-original").run(signals).w[-1] - w)
    err_mod = abs(E.make("pif-modified").run(signals).w[-1] - w)
    assert err_orig > 100 * max(err_mod, 1e-6)
