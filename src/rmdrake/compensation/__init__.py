"""Compensation on the calibrated model: joint-target correction and program
filtering (:mod:`~rmdrake.compensation.correction`), tool targets and joint
programs with their files (:mod:`~rmdrake.compensation.programs`), and the
Cartesian test paths the studies drive (:mod:`~rmdrake.compensation.paths`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.compensation.correction": (
            "Correction",
            "FilteredProgram",
            "correct_joint_motion",
            "correct_path",
            "correct_targets",
            "filter_program",
            "inverse_kinematics",
            "motion_map",
        ),
        "rmdrake.compensation.paths": (
            "PATH_KINDS",
            "JointPathProgram",
            "PlanarPath",
            "min_jerk",
            "plan_path_program",
        ),
        "rmdrake.compensation.programs": (
            "JointProgram",
            "ToolTargets",
            "read_joint_program",
            "read_tool_targets",
            "write_joint_program",
            "write_tool_targets",
        ),
        "rmdrake.kinematics.rotations": (
            "rotation_from_rpy",
            "rpy_from_rotation",
        ),
    },
)
