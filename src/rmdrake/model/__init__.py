"""The robot: its description (MDH table, tool, limits, 13 dynamic parameters
per link, payload, compliance), its units, its named error parameters, loading
(shipped names, robot YAML, URDF), the Drake plant built from it, its elastic
deflection, and URDF in and out (:mod:`rmdrake.model.urdf`).
"""

from __future__ import annotations

from rmdrake.model.error_parameters import (  # noqa: F401
    apply_deltas,
    compliance_parameter_names,
    error_parameter_indices,
    error_parameter_names,
    is_compliance_name,
    split_error_parameters,
)
from rmdrake.model.loading import (  # noqa: F401
    Robot,
    as_robot_model,
    load_robot,
    shipped_robots,
)
from rmdrake.model.robot import (  # noqa: F401
    DEFAULT_ACCELERATION_TIME,
    DYNAMIC_KEYS,
    EXTRA_DYNAMIC_KEYS,
    MDH_KEYS,
    BaseFrame,
    Compliance,
    DynamicTerms,
    JointLimits,
    MassBounds,
    Payload,
    RobotModel,
)

__all__ = [
    "BaseFrame",
    "Compliance",
    "DEFAULT_ACCELERATION_TIME",
    "DYNAMIC_KEYS",
    "DynamicTerms",
    "EXTRA_DYNAMIC_KEYS",
    "JointLimits",
    "MDH_KEYS",
    "MassBounds",
    "Payload",
    "Robot",
    "RobotModel",
    "apply_deltas",
    "as_robot_model",
    "compliance_parameter_names",
    "error_parameter_indices",
    "error_parameter_names",
    "is_compliance_name",
    "load_robot",
    "shipped_robots",
    "split_error_parameters",
]
