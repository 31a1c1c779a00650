"""Kinematic calibration: plane constraints (Wang et al. 2016, §2 and §4) and
measured tool points (laser tracker, motion capture: :mod:`.points`) and a
ball seated in sockets at unknown places (MUKCa: :mod:`.sockets`) and 6-DoF
marker frames (a tracker's 6-DoF probe, a camera: :mod:`.poses`).

A range finder on the tool reads the distance to a flat plate put at several
unknown places; the points measured on one plate are coplanar exactly when the
kinematic model is right. This package simulates such readings, analyses which
error parameters they identify, and estimates them with the paper's method
(Differential Evolution on tetrahedron volumes), with Levenberg-Marquardt on
point-to-plane distances, or with both (``de+lm``). One typed
:class:`~rmdrake.calibration.config.CalibrationConfig` (:mod:`.config`) holds
a calibration's settings, its method a tagged choice of per-method configs.
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.calibration.config": (
            "CALIBRATION_METHODS",
            "CalibrationConfig",
            "CalibratorConfig",
            "PlaneLMConfig",
            "PlateCalibratorConfig",
            "PointLMConfig",
            "SocketLMConfig",
            "VolumeDEConfig",
            "VolumeDEPlaneLMConfig",
            "de_start_budget",
            "plate_calibrator_config",
            "with_de_options",
        ),
        "rmdrake.calibration.identifiability": ("IdentifiabilityReport",),
        "rmdrake.calibration.parameters": (
            "POINT_PRESETS",
            "joint_offset_names",
            "parameter_bounds",
            "resolve_parameters",
        ),
        "rmdrake.calibration.plates.cost": (
            "PlaneProblem",
            "VolumeCost",
            "fit_plane",
            "fit_planes",
            "plate_quadruples",
            "tetrahedron_volumes",
        ),
        "rmdrake.calibration.plates.calibrator": ("PlaneCalibrator",),
        "rmdrake.calibration.plates.data": ("PlaneMeasurements",),
        "rmdrake.calibration.plates.estimators": (
            "CALIBRATION_LOSSES",
            "PlaneLM",
            "VolumeDE",
            "VolumeDEPlaneLM",
            "make_calibrator",
        ),
        "rmdrake.calibration.plates.identifiability": ("analyse_identifiability",),
        "rmdrake.calibration.plates.pose_selection": ("select_d_optimal",),
        "rmdrake.calibration.plates.range_finder": (
            "BeamReadings",
            "RangeFinderSpec",
            "beam_readings",
            "ray_plane_distance",
        ),
        "rmdrake.calibration.plates.selection": (
            "PlateCrossValidation",
            "PlateSelection",
            "plate_cross_validate",
            "plate_distances",
            "plate_splits",
            "select_plate_parameters",
        ),
        "rmdrake.calibration.plates.simulate": (
            "Plate",
            "SimulatedPlates",
            "random_poses",
            "range_readings",
            "simulate_plates",
        ),
        "rmdrake.calibration.points.data": ("PointMeasurements",),
        "rmdrake.calibration.points.identifiability": (
            "analyse_point_identifiability",
        ),
        "rmdrake.calibration.points.lm": (
            "PointLM",
            "make_point_calibrator",
        ),
        "rmdrake.calibration.points.problem": (
            "PointProblem",
            "initial_alignment",
        ),
        "rmdrake.calibration.points.selection": (
            "CrossValidation",
            "Selection",
            "cross_validate",
            "pose_splits",
            "select_parameters",
        ),
        "rmdrake.calibration.points.simulate": (
            "SimulatedPoints",
            "simulate_points",
        ),
        "rmdrake.calibration.poses.config": ("PoseLMConfig", "make_pose_calibrator"),
        "rmdrake.calibration.poses.data": (
            "PoseMeasurements",
            "read_pose_measurements",
            "write_pose_measurements",
        ),
        "rmdrake.calibration.poses.identifiability": ("analyse_pose_identifiability",),
        "rmdrake.calibration.poses.lm": ("PoseLM",),
        "rmdrake.calibration.poses.simulate": ("SimulatedPoses", "simulate_poses"),
        "rmdrake.calibration.selection": (
            "StepwiseSelection",
            "held_out_ids",
            "one_se_choice",
            "stepwise_selection",
        ),
        "rmdrake.calibration.sockets.data": (
            "SocketMeasurements",
            "read_mukca_sockets",
            "read_socket_measurements",
            "write_socket_measurements",
        ),
        "rmdrake.calibration.sockets.lm": (
            "SocketLM",
            "analyse_socket_identifiability",
            "cross_validate_placements",
            "make_socket_calibrator",
        ),
        "rmdrake.calibration.sockets.problem": (
            "SocketProblem",
            "socket_metrics",
        ),
        "rmdrake.calibration.sockets.simulate": (
            "SimulatedSockets",
            "simulate_sockets",
        ),
        "rmdrake.calibration.kind": ("CrossValidationReport", "MeasurementKind"),
        "rmdrake.calibration.registry": (
            "KINDS",
            "kind_named",
            "kind_of_file",
            "measurement_kind",
        ),
        "rmdrake.calibration.validation": (
            "ValidationResult",
            "tool_point_errors",
        ),
        "rmdrake.kinematics.compare": ("rigid_alignment",),
        "rmdrake.kinematics.ik": ("solve_tool_ik",),
    },
)
