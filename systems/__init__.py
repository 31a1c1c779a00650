"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

from rmdrake.systems.excitation import FourierExcitationSource
from rmdrake.systems.friction import JointFriction, friction_torque
from rmdrake.systems.identification_study import (
    IdentificationStudy,
    run_identification_study,
    simulate_log,
)
from rmdrake.systems.joint_sensors import EncoderQuantizer
from rmdrake.systems.sensors import RangeFinder
from rmdrake.systems.station import MakeStation, RunStation, Station, default_gains
from rmdrake.systems.visualization import (
    MakeMeshcat,
    RobotScene,
    save_calibration_html,
    save_robot_poses_html,
)

__all__: list[str] = [
    "EncoderQuantizer",
    "IdentificationStudy",
    "MakeMeshcat",
    "RobotScene",
    "run_identification_study",
    "save_calibration_html",
    "save_robot_poses_html",
    "simulate_log",
    "FourierExcitationSource",
    "JointFriction",
    "MakeStation",
    "RangeFinder",
    "RunStation",
    "Station",
    "default_gains",
    "friction_torque",
]
