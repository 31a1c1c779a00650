"""A 6-DoF plan for ``rmdrake plan``: ``frames`` robot poses, each measured as
a marker frame (position noise in m per coordinate, angle noise in rad per
axis), calibrated by LM with the instrument pose X_IB and the marker pose X_FM
unknown (:class:`~rmdrake.calibration.poses.lm.PoseLM`, the identifiable
subset of the drawn parameters).

The angle noise defaults to :data:`ANGLE_PER_POSITION_NOISE` times the
position noise: a 6-DoF probe's orientation is read over a lever of about
0.4 m, so 20 um per coordinate goes with 50 urad per axis.

Example::

    PosePlan(frames=40).describe()  # '40 frames (6-DoF poses)'
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from rmdrake.calibration.config import CalibrationConfig
from rmdrake.calibration.kind import plan_count, reach_span
from rmdrake.model.robot import RobotModel

__all__ = ["ANGLE_PER_POSITION_NOISE", "PosePlan"]

ANGLE_PER_POSITION_NOISE = 2.5
"""rad per m: the default angle noise of a plan over its position noise."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class PosePlan:
    """Robot poses measured in 6-DoF (a count >= 1) and the angle noise.

    Attributes:
      frames: robot poses, each one 6-DoF reading.
      angle_noise: std of each orientation component, rad; None =
        :data:`ANGLE_PER_POSITION_NOISE` x the plan's position noise.

    Raises:
      ValueError: a count that is not an integer >= 1, a negative angle noise
        (one line).
    """

    kind: ClassVar[str] = "poses"

    frames: int = 40
    angle_noise: float | None = None

    def __post_init__(self) -> None:
        from rmdrake.calibration.poses.simulate import MAX_POSES

        if plan_count(self.frames, "frames") > MAX_POSES:
            raise ValueError(
                f"frames: {self.frames} is over the cap of {MAX_POSES} poses (a "
                "campaign measures hundreds); give fewer"
            )
        if self.angle_noise is not None and not self.angle_noise >= 0:
            raise ValueError(
                f"angle_noise: expected >= 0 rad, found {self.angle_noise!r}"
            )

    @property
    def readings(self) -> int:
        """The poses."""
        return self.frames

    @property
    def per_reading(self) -> int:
        """One frame per pose."""
        return 1

    def sized(self, readings: int) -> PosePlan:
        """``readings`` poses."""
        return dataclasses.replace(self, frames=readings)

    def describe(self) -> str:
        """``40 frames (6-DoF poses)``."""
        return f"{self.readings} frames (6-DoF poses)"

    def record(self) -> dict[str, Any]:
        """``{"angle_noise": rad or None}``."""
        return {"angle_noise": self.angle_noise}

    def summary(self) -> dict[str, Any]:
        """The size fields of ``summary.yaml``: ``frames``, ``angle_noise``."""
        return {"frames": self.frames, "angle_noise": self.angle_noise}

    def check(self, poses_from: str) -> None:
        """Frames take random or D-optimal poses."""

    def noise_span(self, robot: RobotModel) -> tuple[float, str]:
        """The robot's reach, m."""
        return reach_span(robot)

    def _angle_noise(self, noise: float) -> float:
        """rad: the stated angle noise, or the default for ``noise`` (m)."""
        if self.angle_noise is not None:
            return self.angle_noise
        return ANGLE_PER_POSITION_NOISE * noise

    def simulate(
        self,
        robot: RobotModel,
        noise: float,
        seed: int,
        poses_from: str,
        nominal: RobotModel,
    ) -> Any:
        """:func:`~rmdrake.calibration.poses.simulate.simulate_poses` of the
        true ``robot``, ``noise`` m per coordinate."""
        from rmdrake.calibration.poses.simulate import simulate_poses

        return simulate_poses(
            robot,
            poses=self.frames,
            noise_p=noise,
            noise_r=self._angle_noise(noise),
            seed=seed,
            selection="d-optimal" if poses_from == "d-optimal" else "first",
            planning_model=nominal,
        )

    def calibrator(
        self,
        nominal: RobotModel,
        sim: Any,
        names: list[str],
        params: str,
        noise: float | None,
    ) -> Any:
        """LM of the identifiable subset of the drawn names on these
        readings, at the nominal (X_IB and X_FM absorb the base and tool
        frames' errors, whatever the readings).

        Raises:
          ValueError: none of them identifiable (one line).
        """
        from rmdrake.calibration.poses.config import (
            PoseLMConfig,
            make_pose_calibrator,
        )
        from rmdrake.calibration.poses.identifiability import (
            analyse_pose_identifiability,
        )

        report = analyse_pose_identifiability(nominal, sim.data, names)
        if not report.identifiable:
            raise ValueError(f"no parameter of {params} is identifiable")
        angle = None if noise is None else self._angle_noise(noise)
        config = CalibrationConfig(
            params=",".join(report.identifiable),
            noise=noise,
            calibrator=PoseLMConfig(angle_noise=angle),
        )
        return make_pose_calibrator(config, nominal)

    def tool_points(self, est: Any, sim: Any) -> dict[str, Any]:
        """The tool point is the marker's origin (the instrument sees the
        marker frame, not the tool frame)."""
        return {"p_E_calibrated": est.X_FM_[:3, 3], "p_E_true": sim.X_FM[:3, 3]}

    def too_few(self, unknowns: int, dof: int) -> str | None:
        """None: the identifiable subset depends on the readings."""
        return None
