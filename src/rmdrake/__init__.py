"""rmdrake: accuracy for large manipulators, inside Drake.

Core numerics (no diagram wiring); Drake systems live in :mod:`rmdrake.systems`.
"""

from rmdrake.calibration.config import (
    CalibrationConfig,
    PlaneLMConfig,
    PointLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
)
from rmdrake.calibration.identifiability import (
    analyse_identifiability,
    analyse_point_identifiability,
)
from rmdrake.calibration.plates.data import (
    PlaneMeasurements,
    read_plane_measurements,
    write_plane_measurements,
)
from rmdrake.calibration.plates.estimators import (
    PlaneLM,
    VolumeDE,
    VolumeDEPlaneLM,
    make_calibrator,
)
from rmdrake.calibration.plates.simulate import simulate_plates
from rmdrake.calibration.points.data import (
    PointMeasurements,
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.calibration.points.lm import PointLM, make_point_calibrator
from rmdrake.calibration.points.selection import cross_validate
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.compensation.correction import (
    Correction,
    FilteredProgram,
    correct_path,
    correct_targets,
    filter_program,
)
from rmdrake.compensation.programs import (
    JointProgram,
    ToolTargets,
    read_joint_program,
    read_tool_targets,
    write_joint_program,
    write_tool_targets,
)
from rmdrake.dynamics import regressor
from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.chain import SerialChain
from rmdrake.dynamics.compliance import (
    GravityModel,
    gravity_torques,
    link_angles,
    lowest_structural_mode,
    motor_angles,
)
from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.identification import identified_model, identify
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.dynamics.observations import Observations
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares
from rmdrake.excitation.design import ExcitationResult, design_excitation
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import FourierTrajectory, load_fourier
from rmdrake.io.atomic import atomic_write_bytes, atomic_write_text
from rmdrake.kinematics.forward import (
    point_jacobian,
    robot_reach,
    tool_jacobian,
    tool_points,
    tool_poses,
)
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.model.dynamic_parameters import check_physical, standard_parameters
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot, shipped_robots
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import (
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
)
from rmdrake.model.urdf.export import robot_to_urdf
from rmdrake.model.urdf.importer import robot_from_urdf
from rmdrake.optimize import differential_evolution

from rmdrake.version import __version__ as __version__  # noqa: E402

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
    "CalibrationConfig",
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
    "make_point_calibrator",
    "MakePlant",
    "MDH_KEYS",
    "Observations",
    "OrdinaryLeastSquares",
    "Payload",
    "PhysicalLeastSquares",
    "PlaneLM",
    "PlaneLMConfig",
    "PlaneMeasurements",
    "point_jacobian",
    "PointLMConfig",
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
    "VolumeDEConfig",
    "VolumeDEPlaneLM",
    "VolumeDEPlaneLMConfig",
    "WeightedLeastSquares",
    "write_joint_log",
    "write_joint_program",
    "write_plane_measurements",
    "write_tool_targets",
]
