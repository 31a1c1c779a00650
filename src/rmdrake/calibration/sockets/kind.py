"""The sockets as a measurement kind (:class:`~rmdrake.calibration.kind.
MeasurementKind`): a ball on the tool seated in sockets at unknown places,
some pairs a known distance apart (``socket,q1..qn`` CSV and
``<stem>_distances.csv``, m); calibrated by LM, one unknown point per socket.

Example::

    kind = SocketKind()
    data = kind.read("sockets.csv", 6, distances=[(0, 1, 0.05)])
    est = kind.calibrator(CalibrationConfig(), model).fit(data)
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rmdrake.calibration.config import (
    DEFAULT_DISTANCE_NOISE,
    CalibrationConfig,
    CalibratorConfig,
    SocketLMConfig,
)
from rmdrake.calibration.kind import CrossValidationReport
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.calibration.sockets.plan import SocketPlan

__all__ = ["SocketKind"]


class SocketKind:
    """Socket measurements: a ball seated in fixed sockets (see the module
    docstring)."""

    name = "sockets"
    noun = "socket"
    header = "socket,q1..qn"
    plan_option = "placements"
    plan_extra = "per_socket"
    plan_word = "socket"

    def sniff(self, header: list[str]) -> bool:
        """``socket,q1..qn`` in any order."""
        return "socket" in header and all(
            c == "socket" or (c[:1] == "q" and c[1:].isdigit()) for c in header
        )

    def read(
        self,
        path: str | os.PathLike,
        n_joints: int | None = None,
        distances: Sequence[tuple[int, int, float]] = (),
    ) -> Any:
        """:func:`~rmdrake.calibration.sockets.data.read_socket_measurements`
        with ``distances`` ``(a, b, metres)`` added to those of the file
        beside it."""
        from rmdrake.calibration.sockets.data import read_socket_measurements

        return read_socket_measurements(path, n_joints, distances=distances)

    def write(self, path: str | os.PathLike, data: Any) -> Path:
        """:func:`~rmdrake.calibration.sockets.data.write_socket_measurements`
        (and its distance file)."""
        from rmdrake.calibration.sockets.data import write_socket_measurements

        return write_socket_measurements(path, data)

    def calibrator(
        self, config: CalibrationConfig, model: RobotModel, progress: bool = False
    ) -> Any:
        """:func:`~rmdrake.calibration.sockets.lm.make_socket_calibrator` of
        ``config`` (its fit shows no progress: ``progress`` is unused).

        Raises:
          ValueError: another kind's method, or options sockets do not have
            (one line).
        """
        from rmdrake.calibration.sockets.lm import make_socket_calibrator

        return make_socket_calibrator(config, model)

    def refuse_foreign(
        self, options: argparse.Namespace, path: str | os.PathLike, noun: str
    ) -> None:
        """Refuses the sockets' own options (``--drop-outliers``,
        ``--distance-noise``, ``--folds placements``) given for ``noun``
        measurements of another kind.

        Raises:
          ValueError: one of them given (one line).
        """
        given = options.drop_outliers or options.distance_noise is not None
        if given or options.folds == "placements":
            raise ValueError(
                f"{path}: --drop-outliers, --distance-noise and --folds placements "
                f"are for socket measurements; these are {noun} measurements"
            )

    def calibrator_options(
        self, options: argparse.Namespace, path: str | os.PathLike
    ) -> CalibratorConfig:
        """A :class:`~rmdrake.calibration.config.SocketLMConfig` with
        ``--distance-noise`` (m), ``--drop-outliers`` and ``--folds
        placements``.

        Raises:
          ValueError: a ``--method`` other than ``lm``, ``--holdout`` or
            ``--folds`` other than ``placements`` (one line).
        """
        if options.method not in (None, "lm"):
            raise ValueError(
                f"method '{options.method}': socket measurements are calibrated by "
                "lm only"
            )
        if options.holdout is not None or options.folds not in (None, "placements"):
            raise ValueError(
                f"{path}: socket measurements cross-validate over placements only "
                "(--folds placements)"
            )
        return SocketLMConfig(
            distance_noise=options.distance_noise or DEFAULT_DISTANCE_NOISE,
            drop_outliers=options.drop_outliers,
            folds=options.folds,
        )

    def describe(self, model: RobotModel, data: Any, path: str | os.PathLike) -> str:
        """``robot 'panda': 497 configurations in 16 sockets, 8 placements,
        8 known distances from s.csv``."""
        return (
            f"robot '{model.name}': {data.n_rows} configurations in "
            f"{data.socket_ids.size} sockets, {data.n_placements} placements, "
            f"{data.distances.shape[0]} known distances from {path}"
        )

    def cross_validate(
        self, config: CalibrationConfig, model: RobotModel, data: Any, est: Any
    ) -> CrossValidationReport | None:
        """Leave-one-placement-out consistency and distortion (m) when the
        config's :class:`~rmdrake.calibration.config.SocketLMConfig` has
        ``folds`` ``placements`` (nested when ``params`` is ``auto``); else
        None."""
        from rmdrake.calibration.sockets.lm import (
            cross_validate_placements,
            make_socket_calibrator,
        )

        method = config.calibrator
        if not isinstance(method, SocketLMConfig) or method.folds != "placements":
            return None
        cv = cross_validate_placements(
            lambda: make_socket_calibrator(config, model), data
        )
        nested = est.params == "auto"
        line = (
            f"held-out placements (leave one out{', nested' if nested else ''}): "
            f"consistency mean {np.mean(cv.before) * 1e3:.4g} mm (nominal) -> "
            f"{cv.mean_abs * 1e3:.4g} mm, RMS {cv.rms * 1e3:.4g} mm; distortion "
            f"mean {np.mean(cv.distortion) * 1e3:+.4g} mm, mean |.| "
            f"{np.mean(np.abs(cv.distortion)) * 1e3:.4g} mm"
        )
        record = {**cv.record(), "nested": nested}
        return CrossValidationReport(record, (line, *cv.table_lines()))

    def plan(self, size: int, extra: int | None = None) -> SocketPlan:
        """The :class:`~rmdrake.calibration.sockets.plan.SocketPlan` of ``--placements``
        ``size`` and ``--per-socket`` ``extra`` (None: its default)."""
        from rmdrake.calibration.sockets.plan import SocketPlan

        sizes = {"placements": size}
        if extra is not None:
            sizes["per_socket"] = extra
        return SocketPlan(**sizes)
