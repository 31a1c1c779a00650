"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

from rmdrake.systems.excitation import FourierExcitationSource
from rmdrake.systems.friction import JointFriction, friction_torque
from rmdrake.systems.joint_sensors import EncoderQuantizer
from rmdrake.systems.sensors import RangeFinder
from rmdrake.systems.station import MakeStation, RunStation, Station, default_gains

__all__: list[str] = [
    "EncoderQuantizer",
    "FourierExcitationSource",
    "JointFriction",
    "MakeStation",
    "RangeFinder",
    "RunStation",
    "Station",
    "default_gains",
    "friction_torque",
]
