"""Drive gains and dynamic parameters identified together from motor currents.

A drive that logs motor currents i_j (A) and not joint torques gives the
effort tau_j = g_j i_j only up to the drive gain g_j (N m/A, or N/A for a
prismatic joint, gear ratio included). From currents alone the gains cannot be
found: scaling every g_j and the dynamic parameters by the same factor leaves
the equations unchanged. A payload of known mass (and centre of mass and
inertia) fixes that scale: its torques are known from its parameters.

Method (Gautier & Briot 2014, "Global identification of joint drive gains and
dynamic parameters of robots", ASME J. Dyn. Sys. Meas. Control 136(5); used in
practice by Mamedov et al. 2020, "Practical aspects of model-based collision
detection", Frontiers in Robotics and AI 7). With the base regressor Y_b of
:mod:`rmdrake.dynamics.base` (13 standard parameters per link: inertia, rotor
inertia, friction) and the known payload parameters phi_P (10, folded into
link n as :func:`rmdrake.dynamics.standard_parameters` does), a log without
payload gives per sample and joint

    g_j i_j = Y_b,j(q, qd, qdd) beta

and a log with the payload

    g_j i_j = Y_b,j(q, qd, qdd) beta + Y_P,j(q, qd, qdd) phi_P,

Y_P the regressor columns of link n's 10 inertial parameters. Both logs are
stacked into one linear system in the unknowns (beta, g):

    [ Y_b   -D(i) ] [beta; g] = [ 0 ; -Y_P phi_P ]

(D(i) puts i_j in joint j's gain column), solved by least squares with scaled
columns. The right-hand side is the payload's known contribution: the gains and
the base parameters come out in their physical units together. Dividing the
rows of joint j by g_j is the currents form i_j = Y_b,j (beta / g_j) + ... of
the reference: the same solution. The gains are identifiable when the payload
acts on every joint during the loaded log (its mass, and motion or gravity
load on each axis); otherwise the system is rank deficient and refused, the
joints named.

Noise. Currents enter the matrix (errors in variables), so least squares is
slightly biased; with 1 % current noise the error is dominated by variance and
depends on how much the payload loads each joint: on the shipped rv3sb with a
2 kg payload and 400 random states per log, 1.3 % median and 2.6 % worst gain
error over 20 seeds (tests/dynamics/test_drive_gains.py).

Sanity (:func:`check_drive_gains`). A wrong payload mass scales the gains and
the base parameters by the same factor (a 20 kg payload declared for a 2 kg
one: 10x). Two figures refuse it: where the robot has dynamics, the torque
its own base parameters predict on the logs against the identified ones',
RMS(Y_b beta) / RMS(Y_b beta_robot), outside [1/3, 3] (``max_scale``; the
true payload: 1.00, the 20-for-2 payload: 10.0); and the torques g_j i_j of
the logs against the effort limits
(:func:`rmdrake.dynamics.sanity.check_torque_log`: 99th-percentile |torque|
over 3x a limit).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.regressor import regressor
from rmdrake.dynamics.sanity import check_torque_log
from rmdrake.model.dynamic_parameters import (
    N_PER_LINK,
    payload_parameters,
    standard_parameters,
)
from rmdrake.model.robot import Payload, RobotModel

__all__ = [
    "DriveGainIdentification",
    "check_drive_gains",
    "identify_drive_gains",
    "identify_drive_gains_from_logs",
    "prepare_current_logs",
]

_RANK_RTOL = 1e-9  # relative singular value below which a direction is unseen


@dataclasses.dataclass(frozen=True)
class DriveGainIdentification:
    """Drive gains and base parameters identified from currents.

    Attributes:
      gains: (n,) drive gains, N m/A (N/A on a prismatic joint).
      beta: (nb,) base parameters (of ``base``), in their physical units.
      base: the base parameters' definition.
      residual_rms: (n,) RMS of g_j i_j - prediction per joint over both logs,
        N m or N.
      condition: condition number of the column-scaled stacked system.
      dynamics_ratio: RMS(Y_b beta) / RMS(Y_b beta_robot) over the logs, the
        identified base parameters' torques over the robot's own dynamics'
        (None: the robot has no dynamics).
      torque: (N, n) the logs' torques g_j i_j, N m or N (samples stacked).
    """

    gains: np.ndarray
    beta: np.ndarray
    base: BaseParameters
    residual_rms: np.ndarray
    condition: float
    dynamics_ratio: float | None = None
    torque: np.ndarray | None = dataclasses.field(default=None, repr=False)


def _equations(
    model: RobotModel,
    base: BaseParameters,
    samples: JointSamples,
    phi: np.ndarray | None,
    coulomb_width: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Rows [Y_b, -D(i)] and right-hand side -Y_P phi (0 without payload)."""
    q, qd, qdd, i = samples.q, samples.qd, samples.qdd, samples.tau
    N, n = i.shape
    Yb = base.regressor(model, q, qd, qdd, coulomb_width=coulomb_width)
    D = np.zeros((N, n, n))
    D[:, np.arange(n), np.arange(n)] = -i
    A = np.concatenate([Yb, D], axis=2).reshape(N * n, -1)
    if phi is None:
        return A, np.zeros(N * n)
    cols = N_PER_LINK * (n - 1) + np.arange(10)
    tau_P = regressor(model, q, qd, qdd, cols, coulomb_width=coulomb_width) @ phi
    return A, -tau_P.ravel()


