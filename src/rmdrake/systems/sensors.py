"""Sensors that look at the robot's tool: a range finder reading the distance to
a flat plate, and a tracker reading the position of a point on the tool.

The range finder's reading and its validity rule are those of
:func:`rmdrake.calibration.plates.range_finder.beam_readings` (the simulator applies
the same function); the tracker reads what
:func:`rmdrake.kinematics.forward.tool_points`
computes. These are the Drake-diagram forms, so that the readings of a
simulated station come from the MultibodyPlant's own kinematics.
"""

from __future__ import annotations

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    InputPort,
    LeafSystem,
)
from pydrake.systems.primitives import RandomSource

from rmdrake.arrays import as_finite_array
from rmdrake.calibration.plates.range_finder import RangeFinderSpec, beam_readings
from rmdrake.model.plant import TOOL_FRAME

__all__ = ["RangeFinder", "ToolTracker"]


class RangeFinder(LeafSystem):
    """Distance along the tool's z axis from the tool origin to a plate.

    .. pydrake_system::

        name: RangeFinder
        input_ports:
        - body_poses
        output_ports:
        - distance
        - valid

    ::

                        ┌───────────────┐
        body_poses ───► │  RangeFinder  ├───► distance  (1,) m, NaN if invalid
                        │               ├───► valid     (1,) 1.0 or 0.0
                        └───────────────┘

    ``body_poses`` is the MultibodyPlant's ``body_poses`` output (the pose of
    every body in the world W, which is the robot base B of rmdrake's plants).
    With the tool frame E fixed on link L at X_LE, the beam starts at p_WE and
    runs along z_WE. The reading t (m) and its validity (span, incidence cone,
    hit point on the plate) follow
    :func:`~rmdrake.calibration.plates.range_finder.beam_readings`. Invalid readings
    output NaN on ``distance`` and 0 on ``valid``. The output has no noise; add
    a random source downstream for that.

    Parameters of the Context, so that one diagram serves every plate location
    and sensor: the plate pose X_WP (abstract RigidTransform; set it with
    :meth:`SetPlatePose`) and the numbers of a
    :class:`~rmdrake.calibration.plates.range_finder.RangeFinderSpec` as one numeric
    parameter laid out by :meth:`RangeFinderSpec.as_vector
    <rmdrake.calibration.plates.range_finder.RangeFinderSpec.as_vector>`,
    [span_min, span_max, max_incidence, plate_x, plate_y] (m, rad; set them
    with :meth:`SetSpec`). The constructor's values are the defaults.

    Example:

    >>> from rmdrake import MakePlant, load_robot
    >>> from rmdrake.systems import RangeFinder
    >>> plant, _ = MakePlant(load_robot("rv3sb"))
    >>> finder = RangeFinder(plant=plant)
    >>> context = finder.CreateDefaultContext()
    >>> finder.get_output_port(0).get_name(), finder.GetSpec(context).span
    ('distance', (0.005, 0.08))
    """

    def __init__(
        self,
        *,
        plant: MultibodyPlant,
        tool_frame: str = TOOL_FRAME,
        spec: RangeFinderSpec | None = None,
        X_WP: RigidTransform | None = None,
    ) -> None:
        """
        Args:
          plant: the finalized plant carrying the tool frame (not stored; only
            the body index and X_LE are kept).
          tool_frame: name of the range finder's frame E.
          spec: default span, incidence cone and plate size
            (default ``RangeFinderSpec()``).
          X_WP: default plate pose (default identity).
        """
        super().__init__()
        spec = RangeFinderSpec() if spec is None else spec
        frame = plant.GetFrameByName(tool_frame)
        self._body_index = int(frame.body().index())
        self._X_LE = frame.GetFixedPoseInBodyFrame()
        self._spec = self.DeclareNumericParameter(BasicVector(spec.as_vector()))
        self._poses_port = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._plate = self.DeclareAbstractParameter(
            AbstractValue.Make(X_WP if X_WP is not None else RigidTransform())
        )
        self.DeclareVectorOutputPort("distance", 1, self._calc_distance)
        self.DeclareVectorOutputPort("valid", 1, self._calc_valid)

    @staticmethod
    def AddToBuilder(
        builder: DiagramBuilder,
        plant: MultibodyPlant,
        *,
        spec: RangeFinderSpec | None = None,
        X_WP: RigidTransform | None = None,
        name: str = "range_finder",
        tool_frame: str = TOOL_FRAME,
    ) -> RangeFinder:
        """Adds a RangeFinder named ``name`` to ``builder`` and connects the
        plant's ``body_poses`` output to it; returns the system.

        Args:
          builder: the builder that holds ``plant`` (finalized).
          plant: the robot's MultibodyPlant.
          spec, X_WP, tool_frame: as the constructor.
          name: the system's name in the diagram.
        """
        finder = builder.AddSystem(
            RangeFinder(plant=plant, tool_frame=tool_frame, spec=spec, X_WP=X_WP)
        )
        finder.set_name(name)
        builder.Connect(
            plant.get_body_poses_output_port(), finder.get_body_poses_input_port()
        )
        return finder

    def get_body_poses_input_port(self) -> InputPort:
        """The ``body_poses`` input port."""
        return self._poses_port

    def SetPlatePose(self, context: Context, X_WP: RigidTransform) -> None:
        """Sets the plate pose parameter in this system's ``context``."""
        context.get_mutable_abstract_parameter(self._plate).set_value(X_WP)

    def GetPlatePose(self, context: Context) -> RigidTransform:
        """The plate pose in this system's ``context``."""
        return context.get_abstract_parameter(self._plate).get_value()

    def SetSpec(self, context: Context, spec: RangeFinderSpec) -> None:
        """Sets the span, incidence cone and plate size in ``context``."""
        context.get_mutable_numeric_parameter(self._spec).SetFromVector(
            spec.as_vector()
        )

    def GetSpec(self, context: Context) -> RangeFinderSpec:
        """The span, incidence cone and plate size in ``context``.

        Raises:
          ValueError: the numeric parameter holds an invalid spec.
        """
        return RangeFinderSpec.from_vector(
            context.get_numeric_parameter(self._spec).value()
        )

    def _reading(self, context: Context) -> tuple[float, bool]:
        poses = self._poses_port.Eval(context)
        X_WE = poses[self._body_index] @ self._X_LE
        t, _, valid = beam_readings(
            X_WE.GetAsMatrix4()[None],
            self.GetPlatePose(context).GetAsMatrix4(),
            self.GetSpec(context),
        )
        return (float(t[0]) if valid[0] else float("nan")), bool(valid[0])

    def _calc_distance(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self._reading(context)[0])

    def _calc_valid(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, 1.0 if self._reading(context)[1] else 0.0)


