"""``rmdrake calibrate``: plate or point readings in, a calibrated robot YAML
out. The measurements' kind is read from the file's header; the fit is checked
(:mod:`rmdrake.calibration.sanity`, :mod:`rmdrake.calibration.points.checks`)
and an implausible one raises :class:`~rmdrake.errors.ImplausibleResultError`,
writing nothing, unless forced."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.calibration.config import (
    CalibrationConfig,
    PointLMConfig,
    SocketLMConfig,
)
from rmdrake.calibration.plates.data import read_plane_measurements
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.points.data import measurement_kind, read_point_measurements
from rmdrake.calibration.points.lm import make_point_calibrator
from rmdrake.calibration.points.selection import cross_validate
from rmdrake.calibration.sockets.data import read_socket_measurements
from rmdrake.calibration.sockets.lm import (
    cross_validate_placements,
    make_socket_calibrator,
)
from rmdrake.model.loading import Robot, as_robot_model
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.checked import Echo, write_checked

__all__ = ["calibrate_file"]


def calibrate_file(
    robot: Robot,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: CalibrationConfig | None = None,
    echo: Echo = print,
    distances: Sequence[tuple[int, int, float]] = (),
) -> Path:
    """Calibrates ``robot`` from a plane-, point- or socket-measurement CSV
    (told apart by the header,
    :func:`rmdrake.calibration.points.data.measurement_kind`); writes the
    calibrated robot YAML (its ``calibration`` record names the file).

    Args:
      config: the calibration (None = ``CalibrationConfig()``: ``de+lm`` on
        plates, ``lm`` on points, both with ``auto`` parameters: chosen by
        cross-validation over the plates, or over the poses). Plates: built by
        :func:`~rmdrake.calibration.plates.estimators.make_calibrator` (the
        summary lists the automatic choice's candidates); points:
        by :func:`~rmdrake.calibration.points.lm.make_point_calibrator`, and
        its :class:`~rmdrake.calibration.config.PointLMConfig`'s ``folds`` or
        ``holdout`` also report the cross-validated 3-D point error over K
        folds of the poses, or over one held-out fraction of them (split by its
        ``seed``; nested when ``params`` is ``auto``), recorded as the
        record's ``cross_validation``. ``noise`` (m; None: estimated from the
        data) replaces the estimated noise in the sanity checks; ``force``
        writes the result even when its sanity checks
        (:mod:`rmdrake.calibration.sanity`) fail: the reasons are then printed
        as warnings and recorded as the ``warnings`` list of the YAML's
        ``calibration`` record. With ``compliance`` (elastostatic calibration,
        :mod:`rmdrake.calibration.elastostatic`; the robot needs ``dynamics``;
        readings under several payloads make the compliances visible) the YAML
        gets ``compliance: {stiffness}`` of the identified joints (N m/rad) and
        the record their ``compliance``.
      echo: where the summary lines go.
      distances: sockets only: known distances ``(a, b, metres)`` added to
        those of the distance file beside the CSV
        (:func:`~rmdrake.calibration.sockets.data.read_socket_measurements`).
        Sockets are calibrated by
        :func:`~rmdrake.calibration.sockets.lm.make_socket_calibrator`; a
        :class:`~rmdrake.calibration.config.SocketLMConfig` with ``folds``
        ``placements`` also reports the leave-one-placement-out consistency
        and distortion, recorded as ``cross_validation``.

    Raises:
      ValueError: the config's method does not calibrate this kind of
        measurements (a :class:`~rmdrake.calibration.config.PointLMConfig` on
        plane measurements, a plate method on point measurements), or the
        measurements or options are invalid (one line).
      ImplausibleResultError: the sanity checks failed and not ``force``
        (nothing written; ``reasons`` one line per failed check, ``result``
        the calibrated RobotModel).
    """
    config = CalibrationConfig() if config is None else config
    model = as_robot_model(robot)
    kind = measurement_kind(measurements)
    if kind == "socket":
        return _calibrate_sockets(
            model, measurements, out, config=config, echo=echo, distances=distances
        )
    if kind == "point":
        return _calibrate_points(model, measurements, out, config=config, echo=echo)
    if isinstance(config.calibrator, PointLMConfig):
        raise ValueError(
            f"{measurements}: PointLMConfig calibrates point measurements; these "
            "are plane measurements"
        )
    data = read_plane_measurements(measurements, model.n_joints)
    est = make_calibrator(config, model).fit(data)
    sanity, record = _checked_record(est, measurements)
    echo(
        f"robot '{model.name}': {data.n_readings} readings on "
        f"{data.plate_ids.size} plates from {measurements}"
    )
    echo(est.summary())
    _echo_sanity(sanity, echo)
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=config.force, echo=echo
    )


def _checked_record(est: Any, measurements: Any) -> tuple:
    """(sanity report, calibration record naming the data file) of a fitted
    plate or point calibration (its sanity checks ran in the fit, against the
    config's declared noise when it has one)."""
    sanity = est.sanity_
    record = dict(est.model_.calibration)
    record["data"] = {**record["data"], "file": str(measurements)}
    if sanity.warnings:
        record["sanity_warnings"] = list(sanity.warnings)
    return sanity, record


def _echo_sanity(sanity: Any, echo: Echo) -> None:
    """The sanity line, then each warning on its own line."""
    echo(sanity.summary())
    for warning in sanity.warnings:
        echo(f"warning: {warning}")


def _calibrate_points(
    model: RobotModel,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: CalibrationConfig,
    echo: Echo,
) -> Path:
    """:func:`calibrate_file` of point measurements."""
    est = make_point_calibrator(config, model)  # refuses a plate method
    method = config.calibrator
    if not isinstance(method, PointLMConfig):
        method = PointLMConfig()
    data = read_point_measurements(measurements, model.n_joints)
    est.progress = True  # the choice of parameters can take a minute
    est.fit(data)
    sanity, record = _checked_record(est, measurements)
    echo(
        f"robot '{model.name}': {data.n_rows} points, {data.pose_ids.size} poses x "
        f"{data.marker_ids.size} markers from {measurements}"
    )
    echo(est.summary())
    if method.folds is not None or method.holdout is not None:
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
        record["cross_validation"] = {**cv.record(), "nested": nested}
        echo(
            f"cross-validated 3-D point error ({cv.scheme} over poses, {how}): "
            f"RMS {cv.rms * 1e3:.4g} mm, max {cv.max * 1e3:.4g} mm; training RMS "
            f"{est.residual_rms_ * 1e3:.4g} mm, max {est.residual_max_ * 1e3:.4g} mm"
        )
    _echo_sanity(sanity, echo)
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=config.force, echo=echo
    )


