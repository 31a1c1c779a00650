"""``rmdrake identify``: joint logs in, an identified robot YAML out. The
samples are prepared and stacked, the base parameters fitted by the chosen
estimator, the fit checked (:mod:`rmdrake.dynamics.sanity`: an implausible one
raises :class:`~rmdrake.errors.ImplausibleResultError` and writes nothing unless
forced) and the identified robot written atomically."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.dynamics.data import stack_samples
from rmdrake.dynamics.identification import fit_summary, identified_model, identify
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.sanity import (
    check_identification,
    check_log,
    check_masses,
    check_prior,
)
from rmdrake.errors import ImplausibleResultError
from rmdrake.excitation.trajectory import load_fourier
from rmdrake.excitation.trajectory_check import check_follows
from rmdrake.model.loading import Robot, as_robot_model
from rmdrake.model.robot import RobotModel, require_dynamics
from rmdrake.pipelines.checked import Echo, write_checked

__all__ = ["identify_file"]


def identify_file(
    robot: Robot,
    log_path: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    trajectory: str | os.PathLike | None = None,
    method: str = "physical",
    seed: int = 0,
    coulomb_width: float = 0.0,
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
      trajectory: the excitation YAML the log followed: the log must have
        its joint count, cover at least one of its periods and follow its q
        (:func:`~rmdrake.excitation.trajectory_check.check_follows`: per joint
        within 10 % of the motion after the time base is aligned). One log
        only.
      coulomb_width: rad/s; the Coulomb term is fc tanh(qd / width) (0: sign).
      force: write the result even when its sanity checks
        (:mod:`rmdrake.dynamics.sanity`: the torque log's scale, the residual,
        the link masses) fail: the reasons are then printed as warnings and
        recorded as the ``warnings`` list of the YAML's ``calibration``
        record. Warnings that do not refuse (unexplained shares) are printed
        and recorded as ``sanity_warnings``.
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
      ValueError: one line: a robot without joint effort limits (a
        kinematic-only model) when the prior has none either (the torque log's
        unit check needs them; refused by name before the logs are read,
        :func:`~rmdrake.model.robot.require_dynamics`; a robot without
        dynamics is fitted from the logs alone); unreadable log, joint counts
        that differ between
        the logs or from the robot (or the prior), a trajectory with several
        logs or that the log does not follow, a time window outside a log or
        leaving too few equations,
        infeasible mass bounds (the solver's status and the links), a prior
        that is not physical or not this robot
        (:func:`~rmdrake.dynamics.sanity.check_prior`).
      ImplausibleResultError: the sanity checks failed and not ``force``
        (nothing written; ``result`` the identified RobotModel, or None when
        the torque log was refused before the fit).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import JointLog, load_robot, random_fourier_trajectory
    >>> from rmdrake import standard_parameters, write_joint_log
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> tmp = tempfile.TemporaryDirectory()
    >>> log = write_joint_log(Path(tmp.name, "log.csv"), JointLog(t, q, tau, qd, qdd))
    >>> from rmdrake.pipelines import identify_file
    >>> lines = []
    >>> yaml = Path(tmp.name, "identified.yaml")
    >>> out = identify_file("rv3sb", log, yaml, method="ols", echo=lines.append)
    >>> load_robot(out).calibration["method"], len(lines) > 0
    ('identify/ols', True)
    >>> tmp.cleanup()
    """
    model = as_robot_model(robot)
    prior_model = None if prior is None else as_robot_model(prior)
    effort = _effort_limits(model, prior_model)
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
        paths,
        model.n_joints,
        gains=model.drive_gain,
        transmission=model.transmission,
        limits=model.limits,
        sigma=model.sigma,
        **preparation,
    )
    torques = [str(p) for p, g in zip(paths, logs, strict=True) if g.current is None]
    if gains is not None and torques:
        raise ValueError(
            f"--gains given, but {', '.join(torques)} holds joint torques "
            "(tau), not motor currents (i): the gains would be ignored and "
            "written as the drive's; leave --gains out"
        )
    if trajectory is not None:  # the motion itself, not only its length
        excitation = load_fourier(trajectory)
        what, source = f"log {paths[0]}", f"--trajectory {trajectory}"
        check_follows(
            excitation,
            parts[0].t,
            parts[0].q,
            sigma=model.sigma,
            what=what,
            source=source,
        )
        excitation.check_covers(logs[0].t, what)
    samples = stack_samples(parts)
    check_prior(model, model if prior_model is None else prior_model)
    log_reasons = check_log(
        samples, model, effort, model if prior_model is None else prior_model
    )
    headline = f"identification of robot '{model.name}' not written: the log "
    if log_reasons and not force:
        raise ImplausibleResultError(log_reasons, headline=headline + "is not its")
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
            prior=prior_model,
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
    sanity = check_identification(result, model=model, samples=samples)
    n = model.n_joints
    masses = result.chi[9 : 13 * n : 13]
    prior_masses = None if result.prior is None else result.prior[9 : 13 * n : 13]
    warnings = [*sanity.warnings, *check_masses(masses, prior_masses)]
    reasons = [*log_reasons, *sanity.reasons]
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
    for warning in warnings:
        echo(f"warning: {warning}")
    record = dict(identified.calibration)
    if warnings:
        record["sanity_warnings"] = [" ".join(w.split()) for w in warnings]
    return write_checked(
        identified,
        record,
        reasons,
        out,
        force=force,
        echo=echo,
        headline=headline + "contradicts it",
    )


def _effort_limits(model: RobotModel, prior: RobotModel | None) -> np.ndarray:
    """The effort limits (n,), N m or N, the torque log is checked against:
    the robot's, else the prior's (the same robot, checked later), else a
    refusal by name (one line)."""
    source = model
    if not model.has_effort_limits and prior is not None:
        if prior.has_effort_limits and prior.n_joints == model.n_joints:
            source = prior
    require_dynamics(
        source,
        "rmdrake identify",
        dynamics=False,
        remedy="they scale the torque log's unit check; give them, or a --prior "
        "that has them",
    )
    return source.limits.effort
