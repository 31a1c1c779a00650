"""Kinematics of MDH robots, batched over poses and parameter sets: forward
kinematics and error-parameter Jacobians (:mod:`~rmdrake.kinematics.forward`),
tool inverse kinematics (:mod:`~rmdrake.kinematics.ik`) and rotations
(:mod:`~rmdrake.kinematics.rotations`).
"""

from __future__ import annotations

from rmdrake.kinematics.forward import (  # noqa: F401
    link_frames,
    point_jacobian,
    robot_reach,
    tool_jacobian,
    tool_points,
    tool_poses,
)
from rmdrake.kinematics.ik import (  # noqa: F401
    ToolIK,
    solve_tool_ik,
)
from rmdrake.kinematics.rotations import (  # noqa: F401
    checked_rotations,
    rotation_angle,
    rotation_from_rpy,
    rpy_from_rotation,
)

__all__ = [
    "ToolIK",
    "checked_rotations",
    "link_frames",
    "point_jacobian",
    "robot_reach",
    "rotation_angle",
    "rotation_from_rpy",
    "rpy_from_rotation",
    "solve_tool_ik",
    "tool_jacobian",
    "tool_points",
    "tool_poses",
]
