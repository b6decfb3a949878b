"""Evaluation: reference angles, error metrics, running estimators against a simulation, and the
best causal linear filter of a log set as a bound; a target of the default and its verdict."""

from .bound import FirBound, causal_fir_bound
from .compare import REFERENCES, Evaluation, evaluate, reference_angles
from .metrics import METRICS, ErrorMetrics, error_metrics
from .reference import TAU_REFERENCE, first_order_lowpass, theta_reference
from .targets import Target

__all__ = ["FirBound", "causal_fir_bound",
           "REFERENCES", "Evaluation", "evaluate", "reference_angles", "METRICS", "ErrorMetrics", "error_metrics",
           "TAU_REFERENCE", "first_order_lowpass", "theta_reference", "Target"]