def _calibrate_sockets(
    model: RobotModel,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: CalibrationConfig,
    echo: Echo,
    distances: Sequence[tuple[int, int, float]],
) -> Path:
    """:func:`calibrate_file` of socket measurements."""
    est = make_socket_calibrator(config, model)  # refuses another method
    method = config.calibrator
    if not isinstance(method, SocketLMConfig):
        method = SocketLMConfig()
    data = read_socket_measurements(measurements, model.n_joints, distances=distances)
    est.fit(data)
    sanity, record = _checked_record(est, measurements)
    echo(
        f"robot '{model.name}': {data.n_rows} configurations in "
        f"{data.socket_ids.size} sockets, {data.n_placements} placements, "
        f"{data.distances.shape[0]} known distances from {measurements}"
    )
    echo(est.summary())
    if method.folds == "placements":
        cv = cross_validate_placements(
            lambda: make_socket_calibrator(config, model), data
        )
        nested = est.params == "auto"
        record["cross_validation"] = {**cv.record(), "nested": nested}
        echo(
            f"held-out placements (leave one out{', nested' if nested else ''}): "
            f"consistency mean {np.mean(cv.before) * 1e3:.4g} mm (nominal) -> "
            f"{cv.mean_abs * 1e3:.4g} mm, RMS {cv.rms * 1e3:.4g} mm; distortion "
            f"mean {np.mean(cv.distortion) * 1e3:+.4g} mm, mean |.| "
            f"{np.mean(np.abs(cv.distortion)) * 1e3:.4g} mm"
        )
        for line in cv.table_lines():
            echo(line)
    _echo_sanity(sanity, echo)
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=config.force, echo=echo
    )
