"""The poses as a measurement kind (the ``MeasurementKind`` interface of
:mod:`rmdrake.calibration.kind`): a 6-DoF instrument (a laser tracker with a
6-DoF probe, a calibrated camera seeing a marker) measures the pose X_IM of a
marker frame on the tool in its own frame I (``q1..qn,x,y,z,rx,ry,rz`` CSV,
m and rad, :mod:`rmdrake.calibration.poses.data`); calibrated by LM with the
instrument pose X_IB and the marker pose X_FM unknown too
(:class:`~rmdrake.calibration.poses.lm.PoseLM`).

The method's options are :class:`~rmdrake.calibration.poses.config.PoseLMConfig`
(re-exported here; the angle noise is the poses' own).

Example::

    from rmdrake.calibration.config import CalibrationConfig
    from rmdrake.calibration.poses.kind import PoseKind, PoseLMConfig
    kind = PoseKind()
    data = kind.read("poses.csv", 6)
    config = CalibrationConfig(noise=2e-5, calibrator=PoseLMConfig(angle_noise=5e-5))
    est = kind.calibrator(config, model).fit(data)
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rmdrake.calibration.config import CalibrationConfig
from rmdrake.calibration.poses.config import (
    PoseLMConfig,
    make_pose_calibrator,
    method_config,
)
from rmdrake.model.robot import RobotModel

__all__ = ["PoseKind", "PoseLMConfig", "make_pose_calibrator"]  # config re-exported


class PoseKind:
    """Pose measurements: a marker frame on the tool measured in 6-DoF (see
    the module docstring)."""

    name = "poses"
    noun = "pose"
    header = "q1..qn,x,y,z,rx,ry,rz"
    plan_option = "frames"
    plan_extra = "angle_noise"
    plan_word = "6-DoF"

    def sniff(self, header: list[str]) -> bool:
        """Joint columns, ``x,y,z`` and ``rx,ry,rz``, nothing else."""
        from rmdrake.calibration.poses.data import is_pose_header

        return is_pose_header(header)

    def read(
        self,
        path: str | os.PathLike,
        n_joints: int | None = None,
        distances: Sequence[tuple[int, int, float]] = (),
    ) -> Any:
        """:func:`~rmdrake.calibration.poses.data.read_pose_measurements`;
        poses have no socket distances (a one-line ValueError)."""
        from rmdrake.calibration.poses.data import read_pose_measurements

        if distances:
            raise ValueError(
                f"{path}: --socket-distance is for socket measurements; these are "
                f"{self.noun} measurements"
            )
        return read_pose_measurements(path, n_joints)

    def write(self, path: str | os.PathLike, data: Any) -> Path:
        """:func:`~rmdrake.calibration.poses.data.write_pose_measurements`."""
        from rmdrake.calibration.poses.data import write_pose_measurements

        return write_pose_measurements(path, data)

    def calibrator(
        self, config: CalibrationConfig, model: RobotModel, progress: bool = False
    ) -> Any:
        """:func:`make_pose_calibrator` of ``config``, showing the automatic
        choice's progress with ``progress``."""
        est = make_pose_calibrator(config, model)
        est.progress = progress
        return est

    def refuse_foreign(
        self, options: argparse.Namespace, path: str | os.PathLike, noun: str
    ) -> None:
        """Refuses ``--angle-noise`` for another kind's file (one line)."""
        if getattr(options, "angle_noise", None) is not None:
            raise ValueError(
                f"{path}: --angle-noise is for pose measurements; these are {noun} "
                "measurements"
            )

    def calibrator_options(
        self, options: argparse.Namespace, path: str | os.PathLike
    ) -> PoseLMConfig:
        """A :class:`PoseLMConfig` with ``--angle-noise``, ``--seed``,
        ``--folds`` and ``--holdout``.

        Raises:
          ValueError: a ``--method`` other than ``lm`` (one line).
        """
        if getattr(options, "method", None) not in (None, "lm"):
            raise ValueError(
                f"method '{options.method}': pose measurements are calibrated by lm "
                "only"
            )
        return PoseLMConfig(
            angle_noise=getattr(options, "angle_noise", None),
            seed=getattr(options, "seed", 0),
            folds=getattr(options, "folds", None),
            holdout=getattr(options, "holdout", None),
        )

    def describe(self, model: RobotModel, data: Any, path: str | os.PathLike) -> str:
        """``robot 'rv3sb': 40 poses (6-DoF marker readings) from p.csv``."""
        return (
            f"robot '{model.name}': {data.n_rows} poses (6-DoF marker readings) "
            f"from {path}"
        )

    def cross_validate(
        self, config: CalibrationConfig, model: RobotModel, data: Any, est: Any
    ) -> Any:
        """The held-out position and angle errors over K folds of the
        readings or one held-out fraction, when the config's
        :class:`PoseLMConfig` asks for them (nested when ``params`` is
        ``auto``), as a ``CrossValidationReport``; else None."""
        from rmdrake.calibration.kind import CrossValidationReport
        from rmdrake.calibration.poses.selection import cross_validate

        method = method_config(config)
        if method.folds is None and method.holdout is None:
            return None
        cv = cross_validate(
            lambda: make_pose_calibrator(config, model),
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
            f"cross-validated pose error ({cv.scheme} over readings, {how}): "
            f"position RMS {cv.rms_p * 1e3:.4g} mm, angle RMS {cv.rms_r * 1e3:.4g} "
            f"mrad; training {est.residual_rms_p_ * 1e3:.4g} mm, "
            f"{est.residual_rms_r_ * 1e3:.4g} mrad"
        )
        return CrossValidationReport({**cv.record(), "nested": nested}, (line,))

    def plan(self, size: int, extra: float | None = None) -> Any:
        """The :class:`~rmdrake.calibration.poses.plan.PosePlan` of
        ``--frames`` (and ``--angle-noise``, rad)."""
        from rmdrake.calibration.poses.plan import PosePlan

        return PosePlan(frames=size, angle_noise=extra)
