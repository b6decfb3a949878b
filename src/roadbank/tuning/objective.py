"""What tuning minimises: bank-angle errors of an estimator over a set of drives.

For each drive the error ``phi_b_hat - phi_b`` (deg) is scored on the samples every
estimator can use (finite inputs, ``vx >= v_min``) after the first :data:`SETTLE` seconds,
as in the reproduction study. The objective of a set is

.. math::
    J = \\operatorname{mean}_k \\mathrm{RMS}_k + w_{max} \\operatorname{mean}_k \\max_k |e|

with :data:`W_MAX` = 0.1: mostly the RMS error, with a small weight on the worst error so
a tuning that is good on average but lags the bank steps badly loses.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..evaluation.compare import usable_samples
from ..evaluation.metrics import error_metrics

SETTLE = 2.0        #: seconds excluded from scoring at the start of each drive
W_MAX = 0.1         #: weight of the mean max |error| in the objective
#: score of a drive whose estimate is not finite (deg): larger than any real error
FAILED_DEG = 90.0


@dataclass(frozen=True)
class SetScores:
    """Bank errors (deg) of one estimator over a drive set.

    ``median_rms``, ``mean_rms``, ``p95_rms``: median, mean and 95th percentile of the
    per-drive RMS errors; ``mean_max``: mean of the per-drive max |error|;
    ``objective``: :func:`objective_value`; ``n``: number of drives.
    """

    median_rms: float
    mean_rms: float
    p95_rms: float
    mean_max: float
    objective: float
    n: int

    def as_dict(self, prefix: str = "") -> dict:
        """Flat ``{prefix + name_deg: value}`` (``n`` becomes ``prefix + "drives"``)."""
        return {f"{prefix}drives" if k == "n" else f"{prefix}{k}_deg": v for k, v in asdict(self).items()}


def drive_errors(estimator, drives) -> tuple[np.ndarray, np.ndarray]:
    """Per-drive bank RMS and max |error| (deg) of ``estimator`` over ``drives``.

    A drive whose scored estimate is not finite scores :data:`FAILED_DEG`.
    """
    rms, mx = np.empty(len(drives)), np.empty(len(drives))
    for k, d in enumerate(drives):
        e = estimator.run(d.signals)
        m = error_metrics(d.signals.t, e.phi_b, d.phi_b, usable_samples(d.signals, estimator.v_min),
                          settle=SETTLE)
        ok = np.isfinite(m.rms_deg) and np.isfinite(m.max_deg)
        rms[k], mx[k] = (m.rms_deg, m.max_deg) if ok else (FAILED_DEG, FAILED_DEG)
    return rms, mx


def objective_value(rms: np.ndarray, mx: np.ndarray) -> float:
    """``mean(rms) + W_MAX mean(max)`` (deg) of per-drive errors."""
    return float(np.mean(rms) + W_MAX * np.mean(mx))


def score_set(estimator, drives) -> SetScores:
    """:class:`SetScores` of ``estimator`` over ``drives``."""
    rms, mx = drive_errors(estimator, drives)
    return SetScores(float(np.median(rms)), float(np.mean(rms)), float(np.percentile(rms, 95)),
                     float(np.mean(mx)), objective_value(rms, mx), len(drives))
