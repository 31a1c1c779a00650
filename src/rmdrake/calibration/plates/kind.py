"""The plates as a measurement kind (:class:`~rmdrake.calibration.kind.
MeasurementKind`): a range finder on the tool reads distances to a flat plate
put at several unknown places (``plane,q1..qn,distance`` CSV, distances in
m); calibrated by DE on volumes, LM on point-to-plane distances or both.

Example::

    kind = PlateKind()
    data = kind.read("plates.csv", 6)
    est = kind.calibrator(CalibrationConfig(), model).fit(data)
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rmdrake.calibration.config import (
    CalibrationConfig,
    CalibratorConfig,
    plate_calibrator_config,
    with_de_options,
)
from rmdrake.calibration.kind import CrossValidationReport, refuse_distances
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.calibration.plates.plan import PlatePlan

__all__ = ["PlateKind"]


class PlateKind:
    """Plane measurements: readings of a range finder on plates (see the
    module docstring)."""

    name = "plates"
    noun = "plane"
    header = "plane,q1..qn,distance"
    plan_option = "plates"
    plan_extra = "per_plate"
    plan_word = "plate"

    def sniff(self, header: list[str]) -> bool:
        """``plane,q1..qn,distance[,payload]``."""
        return header[:1] == ["plane"] and "distance" in header[-2:]

    def read(
        self,
        path: str | os.PathLike,
        n_joints: int | None = None,
        distances: Sequence[tuple[int, int, float]] = (),
    ) -> Any:
        """:func:`~rmdrake.calibration.plates.data.read_plane_measurements`;
        plates have no socket distances (a one-line ValueError)."""
        from rmdrake.calibration.plates.data import read_plane_measurements

        refuse_distances(self, path, distances)
        return read_plane_measurements(path, n_joints)

    def write(self, path: str | os.PathLike, data: Any) -> Path:
        """:func:`~rmdrake.calibration.plates.data.write_plane_measurements`."""
        from rmdrake.calibration.plates.data import write_plane_measurements

        return write_plane_measurements(path, data)

    def calibrator(
        self, config: CalibrationConfig, model: RobotModel, progress: bool = False
    ) -> Any:
        """:func:`~rmdrake.calibration.plates.estimators.make_calibrator` of
        ``config`` (its DE's progress bar is the config's: ``progress`` is
        unused).

        Raises:
          ValueError: a point method's config (one line).
          TypeError: a config of another kind's method.
        """
        from rmdrake.calibration.plates.estimators import make_calibrator

        return make_calibrator(config, model)

    def refuse_foreign(
        self, options: argparse.Namespace, path: str | os.PathLike, noun: str
    ) -> None:
        """Nothing: every option of this kind is refused by the others' own
        :meth:`calibrator_options`."""

    def calibrator_options(
        self, options: argparse.Namespace, path: str | os.PathLike
    ) -> CalibratorConfig:
        """The config of ``--method`` (default ``de+lm``); a method with a DE
        gets ``--seed``, ``--length-bound`` (m), ``--angle-bound`` (rad), the
        progress bar unless ``--no-progress`` and ``--maxiter`` when given.

        Raises:
          ValueError: ``--folds`` or ``--holdout`` (one line).
        """
        if options.folds is not None or options.holdout is not None:
            raise ValueError(
                f"{path}: --folds and --holdout cross-validate point "
                "measurements; these are plane measurements"
            )
        de = {
            "seed": options.seed,
            "length_bound": options.length_bound,
            "angle_bound": options.angle_bound,
            "progress": not options.no_progress,
        }
        if options.maxiter is not None:
            de["maxiter"] = options.maxiter
        method = plate_calibrator_config(options.method or "de+lm")
        return with_de_options(method, **de)

    def describe(self, model: RobotModel, data: Any, path: str | os.PathLike) -> str:
        """``robot 'rv3sb': 60 readings on 5 plates from plates.csv``."""
        return (
            f"robot '{model.name}': {data.n_readings} readings on "
            f"{data.plate_ids.size} plates from {path}"
        )

    def cross_validate(
        self, config: CalibrationConfig, model: RobotModel, data: Any, est: Any
    ) -> CrossValidationReport | None:
        """None: a plate calibration reports no cross-validation of its own
        (``auto`` chooses its parameters by one, in the fit)."""
        return None

    def plan(self, size: int, extra: int | None = None) -> PlatePlan:
        """The :class:`~rmdrake.calibration.plates.plan.PlatePlan` of ``--plates``
        ``size`` and ``--per-plate`` ``extra`` (None: its default)."""
        from rmdrake.calibration.plates.plan import PlatePlan

        sizes = {"plates": size}
        if extra is not None:
            sizes["per_plate"] = extra
        return PlatePlan(**sizes)
