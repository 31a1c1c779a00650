"""Kinematics of MDH robots, batched over poses and parameter sets: forward
kinematics and error-parameter Jacobians (:mod:`~rmdrake.kinematics.forward`),
tool inverse kinematics (:mod:`~rmdrake.kinematics.ik`) and rotations
(:mod:`~rmdrake.kinematics.rotations`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.kinematics.forward": (
            "link_frames",
            "point_jacobian",
            "robot_reach",
            "tool_jacobian",
            "tool_points",
            "tool_poses",
        ),
        "rmdrake.kinematics.ik": (
            "ToolIK",
            "solve_tool_ik",
        ),
        "rmdrake.kinematics.rotations": (
            "checked_rotations",
            "rotation_angle",
            "rotation_from_rpy",
            "rpy_from_rotation",
        ),
    },
)
