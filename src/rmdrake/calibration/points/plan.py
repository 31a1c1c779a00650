"""A tracker plan for ``rmdrake plan``: ``poses`` x ``markers`` measured
points (noise in m per coordinate), calibrated by LM with the instrument pose
and the markers unknown (:class:`~rmdrake.calibration.points.lm.PointLM`,
the identifiable subset of the drawn parameters).

Example::

    PointPlan(poses=40, markers=3).describe()  # '40 poses (x 3 markers)'
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from rmdrake.calibration.config import CalibrationConfig, PointLMConfig
from rmdrake.calibration.kind import plan_count, reach_span
from rmdrake.model.robot import RobotModel

__all__ = ["PointPlan"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class PointPlan:
    """Robot poses and markers on the tool (counts >= 1).

    Raises:
      ValueError: a count that is not an integer >= 1, or over its cap
        (:func:`~rmdrake.calibration.points.simulate.check_point_counts`; one
        line).
    """

    kind: ClassVar[str] = "points"

    poses: int = 50
    markers: int = 3

    def __post_init__(self) -> None:
        from rmdrake.calibration.points.simulate import check_point_counts

        plan_count(self.poses, "poses")
        plan_count(self.markers, "markers")
        check_point_counts(self.poses, self.markers)

    @property
    def readings(self) -> int:
        """The poses."""
        return self.poses

    @property
    def per_reading(self) -> int:
        """One point per marker at each pose."""
        return self.markers

    def sized(self, readings: int) -> PointPlan:
        """``readings`` poses."""
        return dataclasses.replace(self, poses=readings)

    def describe(self) -> str:
        """``40 poses (x 3 markers)``."""
        return f"{self.readings} poses (x {self.markers} markers)"

    def record(self) -> dict[str, Any]:
        """``{"markers": M}``."""
        return {"markers": self.markers}

    def summary(self) -> dict[str, Any]:
        """The size fields of ``summary.yaml``: ``poses``, ``markers``."""
        return {"poses": self.poses, "markers": self.markers}

    def check(self, poses_from: str) -> None:
        """Points take random or D-optimal poses."""

    def noise_span(self, robot: RobotModel) -> tuple[float, str]:
        """The robot's reach, m."""
        return reach_span(robot)

    def simulate(
        self,
        robot: RobotModel,
        noise: float,
        seed: int,
        poses_from: str,
        nominal: RobotModel,
    ) -> Any:
        """:func:`~rmdrake.calibration.points.simulate.simulate_points` of
        the true ``robot``."""
        from rmdrake.calibration.points.simulate import simulate_points

        return simulate_points(
            robot,
            poses=self.poses,
            markers=self.markers,
            noise=noise,
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
        readings, at the nominal (the instrument pose and the markers absorb
        the base and tool frames' errors, whatever the readings).

        Raises:
          ValueError: none of them identifiable (one line).
        """
        from rmdrake.calibration.points.identifiability import (
            analyse_point_identifiability,
        )
        from rmdrake.calibration.points.lm import make_point_calibrator

        report = analyse_point_identifiability(nominal, sim.data, names)
        if not report.identifiable:
            raise ValueError(f"no parameter of {params} is identifiable")
        config = CalibrationConfig(
            params=",".join(report.identifiable),
            noise=noise,
            calibrator=PointLMConfig(),
        )
        return make_point_calibrator(config, nominal)

    def tool_points(self, est: Any, sim: Any) -> dict[str, Any]:
        """The tool point is the markers' centroid (a tracker sees the
        markers, not the tool frame)."""
        return {
            "p_E_calibrated": est.markers_.mean(axis=0),
            "p_E_true": sim.markers.mean(axis=0),
        }

    def too_few(self, unknowns: int, dof: int) -> str | None:
        """None: the identifiable subset depends on the readings."""
        return None
