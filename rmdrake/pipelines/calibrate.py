"""``rmdrake calibrate``: plate or point readings in, a calibrated robot YAML
out. The measurements' kind is read from the file's header; the fit is checked
(:mod:`rmdrake.calibration.sanity`, :mod:`rmdrake.calibration.points.checks`)
and an implausible one raises :class:`~rmdrake.errors.ImplausibleResultError`,
writing nothing, unless forced."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from rmdrake.calibration.plates.data import read_plane_measurements
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.points.data import measurement_kind, read_point_measurements
from rmdrake.calibration.points.lm import PointLM
from rmdrake.calibration.points.selection import cross_validate
from rmdrake.model.loading import Robot, as_robot_model
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.checked import Echo, write_checked

__all__ = ["calibrate_file"]


def calibrate_file(
    robot: Robot,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    method: str | None = None,
    params: str | None = None,
    seed: int = 0,
    folds: int | None = None,
    holdout: float | None = None,
    maxiter: int | None = None,
    length_bound: float = 3e-3,
    angle_bound: float = 3e-3,
    loss: str = "linear",
    f_scale: float = 1e-5,
    progress: bool = True,
    noise: float | None = None,
    force: bool = False,
    compliance: bool = False,
    echo: Echo = print,
) -> Path:
    """Calibrates ``robot`` from a plane- or point-measurement CSV (told apart
    by the header, :func:`rmdrake.calibration.points.data.measurement_kind`); writes the
    calibrated robot YAML (its ``calibration`` record names the file).

    Args:
      method: plates: ``de``, ``lm`` or ``de+lm`` (default; see
        :func:`~rmdrake.calibration.plates.estimators.make_calibrator`); points:
        ``lm`` only (:class:`~rmdrake.calibration.points.lm.PointLM`).
      params: plates: ``paper`` (default), ``full`` or comma-separated names;
        points: ``auto`` (default, chosen by cross-validation), ``base``,
        ``offsets``, ``full`` or names.
      folds, holdout: points: also report the cross-validated 3-D point error
        over K folds of the poses, or over one held-out fraction of them
        (split by ``seed``; nested when ``params`` is ``auto``).
      seed, maxiter, length_bound, angle_bound: the DE's seed, generations
        (None: its default) and search box (+-m on lengths, +-rad on angles).
      loss, f_scale: LM's loss and robust scale (m).
      progress: show the DE's progress.
      noise: the readings' declared standard deviation, m (None: estimated
        from the data), for the sanity checks.
      force: write the result even when its sanity checks
        (:mod:`rmdrake.calibration.sanity`) fail: the reasons are then printed
        as warnings and recorded as the ``warnings`` list of the YAML's
        ``calibration`` record.
      compliance: add every joint's compliance ``c<j>`` to ``params``
        (elastostatic calibration, :mod:`rmdrake.calibration.elastostatic`;
        points: to the set ``auto`` chooses;
        the robot needs ``dynamics``; readings under several payloads make the
        compliances visible); the YAML gets ``compliance: {stiffness}`` of the
        identified joints (N m/rad) and the record their ``compliance``.

    Raises:
      ImplausibleResultError: the sanity checks failed and not ``force``
        (nothing written; ``reasons`` one line per failed check, ``result``
        the calibrated RobotModel).
    """
    model = as_robot_model(robot)
    if measurement_kind(measurements) == "point":
        options = {"params": params or "auto", "loss": loss, "f_scale": f_scale}
        return _calibrate_points(
            model,
            measurements,
            out,
            method=method or "lm",
            options={**options, "compliance": compliance},
            seed=seed,
            folds=folds,
            holdout=holdout,
            noise=noise,
            force=force,
            echo=echo,
        )
    if folds is not None or holdout is not None:
        raise ValueError(
            f"{measurements}: --folds and --holdout cross-validate point "
            "measurements; these are plane measurements"
        )
    method = method or "de+lm"
    options: dict[str, Any] = {"params": params or "paper"}
    if compliance:
        options["compliance"] = True
    if method != "lm":
        options.update(seed=seed, length_bound=length_bound, angle_bound=angle_bound)
        options["progress"] = progress
        if maxiter is not None:
            options["maxiter"] = maxiter
    if method != "de":
        options.update(loss=loss, f_scale=f_scale)
    data = read_plane_measurements(measurements, model.n_joints)
    est = make_calibrator(method, model, **options).fit(data)
    sanity, record = _checked_record(est, noise, measurements)
    echo(
        f"robot '{model.name}': {data.n_readings} readings on "
        f"{data.plate_ids.size} plates from {measurements}"
    )
    echo(est.summary())
    echo(sanity.summary())
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=force, echo=echo
    )


def _checked_record(est: Any, noise: float | None, measurements: Any) -> tuple:
    """(sanity report, calibration record naming the data file) of a fitted
    plate or point calibration; ``noise`` (m) replaces the estimated noise in
    the sanity checks when given."""
    sanity = est.sanity_ if noise is None else est.check(noise=noise)
    record = dict(est.model_.calibration)
    record["data"] = {**record["data"], "file": str(measurements)}
    return sanity, record


def _calibrate_points(
    model: RobotModel,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    method: str,
    options: dict[str, Any],
    seed: int,
    folds: int | None,
    holdout: float | None,
    noise: float | None,
    force: bool,
    echo: Echo,
) -> Path:
    """:func:`calibrate_file` of point measurements."""
    if method != "lm":
        raise ValueError(
            f"method '{method}': point measurements are calibrated by lm only"
        )
    data = read_point_measurements(measurements, model.n_joints)
    options = {**options, "seed": seed}
    est = PointLM(model, **options).fit(data)
    sanity, record = _checked_record(est, noise, measurements)
    echo(
        f"robot '{model.name}': {data.n_rows} points, {data.pose_ids.size} poses x "
        f"{data.marker_ids.size} markers from {measurements}"
    )
    echo(est.summary())
    if folds is not None or holdout is not None:
        cv = cross_validate(
            lambda: PointLM(model, **options),
            data,
            folds=folds,
            holdout=holdout,
            seed=seed,
        )
        nested = options["params"] == "auto"
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
    echo(sanity.summary())
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=force, echo=echo
    )
