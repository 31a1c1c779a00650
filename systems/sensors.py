"""A range finder on the robot's tool, reading the distance to a flat plate.

The reading and its validity rule are those of
:func:`rmdrake.calibration.range_finder.beam_readings` (the simulator applies
the same function); this is the Drake-diagram form, so that the readings of a
simulated station come from the MultibodyPlant's own kinematics.
"""

from __future__ import annotations

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

from rmdrake.calibration.range_finder import RangeFinderSpec, beam_readings
from rmdrake.plant import TOOL_FRAME

__all__ = ["RangeFinder"]


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
    :func:`~rmdrake.calibration.range_finder.beam_readings`. Invalid readings
    output NaN on ``distance`` and 0 on ``valid``. The output has no noise; add
    a random source downstream for that.

    Parameters of the Context, so that one diagram serves every plate location
    and sensor: the plate pose X_WP (abstract RigidTransform; set it with
    :meth:`SetPlatePose`) and the numbers of a
    :class:`~rmdrake.calibration.range_finder.RangeFinderSpec` as one numeric
    parameter laid out by :meth:`RangeFinderSpec.as_vector
    <rmdrake.calibration.range_finder.RangeFinderSpec.as_vector>`,
    [span_min, span_max, max_incidence, plate_x, plate_y] (m, rad; set them
    with :meth:`SetSpec`). The constructor's values are the defaults.
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
            (default :class:`RangeFinderSpec`()).
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
