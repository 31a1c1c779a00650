"""Several joint logs to one set of identification samples.

Each log is read (:func:`rmdrake.dynamics.joint_log.read_joint_log`) and prepared on
its own
(:func:`rmdrake.dynamics.data.prepare_samples`: time window, resampling,
filtering, derivatives, standstill removal), then the samples are stacked
(:func:`rmdrake.dynamics.data.stack_samples`): the time stamps of two logs
never meet, so no filter or derivative runs across a boundary. A log of motor
currents (``i1..in``) becomes torques with the drive gains, and a motor-side
log (``qm1..``) is mapped to the joints by the robot's transmission (see
:mod:`rmdrake.dynamics.joint_log`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.joint_log import JointLog, check_magnitudes, read_joint_log
from rmdrake.model.robot import JointLimits
from rmdrake.model.transmission import Transmission

__all__ = ["prepare_logs"]


def prepare_logs(
    paths: Sequence[str | os.PathLike],
    n_joints: int,
    *,
    gains: object = None,
    transmission: Transmission | None = None,
    currents_only: bool = False,
    limits: JointLimits | None = None,
    sigma: object = None,
    **preparation: Any,
) -> tuple[list[JointLog], list[JointSamples]]:
    """Reads and prepares each log of ``paths``.

    Args:
      paths: one or more joint-log paths (CSV or NPZ).
      n_joints: the robot's joint count.
      gains: (n,) drive gains, N m/A or N/A, for logs of motor currents
        (tau = gains x i; e.g. ``model.drive_gain``); ignored for torque logs.
      transmission: the robot's (``model.transmission``), for motor-side logs
        (``qm1..``); None refuses them.
      currents_only: refuse a torque log (one without ``i1..in``).
      limits: the robot's joint limits: a value no measurement of it can be
        is refused as read (:func:`~rmdrake.dynamics.joint_log.
        check_magnitudes`, naming the row and column); ``sigma`` (n,) its
        joint types, for the units named.
      preparation: options of :func:`~rmdrake.dynamics.data.prepare_samples`,
        the same for every log.

    Returns:
      The logs as read and the prepared samples of each, in ``paths`` order.

    Raises:
      ValueError: one line naming the file: unreadable, joint counts that
        differ between logs (both files named) or from the robot, or a refusal
        of the preparation (time window outside the log, too short, ...), a
        currents log without gains, an absurd value (with ``limits``).
    """
    if not paths:
        raise ValueError("log: expected at least one joint log")
    logs = [read_joint_log(p, gains=gains, transmission=transmission) for p in paths]
    for p, log in zip(paths, logs, strict=True):
        if currents_only and log.current is None:
            raise ValueError(f"{p}: a torque log (tau); expected motor currents i1..in")
    for p, log in zip(paths[1:], logs[1:], strict=True):
        if log.n_joints != logs[0].n_joints:
            raise ValueError(
                f"logs {paths[0]} ({logs[0].n_joints} joints) and {p} "
                f"({log.n_joints} joints): different joint counts"
            )
    if logs[0].n_joints != n_joints:
        raise ValueError(
            f"{paths[0]}: log has {logs[0].n_joints} joints, expected {n_joints} "
            "(the robot's)"
        )
    parts = []
    for p, log in zip(paths, logs, strict=True):
        try:
            if limits is not None:
                check_magnitudes(
                    log,
                    limits.lower,
                    limits.upper,
                    velocity=limits.velocity,
                    acceleration=limits.acceleration,
                    effort=limits.effort,
                    sigma=sigma,
                )
            parts.append(
                prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd, **preparation)
            )
        except ValueError as e:
            raise ValueError(f"{p}: {e}") from None
    return logs, parts
