"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

from rmdrake.systems.controllers import (
    CalibratedCompensationController,
    NominalController,
    corrected_program,
    default_gains,
)
from rmdrake.systems.correction import JointTargetCorrection, PresolvedTargetCorrection
from rmdrake.systems.deflection import AddPayloadMassSource, DeflectionCompensation
from rmdrake.systems.excitation import FourierExcitationSource, FourierTrajectoryView
from rmdrake.systems.friction import AddFrictionFeedforward, JointFriction
from rmdrake.systems.joint_sensors import EncoderQuantizer
from rmdrake.systems.measurement_runs import (
    MeasurementRun,
    measure_plates_in_diagram,
    measurement_config,
)
from rmdrake.systems.payload_estimator import PayloadEstimator
from rmdrake.systems.sensors import RangeFinder, ToolTracker
from rmdrake.systems.station import MakeStation, RunStation, Station
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    InverseDynamicsControllerConfig,
    PidControllerConfig,
    SensorConfig,
    StationConfig,
)
from rmdrake.systems.station_sources import (
    JointTrajectorySource,
    setpoint_move_times,
    setpoint_times,
    setpoint_trajectory,
)
from rmdrake.systems.visualization import (
    MakeMeshcat,
    RobotScene,
    save_calibration_html,
    save_path_html,
    save_robot_poses_html,
    save_robot_states_html,
    with_own_meshcat,
)

__all__: list[str] = [
    "AddFrictionFeedforward",
    "AddPayloadMassSource",
    "DeflectionCompensation",
    "save_robot_states_html",
    "CalibratedCompensationController",
    "NominalController",
    "corrected_program",
    "JointTargetCorrection",
    "PresolvedTargetCorrection",
    "EncoderQuantizer",
    "MakeMeshcat",
    "RobotScene",
    "save_calibration_html",
    "save_path_html",
    "save_robot_poses_html",
    "with_own_meshcat",
    "FourierExcitationSource",
    "FourierTrajectoryView",
    "JointFriction",
    "PayloadEstimator",
    "MakeStation",
    "RangeFinder",
    "ToolTracker",
    "JointTrajectorySource",
    "setpoint_move_times",
    "setpoint_times",
    "setpoint_trajectory",
    "MeasurementRun",
    "measure_plates_in_diagram",
    "measurement_config",
    "RunStation",
    "Station",
    "StationConfig",
    "SensorConfig",
    "CompensationControllerConfig",
    "InverseDynamicsControllerConfig",
    "PidControllerConfig",
    "default_gains",
]
