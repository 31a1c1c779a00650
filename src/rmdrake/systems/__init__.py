"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.systems.controllers": (
            "CalibratedCompensationController",
            "NominalController",
            "corrected_program",
            "default_gains",
        ),
        "rmdrake.systems.correction": (
            "JointTargetCorrection",
            "PresolvedTargetCorrection",
        ),
        "rmdrake.systems.deflection": (
            "AddPayloadMassSource",
            "DeflectionCompensation",
        ),
        "rmdrake.systems.excitation": (
            "FourierExcitationSource",
            "FourierTrajectoryView",
        ),
        "rmdrake.systems.friction": (
            "AddFrictionFeedforward",
            "JointFriction",
        ),
        "rmdrake.systems.joint_sensors": ("EncoderQuantizer",),
        "rmdrake.systems.measurement_runs": (
            "MeasurementRun",
            "measure_plates_in_diagram",
            "measurement_config",
        ),
        "rmdrake.systems.payload_estimator": ("PayloadEstimator",),
        "rmdrake.systems.sensors": (
            "RangeFinder",
            "ToolTracker",
        ),
        "rmdrake.systems.station": (
            "MakeStation",
            "RunStation",
            "Station",
        ),
        "rmdrake.systems.station_config": (
            "CompensationControllerConfig",
            "InverseDynamicsControllerConfig",
            "PidControllerConfig",
            "SensorConfig",
            "StationConfig",
        ),
        "rmdrake.systems.station_sources": (
            "JointTrajectorySource",
            "setpoint_move_times",
            "setpoint_times",
            "setpoint_trajectory",
        ),
        "rmdrake.systems.visualization": (
            "MakeMeshcat",
            "RobotScene",
            "save_calibration_html",
            "save_path_html",
            "save_robot_poses_html",
            "save_robot_states_html",
            "with_own_meshcat",
        ),
    },
)
