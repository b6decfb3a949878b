"""Validation of the estimators on real driving data (comma2k19, KITTI raw), one scoring for all."""

from .comma2k19 import SEDAN, ValidationResult, validate_comma2k19
from .kitti import KittiValidation, validate_kitti
from .report import markdown, plot, to_json
from .scoring import Score, Scoring

__all__ = ["validate_comma2k19", "validate_kitti", "ValidationResult", "KittiValidation", "SEDAN", "Score",
           "Scoring", "markdown", "plot", "to_json"]
