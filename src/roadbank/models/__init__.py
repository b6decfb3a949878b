"""Vehicle models: bicycle models of the lateral/yaw dynamics, body roll models and the body's attitude kinematics."""

from .bicycle import (StateSpace, augment, augmented_model, disturbance_output, is_observable,
                      modified_model, observability_matrix, original_model, steady_state_gains,
                      understeer_gradient, SteadyStateGains)
from .attitude import euler_pitch_rate, euler_roll_rate, grade_pitch, kinematic_roll
from .roll import ROLL_MODELS, roll_state_space, steady_roll_gain

__all__ = ["StateSpace", "original_model", "modified_model", "augment", "augmented_model",
           "disturbance_output", "understeer_gradient", "steady_state_gains", "SteadyStateGains",
           "observability_matrix", "is_observable", "ROLL_MODELS", "roll_state_space",
           "steady_roll_gain", "grade_pitch", "euler_roll_rate", "euler_pitch_rate", "kinematic_roll"]