def identify_drive_gains(
    model: RobotModel,
    unloaded: JointSamples | Sequence[JointSamples],
    loaded: JointSamples | Sequence[JointSamples],
    payload: Payload,
    *,
    coulomb_width: float = 0.0,
) -> DriveGainIdentification:
    """Drive gains and base parameters from logs of motor currents without and
    with a known payload (see the module docstring).

    Args:
      model: the robot (kinematics; its dynamics are not used; its own
        ``payload`` is ignored: the unloaded logs are taken without one).
      unloaded, loaded: prepared samples (or several) whose ``tau`` holds the
        motor currents in A (:func:`prepare_current_logs`).
      payload: the known payload of the loaded logs, on the tool frame.
      coulomb_width: rad/s (m/s); 0 for the Coulomb column sign(qd).

    Raises:
      ValueError: one line: a payload without mass, joint counts not the
        robot's, too few equations, or gains that the data do not determine
        (the joints named).
    """
    if not payload.mass > 0:
        raise ValueError(
            f"payload.mass: expected a known mass > 0 kg, found {payload.mass}"
        )
    as_list = lambda s: [s] if isinstance(s, JointSamples) else list(s)  # noqa: E731
    parts = [(s, None) for s in as_list(unloaded)]
    if not parts or not as_list(loaded):
        raise ValueError("logs: expected at least one unloaded and one loaded log")
    n = model.n_joints
    phi = payload_parameters(model, payload)
    parts += [(s, phi) for s in as_list(loaded)]
    for s, _ in parts:
        if s.n_joints != n:
            raise ValueError(
                f"samples: {s.n_joints} joints, expected {n} (the robot's)"
            )
    base = base_parameters(dataclasses.replace(model, payload=None))
    rows = [_equations(model, base, s, p, coulomb_width) for s, p in parts]
    A = np.concatenate([r[0] for r in rows])
    b = np.concatenate([r[1] for r in rows])
    if A.shape[0] < A.shape[1]:
        raise ValueError(
            f"samples: {A.shape[0]} equations for {A.shape[1]} unknowns; log more"
        )
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    U, s, Vt = np.linalg.svd(A / scale, full_matrices=False)
    unseen = s < _RANK_RTOL * s[0]
    if np.any(unseen):
        weight = np.abs(Vt[unseen, base.count :]).max(axis=0)
        joints = np.flatnonzero(weight > 1e-3) + 1
        raise ValueError(
            "gains: not determined by the logs (the payload must load every joint "
            f"in motion); joints {', '.join(map(str, joints)) or '(none: the base)'}"
        )
    x = (Vt.T @ ((U.T @ b) / s)) / scale
    beta, gains = x[: base.count], x[base.count :]
    if np.any(gains <= 0):
        bad = ", ".join(str(j + 1) for j in np.flatnonzero(gains <= 0))
        raise ValueError(
            f"gains: identified non-positive drive gain(s) on joint(s) {bad}: "
            "check the current signs and the payload"
        )
    residual = (A @ x - b).reshape(-1, n)
    ratio = None
    if model.dynamics is not None:
        own = base.regroup(
            standard_parameters(dataclasses.replace(model, payload=None))
        )
        Yb = A[:, : base.count]
        ratio = float(np.linalg.norm(Yb @ beta) / max(np.linalg.norm(Yb @ own), 1e-300))
    currents = np.concatenate([p.tau for p, _ in parts])
    return DriveGainIdentification(
        gains=gains,
        beta=beta,
        base=base,
        residual_rms=np.sqrt(np.mean(residual**2, axis=0)),
        condition=float(s[0] / s[-1]),
        dynamics_ratio=ratio,
        torque=currents * gains,
    )


def check_drive_gains(
    result: DriveGainIdentification, model: RobotModel, max_scale: float = 3.0
) -> list[str]:
    """Reasons (one line each; empty: plausible) why identified gains are
    absurd (module docstring, Sanity): the identified dynamics over
    ``max_scale`` times the robot's own or under its inverse, or the logs'
    torques far over the effort limits."""
    reasons = []
    k = result.dynamics_ratio
    if k is not None and not 1.0 / max_scale <= k <= max_scale:
        reasons.append(
            f"gains: the identified dynamics predict {k:.3g}x the torque of robot "
            f"'{model.name}''s own (outside 1/{max_scale:g}..{max_scale:g}x): the "
            "payload is not what was declared or the robot's dynamics are wrong; "
            "check --payload-mass"
        )
    if result.torque is not None:
        reasons += [
            f"gains: {r}" for r in check_torque_log(result.torque, model.limits.effort)
        ]
    return reasons


def prepare_current_logs(
    paths: Sequence[str | os.PathLike], n_joints: int, **preparation: Any
) -> list[JointSamples]:
    """Reads and prepares logs of motor currents (``i1..in``) as
    :func:`~rmdrake.dynamics.log_samples.prepare_logs` does; the samples'
    ``tau`` holds the currents in A.

    Raises:
      ValueError: one line naming the file: a torque log (no currents), or
        any refusal of ``prepare_logs``.
    """
    ones = np.ones(n_joints)
    return prepare_logs(paths, n_joints, gains=ones, currents_only=True, **preparation)[
        1
    ]


def identify_drive_gains_from_logs(
    model: RobotModel,
    unloaded: Sequence[str | os.PathLike],
    loaded: Sequence[str | os.PathLike],
    payload: Payload,
    *,
    coulomb_width: float = 0.0,
    **preparation: Any,
) -> DriveGainIdentification:
    """:func:`identify_drive_gains` from log files of motor currents, each
    prepared alone (``preparation``: options of
    :func:`~rmdrake.dynamics.data.prepare_samples`, the same for every log).

    Raises:
      ValueError: one line naming the file (see :func:`prepare_current_logs`),
        or a refusal of :func:`identify_drive_gains`.
    """
    n = model.n_joints
    free = prepare_current_logs(unloaded, n, **preparation) if unloaded else []
    held = prepare_current_logs(loaded, n, **preparation) if loaded else []
    return identify_drive_gains(model, free, held, payload, coulomb_width=coulomb_width)
