"""A plate plan for ``rmdrake plan``: ``plates`` locations x ``per_plate``
range-finder readings (noise in m per reading), calibrated by LM on
point-to-plane distances (:class:`~rmdrake.calibration.plates.estimators.
PlaneLM`; ``full`` fits its identifiable subset).

Example::

    plan = PlatePlan(plates=5, per_plate=12)
    plan.sized(120).describe()  # '120 readings (5 plates x 24)'
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from rmdrake.calibration.config import CalibrationConfig, PlaneLMConfig
from rmdrake.calibration.kind import plan_count
from rmdrake.model.robot import RobotModel

__all__ = ["PlatePlan"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class PlatePlan:
    """Plate locations and readings per plate (counts >= 1).

    Raises:
      ValueError: a count that is not an integer >= 1 (one line).
    """

    kind: ClassVar[str] = "plates"

    plates: int = 5
    per_plate: int = 12

    def __post_init__(self) -> None:
        from rmdrake.calibration.plates.simulate import check_plate_counts

        plan_count(self.plates, "plates")
        plan_count(self.per_plate, "per_plate")
        check_plate_counts(self.plates, self.per_plate)

    @property
    def readings(self) -> int:
        """Readings in all: plates x per_plate."""
        return self.plates * self.per_plate

    @property
    def per_reading(self) -> int:
        """One distance per reading."""
        return 1

    def sized(self, readings: int) -> PlatePlan:
        """``readings`` in all on the same plates.

        Raises:
          ValueError: not a multiple of ``plates`` (one line).
        """
        if readings % self.plates:
            raise ValueError(
                f"readings {readings}: not a multiple of the {self.plates} plates "
                "(readings = plates x per-plate)"
            )
        return dataclasses.replace(self, per_plate=readings // self.plates)

    def describe(self) -> str:
        """``60 readings (5 plates x 12)``."""
        return f"{self.readings} readings ({self.plates} plates x {self.per_plate})"

    def record(self) -> dict[str, Any]:
        """``{"plates": P}``."""
        return {"plates": self.plates}

    def summary(self) -> dict[str, Any]:
        """The size fields of ``summary.yaml``: ``plates``, ``per_plate``."""
        return {"plates": self.plates, "per_plate": self.per_plate}

    def check(self, poses_from: str) -> None:
        """Plates take random or D-optimal poses."""

    def noise_span(self, robot: RobotModel) -> tuple[float, str]:
        """The range finder's span, m."""
        from rmdrake.calibration.plates.range_finder import RangeFinderSpec

        lo, hi = RangeFinderSpec().span
        return hi - lo, "the range finder's span"

    def simulate(
        self,
        robot: RobotModel,
        noise: float,
        seed: int,
        poses_from: str,
        nominal: RobotModel,
    ) -> Any:
        """:func:`~rmdrake.calibration.plates.simulate.simulate_plates` of
        the true ``robot``."""
        from rmdrake.calibration.plates.simulate import simulate_plates

        return simulate_plates(
            robot,
            plates=self.plates,
            per_plate=self.per_plate,
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
        """LM of ``full`` (its identifiable subset) or of the drawn names (a
        set the readings cannot identify is the calibrator's error)."""
        from rmdrake.calibration.plates.estimators import make_calibrator

        fitted = "full" if params == "full" else ",".join(names)
        config = CalibrationConfig(
            params=fitted, noise=noise, calibrator=PlaneLMConfig()
        )
        return make_calibrator(config, nominal)

    def tool_points(self, est: Any, sim: Any) -> dict[str, Any]:
        """The tool frame's origin: no keyword."""
        return {}

    def too_few(self, unknowns: int, dof: int) -> str | None:
        """The note when the readings cannot fit ``unknowns`` parameters and
        the plates (3 unknowns each) with ``dof`` to check the fit."""
        need = unknowns + 3 * self.plates + dof
        if self.readings >= need:
            return None
        return (
            f"note: {self.describe()} cannot calibrate {unknowns} parameters and "
            f"{self.plates} plates ({unknowns + 3 * self.plates} unknowns and {dof} "
            f"degrees of freedom to check the fit need {need} readings): its arms "
            "will fail"
        )
