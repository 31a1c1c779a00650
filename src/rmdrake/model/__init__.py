"""The robot: its description (MDH table, tool, limits, 13 dynamic parameters
per link, payload, compliance, transmission), its units, its named error
parameters, loading (shipped names, robot YAML, URDF), the Drake plant built
from it, its elastic deflection, and URDF in and out (:mod:`rmdrake.model.urdf`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.model.error_parameters": (
            "apply_deltas",
            "compliance_parameter_names",
            "error_parameter_indices",
            "error_parameter_names",
            "is_compliance_name",
            "split_error_parameters",
        ),
        "rmdrake.model.loading": (
            "Robot",
            "as_robot_model",
            "controller_model_for",
            "load_robot",
            "shipped_robots",
        ),
        "rmdrake.model.robot": (
            "DEFAULT_ACCELERATION_TIME",
            "DYNAMIC_KEYS",
            "EXTRA_DYNAMIC_KEYS",
            "MDH_KEYS",
            "MOTOR_KEYS",
            "BaseFrame",
            "Compliance",
            "DynamicTerms",
            "JointLimits",
            "MassBounds",
            "Payload",
            "RobotModel",
        ),
        "rmdrake.model.transmission": ("Transmission",),
    },
)
