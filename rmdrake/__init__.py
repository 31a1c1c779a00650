"""rmdrake: accuracy for large manipulators, inside Drake.

Core numerics (no diagram wiring); Drake systems live in :mod:`rmdrake.systems`.
"""

from rmdrake.dynamics import (
    SerialChain,
    check_physical,
    regressor,
    standard_parameters,
)
from rmdrake.io import atomic_write_bytes, atomic_write_text
from rmdrake.kinematics import point_jacobian, tool_points, tool_poses
from rmdrake.plant import MakePlant
from rmdrake.robot import (
    DYNAMIC_KEYS,
    MDH_KEYS,
    JointLimits,
    Payload,
    RobotModel,
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
    load_robot,
    shipped_robots,
)

__version__ = "0.1.0"

__all__ = [
    "DYNAMIC_KEYS",
    "MDH_KEYS",
    "JointLimits",
    "MakePlant",
    "Payload",
    "RobotModel",
    "SerialChain",
    "apply_deltas",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_physical",
    "error_parameter_indices",
    "error_parameter_names",
    "load_robot",
    "point_jacobian",
    "regressor",
    "shipped_robots",
    "standard_parameters",
    "tool_points",
    "tool_poses",
]
