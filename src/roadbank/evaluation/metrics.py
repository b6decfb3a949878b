"""Error metrics of an estimate against a reference angle, as the reports tabulate them.

All inputs are radians and seconds; :func:`error_metrics` returns degrees and
seconds, the units of the reports.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

#: metric names in report order
METRICS = ("rms_deg", "max_deg", "bias_deg", "steady_deg", "t_conv_s", "flagged_pct")


@dataclass(frozen=True)
class ErrorMetrics:
    """Errors of one estimate against one reference.

    rms_deg, max_deg, bias_deg : RMS, max absolute and mean error (deg) over the
        scored samples (valid, after the settling time).
    steady_deg : mean error over the final window (deg) — the steady-state error.
    t_conv_s : first time (s, from the start of the log) after which the error
        stays within the band; NaN if it never does.
    n : number of scored samples.
    """

    rms_deg: float
    max_deg: float
    bias_deg: float
    steady_deg: float
    t_conv_s: float
    n: int

    def as_dict(self) -> dict:
        return asdict(self)


def error_metrics(t, estimate, reference, valid=None, *, settle: float = 2.0,
                  final_window: float = 3.0, band_deg: float = 0.5) -> ErrorMetrics:
    """Metrics of ``estimate - reference`` (both rad) at times ``t`` (s).

    Parameters
    ----------
    valid : bool array, optional
        Samples to score (e.g. ``Estimate.valid``); others are ignored.
    settle : float
        Seconds from the start of the log excluded from scoring.
    final_window : float
        Length (s) of the final window of the steady-state error.
    band_deg : float
        Convergence band (deg) of ``t_conv_s``.
    """
    t = np.asarray(t, float)
    err = np.rad2deg(np.asarray(estimate, float) - np.asarray(reference, float))
    ok = np.isfinite(err)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    scored = ok & (t >= t[0] + settle)
    if not scored.any():
        nan = float("nan")
        return ErrorMetrics(nan, nan, nan, nan, nan, 0)
    e = err[scored]
    final = scored & (t >= t[-1] - final_window)
    steady = float(np.mean(err[final])) if final.any() else float("nan")
    outside = ok & (np.abs(err) > band_deg)
    if not outside.any():
        t_conv = 0.0
    elif outside[-1] or not ok[np.flatnonzero(outside)[-1]:].any():
        t_conv = float("nan")
    else:
        t_conv = float(t[np.flatnonzero(outside)[-1] + 1] - t[0])
    return ErrorMetrics(float(np.sqrt(np.mean(e**2))), float(np.max(np.abs(e))), float(np.mean(e)),
                        steady, t_conv, int(scored.sum()))
