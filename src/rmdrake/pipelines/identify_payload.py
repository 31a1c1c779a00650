"""``rmdrake identify-payload``: an identified robot and a log of it carrying
a payload (and optionally a log of the same trajectory without it) in, the
robot YAML with its identified ``payload: {mass, com, inertia}`` out. The logs
are prepared as ``identify`` prepares them
(:func:`~rmdrake.dynamics.log_samples.prepare_logs`); the method is
:mod:`rmdrake.dynamics.payload`."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rmdrake.dynamics.data import JointSamples, stack_samples
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.payload import (
    check_payload,
    identify_payload,
    payload_warnings,
)
from rmdrake.dynamics.sanity import check_torque_log
from rmdrake.errors import ImplausibleResultError
from rmdrake.model.loading import Robot, as_robot_model
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.checked import Echo, write_checked

__all__ = ["identify_payload_file"]

Paths = str | os.PathLike | Sequence[str | os.PathLike]


def _as_paths(paths: Paths) -> list[str | os.PathLike]:
    return [paths] if isinstance(paths, str | os.PathLike) else list(paths)


def _samples(
    model: RobotModel, paths: list[str | os.PathLike], preparation: dict[str, Any]
) -> JointSamples:
    """The logs prepared one by one and stacked (torques, or currents times
    the robot's drive gains)."""
    parts = prepare_logs(
        paths,
        model.n_joints,
        gains=model.drive_gain,
        transmission=model.transmission,
        limits=model.limits,
        sigma=model.sigma,
        **preparation,
    )
    return stack_samples(parts[1])


def identify_payload_file(
    robot: Robot,
    log_path: Paths,
    out: str | os.PathLike,
    *,
    unloaded: Paths | None = None,
    coulomb_width: float = 0.0,
    force: bool = False,
    echo: Echo = print,
    **preparation: Any,
) -> Path:
    """Identifies the payload ``robot`` carries in ``log_path``; writes the
    robot YAML with that ``payload`` entry (the rest of the robot unchanged,
    the fit recorded under ``calibration: {payload: ...}``).

    Args:
      robot: the identified arm (with ``dynamics``), without or with a payload
        entry (replaced).
      log_path: one or several logs of the arm carrying the payload.
      unloaded: a log of the same trajectory without it (paired sample by
        sample with the loaded log; one loaded log then).
      coulomb_width: rad/s; the arm's Coulomb term fc tanh(qd / width) (0:
        sign).
      force: write even when :func:`~rmdrake.dynamics.payload.check_payload`
        refuses (the reasons recorded as warnings).
      preparation: options of :func:`~rmdrake.dynamics.data.prepare_samples`,
        the same for every log.

    Raises:
      ValueError: one line: a robot without dynamics, an unreadable log, joint
        counts not the robot's, logs that are not one trajectory, a payload the
        motion does not identify.
      ImplausibleResultError: a mass <= 0, not told from 0 or absurd, a
        centre of mass left undetermined
        (:func:`~rmdrake.dynamics.payload.check_payload`), or torque logs far
        over the effort limits, and not ``force`` (nothing written). An
        undetermined inertia is a warning (printed and recorded).
    """
    model = as_robot_model(robot)
    if model.dynamics is None:
        raise ValueError(
            f"robot '{model.name}': has no dynamics; identify the arm first "
            "(rmdrake identify), then its payload"
        )
    paths = _as_paths(log_path)
    free = None if unloaded is None else _as_paths(unloaded)
    if free is not None and (len(free) != 1 or len(paths) != 1):
        raise ValueError(
            f"--log-unloaded: {len(free)} unloaded log(s) for {len(paths)} loaded "
            "log(s); give one loaded log and one unloaded log of the same trajectory"
        )
    loaded = _samples(model, paths, preparation)
    log_reasons = check_torque_log(loaded.tau, model.limits.effort)
    if log_reasons and not force:
        raise ImplausibleResultError(log_reasons)
    free_samples = None if free is None else _samples(model, free, preparation)
    result = identify_payload(model, loaded, free_samples, coulomb_width=coulomb_width)
    echo(
        f"robot '{model.name}': payload identified from {len(paths)} loaded log(s)"
        f"{'' if free is None else f' and {len(free)} unloaded'}"
    )
    list(map(echo, result.summary()))
    reasons = [*log_reasons, *check_payload(result, model)]
    warnings = payload_warnings(result)
    for warning in warnings:
        echo(f"warning: {warning}")
    p = result.payload
    record = dict(model.calibration or {})
    record["payload"] = {
        "logs": [str(v) for v in paths],
        "unloaded_logs": [str(v) for v in free or []],
        "samples": result.samples,
        "coulomb_width": coulomb_width,
        "mass_std_kg": result.mass_std,
        "com_std_m": [float(v) for v in result.com_std],
        "condition": result.condition_raw,
        "residual_rms": [float(v) for v in result.residual_rms],
        "least_squares_physical": result.physical_ls,
    }
    if warnings:
        record["payload"]["sanity_warnings"] = warnings
    identified = dataclasses.replace(model, payload=p)
    return write_checked(identified, record, reasons, out, force=force, echo=echo)
