"""rmdrake: accuracy for large manipulators, inside Drake.

Core numerics (no diagram wiring); Drake systems live in :mod:`rmdrake.systems`.
"""

from rmdrake.calibration import (
    PlaneLM,
    PlaneMeasurements,
    PointLM,
    VolumeDE,
    VolumeDEPlaneLM,
    analyse_identifiability,
    analyse_point_identifiability,
    cross_validate,
    make_calibrator,
    simulate_plates,
    simulate_points,
    tool_point_errors,
)
from rmdrake.compensation import (
    Correction,
    FilteredProgram,
    correct_path,
    correct_targets,
    filter_program,
)
from rmdrake.compliance import (
    GravityModel,
    gravity_torques,
    link_angles,
    lowest_structural_mode,
    motor_angles,
)
from rmdrake.dynamics import (
    SerialChain,
    check_physical,
    regressor,
    standard_parameters,
)
from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    Observations,
    OrdinaryLeastSquares,
    PhysicalLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.identification import identified_model, identify
from rmdrake.excitation import (
    ExcitationResult,
    design_excitation,
    random_fourier_trajectory,
)
from rmdrake.ik import solve_tool_ik
from rmdrake.io import (
    JointLog,
    atomic_write_bytes,
    atomic_write_text,
    read_joint_log,
    read_plane_measurements,
    write_joint_log,
    write_plane_measurements,
)
from rmdrake.kinematics import (
    point_jacobian,
    robot_reach,
    tool_jacobian,
    tool_points,
    tool_poses,
)
from rmdrake.optimize import differential_evolution
from rmdrake.plant import MakePlant
from rmdrake.point_io import (
    PointMeasurements,
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.programs import (
    JointProgram,
    ToolTargets,
    read_joint_program,
    read_tool_targets,
    write_joint_program,
    write_tool_targets,
)
from rmdrake.robot import (
    DEFAULT_ACCELERATION_TIME,
    DYNAMIC_KEYS,
    MDH_KEYS,
    BaseFrame,
    Compliance,
    DynamicTerms,
    JointLimits,
    MassBounds,
    Payload,
    RobotModel,
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
    load_robot,
    shipped_robots,
)
from rmdrake.trajectory import FourierTrajectory, load_fourier
from rmdrake.urdf import robot_from_urdf, robot_to_urdf

__version__ = "0.1.0"

__all__ = [
    "Compliance",
    "GravityModel",
    "MassBounds",
    "gravity_torques",
    "link_angles",
    "lowest_structural_mode",
    "motor_angles",
    "PointLM",
    "analyse_point_identifiability",
    "cross_validate",
    "simulate_points",
    "PointMeasurements",
    "read_point_measurements",
    "write_point_measurements",
    "DynamicTerms",
    "analyse_identifiability",
    "apply_deltas",
    "atomic_write_bytes",
    "atomic_write_text",
    "base_parameters",
    "BaseFrame",
    "BaseParameters",
    "check_physical",
    "correct_path",
    "correct_targets",
    "Correction",
    "DEFAULT_ACCELERATION_TIME",
    "design_excitation",
    "differential_evolution",
    "DifferentialEvolutionLeastSquares",
    "DYNAMIC_KEYS",
    "error_parameter_indices",
    "error_parameter_names",
    "ExcitationResult",
    "filter_program",
    "FilteredProgram",
    "FourierTrajectory",
    "identified_model",
    "identify",
    "JointLimits",
    "JointLog",
    "JointProgram",
    "JointSamples",
    "load_fourier",
    "load_robot",
    "make_calibrator",
    "MakePlant",
    "MDH_KEYS",
    "Observations",
    "OrdinaryLeastSquares",
    "Payload",
    "PhysicalLeastSquares",
    "PlaneLM",
    "PlaneMeasurements",
    "point_jacobian",
    "prepare_samples",
    "random_fourier_trajectory",
    "read_joint_log",
    "read_joint_program",
    "read_plane_measurements",
    "read_tool_targets",
    "regressor",
    "robot_from_urdf",
    "robot_reach",
    "robot_to_urdf",
    "RobotModel",
    "SerialChain",
    "shipped_robots",
    "simulate_plates",
    "solve_tool_ik",
    "standard_parameters",
    "tool_point_errors",
    "tool_jacobian",
    "tool_points",
    "tool_poses",
    "ToolTargets",
    "VolumeDE",
    "VolumeDEPlaneLM",
    "WeightedLeastSquares",
    "write_joint_log",
    "write_joint_program",
    "write_plane_measurements",
    "write_tool_targets",
]
