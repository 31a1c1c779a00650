"""Kinematic calibration: plane constraints (Wang et al. 2016, §2 and §4) and
measured tool points (laser tracker, motion capture: :mod:`.points`) and a
ball seated in sockets at unknown places (MUKCa: :mod:`.sockets`).

A range finder on the tool reads the distance to a flat plate put at several
unknown places; the points measured on one plate are coplanar exactly when the
kinematic model is right. This package simulates such readings, analyses which
error parameters they identify, and estimates them with the paper's method
(Differential Evolution on tetrahedron volumes), with Levenberg-Marquardt on
point-to-plane distances, or with both (``de+lm``). One typed
:class:`~rmdrake.calibration.config.CalibrationConfig` (:mod:`.config`) holds
a calibration's settings, its method a tagged choice of per-method configs.
"""

from rmdrake.calibration.calibrator import PlaneCalibrator
from rmdrake.calibration.config import (
    CalibrationConfig,
    CalibratorConfig,
    PlaneLMConfig,
    PlateCalibratorConfig,
    PointLMConfig,
    SocketLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
    de_start_budget,
    plate_calibrator_config,
    with_de_options,
)
from rmdrake.calibration.identifiability import (
    IdentifiabilityReport,
    analyse_identifiability,
    analyse_point_identifiability,
)
from rmdrake.calibration.parameters import (
    POINT_PRESETS,
    joint_offset_names,
    parameter_bounds,
    resolve_parameters,
)
from rmdrake.calibration.plates.cost import (
    PlaneProblem,
    VolumeCost,
    fit_plane,
    fit_planes,
    plate_quadruples,
    tetrahedron_volumes,
)
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.estimators import (
    CALIBRATION_LOSSES,
    CALIBRATION_METHODS,
    PlaneLM,
    VolumeDE,
    VolumeDEPlaneLM,
    make_calibrator,
)
from rmdrake.calibration.plates.pose_selection import select_d_optimal
from rmdrake.calibration.plates.range_finder import (
    BeamReadings,
    RangeFinderSpec,
    beam_readings,
    ray_plane_distance,
)
from rmdrake.calibration.plates.selection import (
    PlateCrossValidation,
    PlateSelection,
    plate_cross_validate,
    plate_distances,
    plate_splits,
    select_plate_parameters,
)
from rmdrake.calibration.plates.simulate import (
    Plate,
    SimulatedPlates,
    random_poses,
    range_readings,
    simulate_plates,
)
from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.lm import PointLM, make_point_calibrator
from rmdrake.calibration.points.problem import PointProblem, initial_alignment
from rmdrake.calibration.points.selection import (
    CrossValidation,
    Selection,
    cross_validate,
    pose_splits,
    select_parameters,
)
from rmdrake.calibration.points.simulate import SimulatedPoints, simulate_points
from rmdrake.calibration.selection import (
    StepwiseSelection,
    one_se_choice,
    stepwise_selection,
)
from rmdrake.calibration.sockets.data import (
    SocketMeasurements,
    read_mukca_sockets,
    read_socket_measurements,
    write_socket_measurements,
)
from rmdrake.calibration.sockets.lm import (
    SocketLM,
    analyse_socket_identifiability,
    cross_validate_placements,
    make_socket_calibrator,
)
from rmdrake.calibration.sockets.problem import SocketProblem, socket_metrics
from rmdrake.calibration.sockets.simulate import SimulatedSockets, simulate_sockets
from rmdrake.calibration.validation import ValidationResult, tool_point_errors
from rmdrake.kinematics.compare import rigid_alignment
from rmdrake.kinematics.ik import solve_tool_ik

__all__ = [
    "CalibrationConfig",
    "CalibratorConfig",
    "PlaneLMConfig",
    "PlateCalibratorConfig",
    "PointLMConfig",
    "VolumeDEConfig",
    "VolumeDEPlaneLMConfig",
    "de_start_budget",
    "make_point_calibrator",
    "plate_calibrator_config",
    "with_de_options",
    "POINT_PRESETS",
    "CrossValidation",
    "PointLM",
    "PointMeasurements",
    "PointProblem",
    "Selection",
    "SimulatedPoints",
    "analyse_point_identifiability",
    "cross_validate",
    "initial_alignment",
    "joint_offset_names",
    "pose_splits",
    "select_parameters",
    "simulate_points",
    "SimulatedSockets",
    "SocketLM",
    "SocketLMConfig",
    "SocketMeasurements",
    "SocketProblem",
    "analyse_socket_identifiability",
    "cross_validate_placements",
    "make_socket_calibrator",
    "read_mukca_sockets",
    "read_socket_measurements",
    "simulate_sockets",
    "socket_metrics",
    "write_socket_measurements",
    "PlateCrossValidation",
    "PlateSelection",
    "StepwiseSelection",
    "one_se_choice",
    "plate_cross_validate",
    "plate_distances",
    "plate_splits",
    "select_plate_parameters",
    "stepwise_selection",
    "CALIBRATION_LOSSES",
    "CALIBRATION_METHODS",
    "BeamReadings",
    "IdentifiabilityReport",
    "PlaneCalibrator",
    "PlaneLM",
    "PlaneMeasurements",
    "PlaneProblem",
    "Plate",
    "RangeFinderSpec",
    "SimulatedPlates",
    "ValidationResult",
    "VolumeCost",
    "VolumeDE",
    "VolumeDEPlaneLM",
    "analyse_identifiability",
    "beam_readings",
    "fit_plane",
    "fit_planes",
    "make_calibrator",
    "parameter_bounds",
    "plate_quadruples",
    "random_poses",
    "range_readings",
    "ray_plane_distance",
    "resolve_parameters",
    "rigid_alignment",
    "select_d_optimal",
    "simulate_plates",
    "solve_tool_ik",
    "tetrahedron_volumes",
    "tool_point_errors",
]
