"""Compensation on the calibrated model: joint-target correction and program
filtering (:mod:`~rmdrake.compensation.correction`), tool targets and joint
programs with their files (:mod:`~rmdrake.compensation.programs`), and the
Cartesian test paths the studies drive (:mod:`~rmdrake.compensation.paths`).
"""

from __future__ import annotations

from rmdrake.compensation.correction import (
    Correction,
    FilteredProgram,
    correct_joint_motion,
    correct_path,
    correct_targets,
    filter_program,
    inverse_kinematics,
    motion_map,
)
from rmdrake.compensation.paths import (  # noqa: F401
    PATH_KINDS,
    JointPathProgram,
    PlanarPath,
    min_jerk,
    plan_path_program,
)
from rmdrake.compensation.programs import (  # noqa: F401
    JointProgram,
    ToolTargets,
    read_joint_program,
    read_tool_targets,
    write_joint_program,
    write_tool_targets,
)
from rmdrake.kinematics.rotations import rotation_from_rpy, rpy_from_rotation

__all__ = [
    "Correction",
    "FilteredProgram",
    "JointPathProgram",
    "JointProgram",
    "PATH_KINDS",
    "PlanarPath",
    "ToolTargets",
    "correct_joint_motion",
    "correct_path",
    "correct_targets",
    "filter_program",
    "inverse_kinematics",
    "min_jerk",
    "motion_map",
    "plan_path_program",
    "read_joint_program",
    "read_tool_targets",
    "rotation_from_rpy",
    "rpy_from_rotation",
    "write_joint_program",
    "write_tool_targets",
]
