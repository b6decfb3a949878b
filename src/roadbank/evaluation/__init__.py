"""Evaluation: reference angles, error metrics, and running estimators against a simulation."""

from .compare import REFERENCES, Evaluation, evaluate, reference_angles
from .metrics import METRICS, ErrorMetrics, error_metrics
from .reference import TAU_REFERENCE, first_order_lowpass, theta_reference

__all__ = ["REFERENCES", "Evaluation", "evaluate", "reference_angles", "METRICS", "ErrorMetrics", "error_metrics",
           "TAU_REFERENCE", "first_order_lowpass", "theta_reference"]
