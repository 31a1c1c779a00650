"""File-to-file pipelines behind ``rmdrake calibrate``, ``simulate`` and
``identify`` (``correct``: :mod:`rmdrake.studies.correct`): read and check the
inputs, run, check that the result is plausible
(:mod:`rmdrake.calibration.sanity`, :mod:`rmdrake.dynamics.sanity`: an
implausible one raises :class:`~rmdrake.errors.ImplausibleResultError` and
writes nothing unless forced), write the result atomically and echo the lines
that say what was done. Scripts can call them as the command line does."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.calibration.estimators import make_calibrator
from rmdrake.calibration.point_lm import PointLM
from rmdrake.calibration.point_selection import cross_validate
from rmdrake.dynamics.data import stack_samples
from rmdrake.dynamics.identification import fit_summary, identified_model, identify
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.sanity import check_identification
from rmdrake.errors import ImplausibleResultError
from rmdrake.io import (
    JointLog,
    read_plane_measurements,
    write_joint_log,
)
from rmdrake.point_io import measurement_kind, read_point_measurements
from rmdrake.progress import progress_bar
from rmdrake.robot import RobotModel, load_robot
from rmdrake.studies.correct import correct_file
from rmdrake.studies.simulate import (
    controller_model_for,
    log_summary,
    simulate_trajectory,
    station_config,
)
from rmdrake.trajectory import check_sampling, load_fourier

__all__ = ["calibrate_file", "correct_file", "identify_file", "simulate_file"]

Echo = Callable[[str], None]
Robot = RobotModel | str | os.PathLike
"""A robot: a loaded model, a shipped name, a robot YAML or a URDF path."""


def _model(robot: Robot) -> RobotModel:
    return robot if isinstance(robot, RobotModel) else load_robot(robot)


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
    by the header, :func:`rmdrake.point_io.measurement_kind`); writes the
    calibrated robot YAML (its ``calibration`` record names the file).

    Args:
      method: plates: ``de``, ``lm`` or ``de+lm`` (default; see
        :func:`~rmdrake.calibration.estimators.make_calibrator`); points:
        ``lm`` only (:class:`~rmdrake.calibration.point_lm.PointLM`).
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
    model = _model(robot)
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
    return _write_checked(
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
    return _write_checked(
        est.model_, record, list(sanity.reasons), out, force=force, echo=echo
    )


def _write_checked(
    model: Any,
    record: dict[str, Any],
    reasons: list[str],
    out: str | os.PathLike,
    *,
    force: bool,
    echo: Echo,
) -> Path:
    """Saves ``model`` with its ``calibration`` ``record``; if ``reasons`` (the
    failed sanity checks) raises ImplausibleResultError unless ``force``, when
    they are echoed as warnings and recorded as ``record["warnings"]``."""
    if reasons and not force:
        rejected = dataclasses.replace(model, calibration=record)
        raise ImplausibleResultError(reasons, rejected)
    if reasons:
        record = {**record, "warnings": list(reasons)}
        for reason in reasons:
            echo(f"warning: implausible result written (forced): {reason}")
    return dataclasses.replace(model, calibration=record).save(out)


def simulate_file(
    robot: str,
    trajectory: str | os.PathLike,
    out: str | os.PathLike,
    *,
    nominal: str | None = None,
    periods: float = 1.0,
    derivatives: bool = True,
    echo: Echo = print,
    **station: Any,
) -> Path:
    """Runs the true ``robot`` along a Fourier trajectory YAML in the Drake
    station and writes the joint log (t,q,tau[,qd,qdd]; CSV or NPZ by suffix).

    The controller uses ``nominal`` (default :func:`controller_model_for`);
    ``station`` are the options of
    :func:`~rmdrake.studies.simulate.station_config` (rate in Hz, accuracy,
    v_eps in rad/s, torque noise in N m, encoder resolution in rad, seed).
    """
    true_model = load_robot(robot)
    controller = load_robot(nominal) if nominal else None
    controller = controller or controller_model_for(true_model, str(robot))
    traj = load_fourier(trajectory)
    config = station_config(**station)
    check_sampling(traj.base_frequency, 1.0 / config.log_period, periods, traj.n_joints)
    duration = periods * traj.period
    same = "" if controller is not true_model else ", the true robot itself"
    if controller.compliance is None and true_model.compliance is not None:
        same = ", rigid joints"
    echo(
        f"simulating '{true_model.name}' (controller model '{controller.name}'"
        f"{same}) for {duration:.6g} s ({periods:g} period(s) of "
        f"{traj.period:.6g} s), logging at {1 / config.log_period:g} Hz"
    )
    bar: list = []  # opened at the first step: bad input fails before

    def progress(t: float, t_final: float) -> None:
        if not bar:
            bar.append(progress_bar(total=round(duration, 3), desc="simulated s"))
        bar[0].update(t - bar[0].n)

    try:
        log, wall = simulate_trajectory(
            config, true_model, controller, traj, periods=periods, progress=progress
        )
    finally:
        for b in bar:
            b.close()
    if not derivatives:
        log = JointLog(t=log.t, q=log.q, tau=log.tau)
    path = write_joint_log(out, log)
    fields = "t,q,tau,qd,qdd" if log.qd is not None else "t,q,tau"
    echo(
        f"wrote {path}: {log.n_samples} samples x {log.n_joints} joints ({fields}) "
        f"in {wall:.2f} s wall time ({duration / wall:.2f}x real time)"
    )
    for line in log_summary(
        log, traj, true_model.limits.effort, sigma=true_model.sigma
    ):
        echo(line)
    return path


def identify_file(
    robot: Robot,
    log_path: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    trajectory: str | os.PathLike | None = None,
    method: str = "physical",
    seed: int = 0,
    coulomb_width: float = 0.0,
    noise: float | Sequence[float] | None = None,
    force: bool = False,
    prior: Robot | None = None,
    mass_bounds: Any = None,
    total_mass: Any = None,
    gains: Sequence[float] | None = None,
    echo: Echo = print,
    **preparation: Any,
) -> Path:
    """Identifies ``robot``'s dynamics from one or several joint logs; writes
    the identified robot YAML.

    Each log is prepared alone (:func:`~rmdrake.dynamics.data.prepare_samples`:
    time window, resampling, filtering, derivatives, standstill removal) and
    the samples are stacked (:func:`~rmdrake.dynamics.data.stack_samples`):
    no filter or derivative crosses from one log to the next.

    Args:
      log_path: one log path, or a sequence of them.
      trajectory: the excitation YAML the log followed: the log must cover at
        least one of its periods. One log only.
      coulomb_width: rad/s; the Coulomb term is fc tanh(qd / width) (0: sign).
      noise: declared torque noise (standard deviation), N m, one value or one
        per joint (None: estimated from the raw logs), for the sanity checks.
      force: write the result even when its sanity checks
        (:mod:`rmdrake.dynamics.sanity`) fail: the reasons are then printed as
        warnings and recorded as the ``warnings`` list of the YAML's
        ``calibration`` record.
      prior, mass_bounds, total_mass: of :func:`~rmdrake.dynamics.identify`
        (prior: a robot; default ``robot``'s own dynamics; the bounds default
        to ``robot``'s ``mass_bounds`` entry).
      gains: drive gains (N m/A, N/A on a prismatic joint) for logs of motor
        currents ``i1..in`` (torque = gain x current); default the robot's
        ``drive: {gain}``. Given, they are written as the result's drive gains.
      preparation: options of :func:`~rmdrake.dynamics.data.prepare_samples`
        (rate, cutoff, decimate, derivative_cutoff, time_window, idle_speed,
        ...), the same for every log.

    Raises:
      ValueError: one line: unreadable log, joint counts that differ between
        the logs or from the robot (or the prior), a trajectory with several
        logs, a time window outside a log or leaving too few equations,
        infeasible mass bounds (the solver's status and the links).
      ImplausibleResultError: the sanity checks failed and not ``force``
        (nothing written; ``result`` the identified RobotModel).
    """
    model = _model(robot)
    paths = [log_path] if isinstance(log_path, str | os.PathLike) else list(log_path)
    if trajectory is not None and len(paths) > 1:
        raise ValueError(
            f"trajectory: applies to a single log, {len(paths)} logs given "
            "(leave it out to identify from several)"
        )
    if gains is not None:  # one value: every joint's
        gains = np.broadcast_to(np.asarray(gains, float), (model.n_joints,))
        model = dataclasses.replace(model, drive_gain=gains)
    logs, parts = prepare_logs(
        paths, model.n_joints, gains=model.drive_gain, **preparation
    )
    if trajectory is not None:
        load_fourier(trajectory).check_covers(logs[0].t, f"log {paths[0]}")
    samples = stack_samples(parts)
    if model.mass_bounds is not None:  # the robot YAML's, where none is given
        mass_bounds = model.mass_bounds.links if mass_bounds is None else mass_bounds
        total_mass = model.mass_bounds.total if total_mass is None else total_mass
    try:
        result = identify(
            model,
            samples,
            method=method,
            seed=seed,
            progress=True,
            coulomb_width=coulomb_width,
            prior=None if prior is None else _model(prior),
            mass_bounds=mass_bounds,
            total_mass=total_mass,
        )
    except ValueError as e:
        if preparation.get("time_window") is None:
            raise
        raise ValueError(f"after trim: {e}") from None
    preparation_notes = list(samples.notes) + [
        f"warning: {w}" for w in samples.warnings
    ]
    notes = {
        "logs": [str(p) for p in paths],
        "samples": samples.n_samples,
        "rate_Hz": samples.rate,
        "preparation": preparation_notes,
        "coulomb_width": coulomb_width,
    }
    raw_tau = np.concatenate([log.tau for log in logs])
    sanity = check_identification(result, noise=noise, raw_torque=raw_tau)
    identified = identified_model(model, result, notes=notes)
    echo(
        f"robot '{model.name}': {samples.n_samples} samples at {samples.rate:g} Hz "
        f"from {len(paths)} log(s); {result.base.count} base parameters "
        f"identified by {method} (terms: {result.terms})"
    )
    if len(parts) > 1:
        for p, part in zip(paths, parts, strict=True):
            echo(f"  log {p}: {part.n_samples} samples")
    for note in preparation_notes:
        echo(f"  {note}")
    rms = ", ".join(f"{v:.4g}" for v in result.residual_rms)
    echo(f"residual RMS per joint [N m]: {rms}")
    list(map(echo, fit_summary(result)))
    echo(sanity.summary())
    record = dict(identified.calibration)
    return _write_checked(
        identified, record, list(sanity.reasons), out, force=force, echo=echo
    )
