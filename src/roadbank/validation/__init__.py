"""Validation of the estimators on real driving data (comma2k19)."""

from .comma2k19 import SEDAN, ValidationResult, validate_comma2k19
from .report import markdown, plot, to_json

__all__ = ["validate_comma2k19", "ValidationResult", "SEDAN", "markdown", "plot", "to_json"]
