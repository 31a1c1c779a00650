"""A range finder on the robot's tool, reading the distance to a flat plate.

The numerics are those of :mod:`rmdrake.calibration.measurements`; this is the
Drake-diagram form, so that the readings of a simulated station come from the
MultibodyPlant's own kinematics.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from rmdrake.plant import TOOL_FRAME

__all__ = ["RangeFinder"]


class RangeFinder(LeafSystem):
    """Distance along the tool's z axis from the tool origin to a plate.

    .. code-block:: text

                        ┌───────────────┐
        body_poses ───► │  RangeFinder  ├───► distance  (1,) m, NaN if invalid
                        │               ├───► valid     (1,) 1.0 or 0.0
                        └───────────────┘
        parameters (Context): X_WP, the plate pose (RigidTransform, abstract);
          [span_min, span_max, max_incidence, plate_x, plate_y] (m, rad; numeric)

    ``body_poses`` is the MultibodyPlant's ``body_poses`` output (the pose of
    every body in the world W, which is the robot base B of rmdrake's plants).
    With the tool frame E fixed on link L at X_LE, the beam starts at p_WE and
    runs along z_WE; the plate frame P has its origin at the plate centre and
    z_P as the normal on the sensor's side. The reading is the distance t (m) to
    the plate plane; it is valid when t lies in ``span``, the incidence (angle
    between z_WE and -z_WP) is at most ``max_incidence`` and the hit point lies
    on the plate (|x_P|, |y_P| within half of ``plate_size``). Invalid readings
    output NaN on ``distance`` and 0 on ``valid``. The output has no noise; add a
    random source downstream for that.

    The plate pose and the sensor's numbers are parameters of the Context (set
    the pose with :meth:`SetPlatePose`), so one diagram serves every plate
    location; the constructor's values are the defaults.
    """

    def __init__(
        self,
        *,
        plant: MultibodyPlant,
        tool_frame: str = TOOL_FRAME,
        span: Sequence[float] = (0.005, 0.080),
        max_incidence: float = float(np.deg2rad(35.0)),
        plate_size: Sequence[float] = (0.3, 0.3),
        X_WP: RigidTransform | None = None,
    ) -> None:
        """
        Args:
          plant: the finalized plant carrying the tool frame (not stored; only
            the body index and X_LE are kept).
          tool_frame: name of the range finder's frame E.
          span: (min, max) valid reading, m.
          max_incidence: largest incidence angle, rad.
          plate_size: (2,) plate edge lengths along x_P, y_P, m.
          X_WP: default plate pose.
        """
        super().__init__()
        frame = plant.GetFrameByName(tool_frame)
        self._body_index = int(frame.body().index())
        self._X_LE = frame.GetFixedPoseInBodyFrame()
        if not 0 <= span[0] < span[1]:
            raise ValueError(f"span: expected 0 <= min < max, found {tuple(span)}")
        self._numbers = self.DeclareNumericParameter(
            BasicVector([span[0], span[1], max_incidence, plate_size[0], plate_size[1]])
        )
        self._poses_port = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._plate = self.DeclareAbstractParameter(
            AbstractValue.Make(X_WP if X_WP is not None else RigidTransform())
        )
        self.DeclareVectorOutputPort("distance", 1, self._calc_distance)
        self.DeclareVectorOutputPort("valid", 1, self._calc_valid)

    def get_body_poses_input_port(self):
        """The ``body_poses`` input port."""
        return self._poses_port

    def SetPlatePose(self, context: Context, X_WP: RigidTransform) -> None:
        """Sets the plate pose parameter in this system's ``context``."""
        context.get_mutable_abstract_parameter(self._plate).set_value(X_WP)

    def GetPlatePose(self, context: Context) -> RigidTransform:
        """The plate pose in this system's ``context``."""
        return context.get_abstract_parameter(self._plate).get_value()

    def _reading(self, context: Context) -> tuple[float, bool]:
        poses = self._poses_port.Eval(context)
        X_WE = poses[self._body_index] @ self._X_LE
        X_WP = self.GetPlatePose(context)
        p_WE = X_WE.translation()
        z_WE = X_WE.rotation().col(2)
        n_W = X_WP.rotation().col(2)
        cos = float(n_W @ z_WE)
        if abs(cos) < 1e-12:
            return float("nan"), False
        t = float(n_W @ (X_WP.translation() - p_WE)) / cos
        p_WM = p_WE + t * z_WE
        p_PM = X_WP.inverse() @ p_WM
        lo, hi, max_incidence, size_x, size_y = context.get_numeric_parameter(
            self._numbers
        ).value()
        valid = (
            lo <= t <= hi
            and -cos >= np.cos(max_incidence)
            and abs(p_PM[0]) <= size_x / 2
            and abs(p_PM[1]) <= size_y / 2
        )
        return (t if valid else float("nan")), valid

    def _calc_distance(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self._reading(context)[0])

    def _calc_valid(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, 1.0 if self._reading(context)[1] else 0.0)
