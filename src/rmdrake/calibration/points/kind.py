"""The points as a measurement kind (:class:`~rmdrake.calibration.kind.
MeasurementKind`): a laser tracker or motion capture measures markers on the
tool in its own frame (``pose,marker,q1..qn,x,y,z[,payload]`` CSV, m);
calibrated by LM with the instrument pose and the markers unknown too.

Example::

    kind = PointKind()
    data = kind.read("points.csv", 6)
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
    PointLMConfig,
)
from rmdrake.calibration.kind import CrossValidationReport, refuse_distances
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.calibration.points.plan import PointPlan

__all__ = ["PointKind"]


class PointKind:
    """Point measurements: tool markers measured by a tracker (see the
    module docstring)."""

    name = "points"
    noun = "point"
    header = "pose,marker,q1..qn,x,y,z[,payload]"
    plan_option = "poses"
    plan_extra = "markers"
    plan_word = "tracker"

    def sniff(self, header: list[str]) -> bool:
        """``pose,marker,...``."""
        return header[:2] == ["pose", "marker"]

    def read(
        self,
        path: str | os.PathLike,
        n_joints: int | None = None,
        distances: Sequence[tuple[int, int, float]] = (),
    ) -> Any:
        """:func:`~rmdrake.calibration.points.data.read_point_measurements`;
        points have no socket distances (a one-line ValueError)."""
        from rmdrake.calibration.points.data import read_point_measurements

        refuse_distances(self, path, distances)
        return read_point_measurements(path, n_joints)

    def write(self, path: str | os.PathLike, data: Any) -> Path:
        """:func:`~rmdrake.calibration.points.data.write_point_measurements`."""
        from rmdrake.calibration.points.data import write_point_measurements

        return write_point_measurements(path, data)

    def calibrator(
        self, config: CalibrationConfig, model: RobotModel, progress: bool = False
    ) -> Any:
        """:func:`~rmdrake.calibration.points.lm.make_point_calibrator` of
        ``config``, showing the automatic choice's progress with
        ``progress``.

        Raises:
          ValueError: a plate method's config (one line).
        """
        from rmdrake.calibration.points.lm import make_point_calibrator

        est = make_point_calibrator(config, model)
        est.progress = progress
        return est

    def refuse_foreign(
        self, options: argparse.Namespace, path: str | os.PathLike, noun: str
    ) -> None:
        """Nothing: every option of this kind is refused by the others' own
        :meth:`calibrator_options`."""

    def calibrator_options(
        self, options: argparse.Namespace, path: str | os.PathLike
    ) -> CalibratorConfig:
        """A :class:`~rmdrake.calibration.config.PointLMConfig` with
        ``--seed``, ``--folds`` and ``--holdout``.

        Raises:
          ValueError: a ``--method`` other than ``lm`` (one line).
        """
        if options.method not in (None, "lm"):
            raise ValueError(
                f"method '{options.method}': point measurements are calibrated by "
                "lm only"
            )
        return PointLMConfig(
            seed=options.seed, folds=options.folds, holdout=options.holdout
        )

    def describe(self, model: RobotModel, data: Any, path: str | os.PathLike) -> str:
        """``robot 'rv3sb': 90 points, 30 poses x 3 markers from p.csv``."""
        return (
            f"robot '{model.name}': {data.n_rows} points, {data.pose_ids.size} poses "
            f"x {data.marker_ids.size} markers from {path}"
        )

    def cross_validate(
        self, config: CalibrationConfig, model: RobotModel, data: Any, est: Any
    ) -> CrossValidationReport | None:
        """The cross-validated 3-D point error over K folds of the poses or
        one held-out fraction of them, when the config's
        :class:`~rmdrake.calibration.config.PointLMConfig` asks for it (nested
        when ``params`` is ``auto``); else None."""
        from rmdrake.calibration.points.lm import make_point_calibrator
        from rmdrake.calibration.points.selection import cross_validate

        method = config.calibrator
        if not isinstance(method, PointLMConfig):
            method = PointLMConfig()
        if method.folds is None and method.holdout is None:
            return None
        cv = cross_validate(
            lambda: make_point_calibrator(config, model),
            data,
            folds=method.folds,
            holdout=method.holdout,
            seed=method.seed,
            progress=True,
        )
        nested = est.params == "auto"
        how = (
            "nested: the automatic choice rerun inside each training set"
            if nested
            else "the held-out poses never enter the fit"
        )
        line = (
            f"cross-validated 3-D point error ({cv.scheme} over poses, {how}): "
            f"RMS {cv.rms * 1e3:.4g} mm, max {cv.max * 1e3:.4g} mm; training RMS "
            f"{est.residual_rms_ * 1e3:.4g} mm, max {est.residual_max_ * 1e3:.4g} mm"
        )
        return CrossValidationReport({**cv.record(), "nested": nested}, (line,))

    def plan(self, size: int, extra: int | None = None) -> PointPlan:
        """The :class:`~rmdrake.calibration.points.plan.PointPlan` of ``--poses``
        ``size`` and ``--markers`` ``extra`` (None: its default)."""
        from rmdrake.calibration.points.plan import PointPlan

        sizes = {"poses": size}
        if extra is not None:
            sizes["markers"] = extra
        return PointPlan(**sizes)
