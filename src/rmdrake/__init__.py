"""rmdrake: accuracy for large manipulators, inside Drake.

Core numerics (no diagram wiring); Drake systems live in :mod:`rmdrake.systems`.
"""

from rmdrake.exports import lazy_exports
from rmdrake.version import __version__ as __version__

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.calibration.config": (
            "CalibrationConfig",
            "PlaneLMConfig",
            "PointLMConfig",
            "VolumeDEConfig",
            "VolumeDEPlaneLMConfig",
        ),
        "rmdrake.calibration.plates.data": (
            "PlaneMeasurements",
            "read_plane_measurements",
            "write_plane_measurements",
        ),
        "rmdrake.calibration.plates.estimators": (
            "PlaneLM",
            "VolumeDE",
            "VolumeDEPlaneLM",
            "make_calibrator",
        ),
        "rmdrake.calibration.plates.identifiability": ("analyse_identifiability",),
        "rmdrake.calibration.plates.simulate": ("simulate_plates",),
        "rmdrake.calibration.points.data": (
            "PointMeasurements",
            "read_point_measurements",
            "write_point_measurements",
        ),
        "rmdrake.calibration.points.identifiability": (
            "analyse_point_identifiability",
        ),
        "rmdrake.calibration.points.lm": (
            "PointLM",
            "make_point_calibrator",
        ),
        "rmdrake.calibration.points.selection": ("cross_validate",),
        "rmdrake.calibration.points.simulate": ("simulate_points",),
        "rmdrake.calibration.validation": ("tool_point_errors",),
        "rmdrake.compensation.correction": (
            "Correction",
            "FilteredProgram",
            "correct_path",
            "correct_targets",
            "filter_program",
        ),
        "rmdrake.compensation.programs": (
            "JointProgram",
            "ToolTargets",
            "read_joint_program",
            "read_tool_targets",
            "write_joint_program",
            "write_tool_targets",
        ),
        "rmdrake.dynamics": ("regressor",),
        "rmdrake.dynamics.base": (
            "BaseParameters",
            "base_parameters",
        ),
        "rmdrake.dynamics.chain": ("SerialChain",),
        "rmdrake.dynamics.compliance": (
            "GravityModel",
            "gravity_torques",
            "link_angles",
            "lowest_structural_mode",
            "motor_angles",
        ),
        "rmdrake.dynamics.data": (
            "JointSamples",
            "prepare_samples",
        ),
        "rmdrake.dynamics.estimators": (
            "DifferentialEvolutionLeastSquares",
            "OrdinaryLeastSquares",
            "WeightedLeastSquares",
        ),
        "rmdrake.dynamics.identification": (
            "identified_model",
            "identify",
        ),
        "rmdrake.dynamics.joint_log": (
            "JointLog",
            "read_joint_log",
            "write_joint_log",
        ),
        "rmdrake.dynamics.observations": ("Observations",),
        "rmdrake.dynamics.physical_fit": ("PhysicalLeastSquares",),
        "rmdrake.excitation.design": (
            "ExcitationResult",
            "design_excitation",
        ),
        "rmdrake.excitation.random": ("random_fourier_trajectory",),
        "rmdrake.excitation.trajectory": (
            "FourierTrajectory",
            "load_fourier",
        ),
        "rmdrake.io.atomic": (
            "atomic_write_bytes",
            "atomic_write_text",
        ),
        "rmdrake.kinematics.forward": (
            "point_jacobian",
            "robot_reach",
            "tool_jacobian",
            "tool_points",
            "tool_poses",
        ),
        "rmdrake.kinematics.ik": ("solve_tool_ik",),
        "rmdrake.model.dynamic_parameters": (
            "check_physical",
            "standard_parameters",
        ),
        "rmdrake.model.error_parameters": (
            "apply_deltas",
            "error_parameter_indices",
            "error_parameter_names",
        ),
        "rmdrake.model.loading": (
            "load_robot",
            "shipped_robots",
        ),
        "rmdrake.model.plant": ("MakePlant",),
        "rmdrake.model.robot": (
            "DEFAULT_ACCELERATION_TIME",
            "DYNAMIC_KEYS",
            "MDH_KEYS",
            "BaseFrame",
            "Compliance",
            "DynamicTerms",
            "JointLimits",
            "MassBounds",
            "Payload",
            "RobotModel",
        ),
        "rmdrake.model.urdf.export": ("robot_to_urdf",),
        "rmdrake.model.urdf.importer": ("robot_from_urdf",),
        "rmdrake.optimize": ("differential_evolution",),
    },
)
