"""Vehicle models: bicycle models of the lateral/yaw dynamics and body roll models."""

from .bicycle import (StateSpace, augment, augmented_model, disturbance_output, is_observable,
                      modified_model, observability_matrix, original_model, steady_state_gains,
                      understeer_gradient, SteadyStateGains)
from .roll import ROLL_MODELS, roll_state_space, steady_roll_gain

__all__ = ["StateSpace", "original_model", "modified_model", "augment", "augmented_model",
           "disturbance_output", "understeer_gradient", "steady_state_gains", "SteadyStateGains",
           "observability_matrix", "is_observable", "ROLL_MODELS", "roll_state_space",
           "steady_roll_gain"]