class ToolTracker(LeafSystem):
    """Position of a marker M on the tool, as a laser tracker or a motion-capture
    system reads it.

    .. pydrake_system::

        name: ToolTracker
        input_ports:
        - body_poses
        - noise (optional)
        output_ports:
        - p_WM

    ::

                        ┌─────────────┐
        body_poses ───► │             │
                        │ ToolTracker ├───► p_WM  (3,) m, in W
        noise ────────► │             │
                        └─────────────┘

    ``body_poses`` is the MultibodyPlant's ``body_poses`` output (every body's
    pose in the world W, which is the robot base B of rmdrake's plants). With
    the tool frame E fixed on link L at X_LE, the output is

        p_WM = p_WE + R_WE p_EM + std * w

    where p_EM is the marker's offset from the tool origin, expressed in E (m),
    and w is the 3-vector on the ``noise`` input (standard normal samples; the
    input may stay unconnected, then w = 0). With p_EM = 0 and no noise it is
    :func:`rmdrake.kinematics.forward.tool_points` ``(model.table, q,
    sigma=model.sigma)`` (prismatic joints included: the plant has a
    PrismaticJoint where sigma is 1). p_EM (3, m) and std
    (1, m, >= 0) are numeric parameters of the Context (:meth:`SetMarkerOffset`,
    :meth:`SetNoiseStd`); the constructor's values are the defaults.

    Noise comes in on an input port, from a Drake ``RandomSource``
    (:meth:`AddToBuilder` adds one), rather than from a seed inside the system:
    Drake keeps random state in the Context, seeded for the whole diagram by
    ``diagram.SetRandomContext(context, RandomGenerator(seed))``, so one seed
    reproduces every noise of a station (the torque noise uses the same
    mechanism) and different contexts can draw different noise, while the
    tracker itself stays a pure function of its inputs and parameters.

    Example:

    >>> from rmdrake import MakePlant, load_robot
    >>> from rmdrake.systems import ToolTracker
    >>> plant, _ = MakePlant(load_robot("rv3sb"))
    >>> tracker = ToolTracker(plant=plant, p_EM=(0.0, 0.0, 0.05), noise=1e-5)
    >>> context = tracker.CreateDefaultContext()
    >>> tracker.GetMarkerOffset(context).tolist(), tracker.GetNoiseStd(context)
    ([0.0, 0.0, 0.05], 1e-05)
    """

    def __init__(
        self,
        *,
        plant: MultibodyPlant,
        tool_frame: str = TOOL_FRAME,
        p_EM: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
        noise: float = 0.0,
    ) -> None:
        """
        Args:
          plant: the finalized plant carrying the tool frame (not stored; only
            the body index and X_LE are kept).
          tool_frame: name of the tool frame E.
          p_EM: default marker offset in E, m.
          noise: default noise std, m (>= 0).
        """
        super().__init__()
        frame = plant.GetFrameByName(tool_frame)
        self._body_index = int(frame.body().index())
        self._X_LE = frame.GetFixedPoseInBodyFrame()
        self._p_EM = self.DeclareNumericParameter(BasicVector(_offset(p_EM)))
        self._std = self.DeclareNumericParameter(BasicVector([_std(noise)]))
        self._poses_port = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._noise_port = self.DeclareVectorInputPort("noise", 3)
        self.DeclareVectorOutputPort("p_WM", 3, self._calc_p_WM)

    @staticmethod
    def AddToBuilder(
        builder: DiagramBuilder,
        plant: MultibodyPlant,
        *,
        p_EM: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
        noise: float = 0.0,
        name: str = "tool_tracker",
        tool_frame: str = TOOL_FRAME,
        noise_period: float = 0.01,
    ) -> ToolTracker:
        """Adds a ToolTracker named ``name`` to ``builder``, connects the plant's
        ``body_poses`` output to it and, when ``noise`` > 0, a Drake
        ``RandomSource`` named ``{name}_noise`` (standard normal, a new sample
        every ``noise_period`` s) to its ``noise`` input; returns the tracker.

        With ``noise`` = 0 no source is added and the std parameter has no
        effect. Seed the noise with ``diagram.SetRandomContext``.

        Args:
          builder: the builder that holds ``plant`` (finalized).
          plant: the robot's MultibodyPlant.
          p_EM, noise, tool_frame: as the constructor (m, m).
          name: the system's name in the diagram.
          noise_period: s between noise samples (> 0); readings further apart
            than this get independent noise.
        """
        tracker = builder.AddNamedSystem(
            name,
            ToolTracker(plant=plant, tool_frame=tool_frame, p_EM=p_EM, noise=noise),
        )
        builder.Connect(
            plant.get_body_poses_output_port(), tracker.get_body_poses_input_port()
        )
        if noise > 0:
            source = builder.AddNamedSystem(
                f"{name}_noise",
                RandomSource(RandomDistribution.kGaussian, 3, noise_period),
            )
            builder.Connect(source.get_output_port(), tracker.get_noise_input_port())
        return tracker

    def get_body_poses_input_port(self) -> InputPort:
        """The ``body_poses`` input port."""
        return self._poses_port

    def get_noise_input_port(self) -> InputPort:
        """The ``noise`` input port (3 standard normal samples)."""
        return self._noise_port

    def SetMarkerOffset(self, context: Context, p_EM: np.ndarray) -> None:
        """Sets the marker offset p_EM (3, m, in E) in this system's ``context``."""
        context.get_mutable_numeric_parameter(self._p_EM).SetFromVector(_offset(p_EM))

    def GetMarkerOffset(self, context: Context) -> np.ndarray:
        """The marker offset p_EM (3, m, in E) in ``context``."""
        return context.get_numeric_parameter(self._p_EM).value().copy()

    def SetNoiseStd(self, context: Context, std: float) -> None:
        """Sets the noise std (m, >= 0) in this system's ``context``."""
        context.get_mutable_numeric_parameter(self._std).SetAtIndex(0, _std(std))

    def GetNoiseStd(self, context: Context) -> float:
        """The noise std (m) in ``context``."""
        return float(context.get_numeric_parameter(self._std).GetAtIndex(0))

    def _calc_p_WM(self, context: Context, output: BasicVector) -> None:
        X_WE = self._poses_port.Eval(context)[self._body_index] @ self._X_LE
        p_WM = X_WE @ context.get_numeric_parameter(self._p_EM).value()
        if self._noise_port.HasValue(context):
            p_WM = p_WM + self.GetNoiseStd(context) * self._noise_port.Eval(context)
        output.SetFromVector(p_WM)


def _offset(p_EM: object) -> np.ndarray:
    return as_finite_array(p_EM, "p_EM", (3,))


def _std(noise: object) -> float:
    std = float(as_finite_array(noise, "noise", ()))
    if std < 0:
        raise ValueError(f"noise: expected a std >= 0 m, found {std}")
    return std
