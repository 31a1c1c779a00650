"""Elastostatic calibration: joint compliances among the unknowns of the plane
calibration.

An elastic joint j turns its link side to q_l = q_m + c_j tau_j(q_l)
(:mod:`rmdrake.dynamics.compliance`; q_m the encoder's motor angle, c_j = 1 / k_j in
rad/(N m), m/N on a slide, tau_j the generalized gravity force on the joint,
Drake's sign, from the links' masses and the payload of each reading). The MDH
chain sees only q_l, so a residual's derivative with respect to c_j is its
derivative with respect to joint j's offset (``dtheta<j>``, ``dr<j>``) times
tau_j of that reading: :class:`ElasticJoints` gives the least-squares problems
(:class:`~rmdrake.calibration.plates.cost.PlaneProblem` for plates,
:class:`~rmdrake.calibration.points.problem.PointProblem` for tracker points)
the link angles and these columns, with tau held fixed.

tau depends weakly on q_l (about 0.5 % of the deflection on ``demo_rh``) and on
the geometry, so the fit runs in short outer passes (:class:`JointLoads`):

1. tau at the link angles of the starting estimate (the nominal geometry plus
   the starting deltas, the starting compliances: the nominal's, 0 on a rigid
   nominal);
2. least-squares fit of deltas, compliances and plates with tau fixed;
3. tau again at the link angles of the fitted estimate (its geometry and
   compliances, the nominal's masses and payload centre of mass); refit from
   the previous solution. Stop when the link angles moved by less than
   :data:`PASS_TOLERANCE` rad between two passes, after at most
   :data:`MAX_PASSES` passes.

Each pass shrinks the error of the compliances about tenfold on ``demo_rh``
(tau follows the link angles and the fitted geometry): 0.3 % after the first
pass, under 1e-5 after the fourth, round-off after six. 1e-9 rad is 8 nm at
8 m, far below any range finder's noise. A rigid nominal without compliances
asked for has no loads: one pass on the motor angles, the rigid calibration
unchanged.

Identifiability: a joint whose torque is zero at every reading (joint 1 about
a vertical axis) has a zero column; one whose torque does not vary over the
readings (all taken with one payload, little arm weight on the joint) has the
column of its offset and cannot be separated from it. Compliances come after
every MDH entry in the preference order (:mod:`.identifiability`): the offset
is kept, the compliance dropped, and :func:`compliance_warning` says which in
one line, with what would make them visible.
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Protocol

import numpy as np

from rmdrake.dynamics.compliance import GravityModel, joint_compliances, payload_masses
from rmdrake.kinematics.forward import point_jacobian
from rmdrake.model.error_parameters import (
    apply_deltas,
    compliance_parameter_names,
    is_compliance_name,
    split_error_parameters,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "MAX_PASSES",
    "PASS_TOLERANCE",
    "ComplianceWarning",
    "ElasticJoints",
    "JointLoads",
    "LoadedReadings",
    "check_identified",
    "compliance_warning",
    "elastic_record",
    "require_payloads",
    "with_compliances",
]

MAX_PASSES = 8
"""Most outer passes (tau recomputed between them) of an elastic fit."""

PASS_TOLERANCE = 1e-9
"""rad (m on a slide): the link angles' largest change between two passes below
which the outer passes stop."""

_ZERO_TORQUE = 1e-9
"""A joint's torques below this fraction of the largest torque of any joint
are round-off (a vertical axis): set to 0."""

_FIXED_POINT_TOLERANCE = 1e-13
_FIXED_POINT_ITERATIONS = 60


class LoadedReadings(Protocol):
    """What the compliances need of any kind's measurements: the joint
    positions ``q`` (N, n), rad (m on a slide), and ``payload_masses`` (N,)
    in kg at the tool (0 without a payload column)."""

    @property
    def q(self) -> np.ndarray: ...

    @property
    def payload_masses(self) -> np.ndarray: ...


class ComplianceWarning(UserWarning):
    """Compliances asked for that the readings cannot identify (dropped)."""


class ElasticJoints:
    """The elastic joints of a least-squares problem, with tau held fixed.

    With ``torques`` tau (N, n) the chain turns the link angles
    ``q_l = q + c * tau`` (q the readings' motor angles), with c the fixed
    ``compliance`` (n,) except on ``compliance_joints``, whose compliances are
    unknowns right after the ``k_geometric`` MDH deltas of the problem's x. The
    column of an unknown c_j is that of joint j's offset (``dtheta<j>``,
    ``dr<j>`` on a slide: computed whether or not the offset is an unknown)
    times tau_j of each reading.

    Args:
      q: (N, n) motor angles, rad or m.
      k_geometric: number of MDH deltas before the compliances in x.
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.
      torques: (N, n) generalized gravity force per joint and reading, N m or N
        (Drake's sign); None: rigid joints (q_l = q).
      compliance: (n,) fixed compliances, rad/(N m) or m/N; default 0.
      compliance_joints: (k_c,) 0-based joints whose compliance is unknown.

    Raises:
      ValueError: unknown compliances without torques.
    """

    def __init__(
        self,
        q: np.ndarray,
        k_geometric: int,
        *,
        sigma: np.ndarray | None = None,
        torques: np.ndarray | None = None,
        compliance: np.ndarray | None = None,
        compliance_joints: np.ndarray | None = None,
    ) -> None:
        self.q = np.asarray(q)
        n = self.q.shape[1]
        self.torques = None if torques is None else np.asarray(torques, float)
        self.compliance = (
            np.zeros(n) if compliance is None else np.array(compliance, float)
        )
        joints = [] if compliance_joints is None else compliance_joints
        self.joints = np.asarray(joints, dtype=np.intp)
        if self.joints.size and self.torques is None:
            raise ValueError("compliance_joints: unknown compliances need torques")
        slide = np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1
        # The flat table index of joint j's offset: theta_j, or r_j on a slide.
        self.offset_indices = 5 * self.joints + np.where(slide[self.joints], 3, 2)
        self.k_geometric = int(k_geometric)
        self.k = self.k_geometric + self.joints.size

    def link_angles(self, x: np.ndarray) -> np.ndarray:
        """(N, n) joint positions the chain turns at x: q + c * tau (q without
        torques), rad or m."""
        if self.torques is None:
            return self.q
        c = self.compliance.copy()
        c[self.joints] = x[self.k_geometric : self.k]
        return self.q + c * self.torques

    def point_jacobian(
        self,
        table: np.ndarray,
        q_l: np.ndarray,
        indices: np.ndarray,
        rows: slice = slice(None),
        **options,
    ) -> np.ndarray:
        """(N, 3, k) d p_BM / d (deltas at flat table ``indices``, unknown
        compliances) at link angles ``q_l``: m/rad or m/m, then m/(rad/(N m))
        (:func:`rmdrake.kinematics.forward.point_jacobian` with ``options``).
        ``rows``: the readings ``q_l`` holds (a slice of the problem's, for a
        caller working chunk by chunk; their torques are used)."""
        columns = np.concatenate([indices, self.offset_indices])
        J = point_jacobian(table, q_l, columns, **options)
        if self.joints.size:  # d q_l / d c_j = tau_j
            J[:, :, self.k_geometric :] *= self.torques[rows, None, self.joints]
        return J


class JointLoads:
    """The joint torques of an elastic calibration's readings.

    Args:
      model: the nominal robot (its ``dynamics`` and ``payload.com`` give tau).
      data: the plate readings or tracker points (their motor angles q and
        ``payload`` per reading, 0 kg without the column).
      names: the error parameters; the ``c<j>`` among them are unknowns, the
        other joints keep the nominal's compliance.

    Attributes:
      active: whether any joint is elastic (unknown or nominal compliance); if
        not, :meth:`torques` is None and the calibration is the rigid one.
      joints: (k_c,) 0-based joints of the unknown compliances, in name order.
      compliance: (n,) the nominal's compliances (rad/(N m) or m/N).
      payload: (N,) kg per reading.

    Raises:
      ValueError: compliances on a robot without dynamics, a payload on a
        robot without a ``payload`` entry.
    """

    def __init__(
        self,
        model: RobotModel,
        data: LoadedReadings,
        names: list[str],
    ) -> None:
        self.model = model
        self.names = list(names)
        self.geometric, self.joints = split_error_parameters(model, names)
        self.is_compliance = np.array([is_compliance_name(n) for n in names], bool)
        self.compliance = joint_compliances(model)
        self.active = bool(self.joints.size or np.any(self.compliance))
        self.q = np.asarray(data.q)
        if self.active and model.dynamics is None:
            asked = [n for n in names if is_compliance_name(n)]
            what = ", ".join(asked) if asked else "its compliance"
            raise ValueError(
                f"robot '{model.name}' has no dynamics: {what} need(s) its gravity "
                "model (the links' masses, 'dynamics:') for the joint torques"
            )
        self.payload = payload_masses(model, data.payload_masses, self.q.shape[0])

    def start(self) -> np.ndarray:
        """(k_c,) starting compliances: the nominal's (0 on a rigid joint)."""
        return self.compliance[self.joints].copy()

    def nominal(self) -> np.ndarray:
        """(k,) the nominal's values of ``names``: zero deltas, then
        :meth:`start`."""
        return np.concatenate([np.zeros(len(self.geometric)), self.start()])

    def _state(self, params: np.ndarray) -> tuple[RobotModel, np.ndarray]:
        params = np.asarray(params, dtype=np.float64)
        model = apply_deltas(
            dataclasses.replace(self.model, compliance=None),
            self.geometric,
            params[~self.is_compliance],
        )
        c = self.compliance.copy()
        c[self.joints] = params[self.is_compliance]
        return model, c

    def torques(self, params: np.ndarray) -> np.ndarray | None:
        """(N, n) tau at the link angles of the estimate ``params`` (values of
        ``names``): the fixed point q_l = q + c tau(q_l) of the nominal plus the
        geometric deltas, N m or N; None when no joint is elastic."""
        if not self.active:
            return None
        model, c = self._state(params)
        gravity = GravityModel(model)
        q = self.q.copy()
        for _ in range(_FIXED_POINT_ITERATIONS):
            tau = gravity(q, self.payload)
            step = self.q + c * tau - q
            q = q + step
            if np.max(np.abs(step)) <= _FIXED_POINT_TOLERANCE:
                break
        tau = gravity(q, self.payload)
        small = np.max(np.abs(tau), axis=0) <= _ZERO_TORQUE * np.max(np.abs(tau))
        tau[:, small] = 0.0
        return tau

    def problem_options(self, torques: np.ndarray | None) -> dict[str, object]:
        """The elastic keyword arguments of
        :class:`~rmdrake.calibration.plates.cost.PlaneProblem` and
        :class:`~rmdrake.calibration.points.problem.PointProblem` for
        ``torques``."""
        if torques is None:
            return {}
        return {
            "torques": torques,
            "compliance": self.compliance,
            "compliance_joints": self.joints,
        }

    def link_angles(self, params: np.ndarray, torques: np.ndarray | None) -> np.ndarray:
        """(N, n) q + c tau of ``params`` with ``torques`` held, rad or m."""
        if torques is None:
            return self.q
        _, c = self._state(params)
        return self.q + c * torques

    def passes(
        self, fit, params0: np.ndarray, max_passes: int = MAX_PASSES
    ) -> tuple[object, np.ndarray, int]:
        """Runs the outer passes of the module docstring.

        Args:
          fit: ``fit(torques, params) -> (result, params)``: one least-squares
            fit with tau held, started from ``params``.
          params0: (k,) starting values of ``names``.
          max_passes: most passes (1: tau at the start's link angles only, the
            compliances within about 0.3 % on ``demo_rh``).

        Returns:
          (the last fit's result, its params (k,), the number of passes).
        """
        params = np.asarray(params0, dtype=np.float64)
        torques = self.torques(params)
        result, params = fit(torques, params)
        count = 1
        while torques is not None and count < max_passes:
            new = self.torques(params)
            q_new = self.link_angles(params, new)
            moved = np.max(np.abs(q_new - self.link_angles(params, torques)))
            torques = new
            if moved < PASS_TOLERANCE:
                break
            result, params = fit(torques, params)
            count += 1
        self.final_torques = torques
        return result, params, count


def require_payloads(payload: np.ndarray, option: str = "--compliance") -> None:
    """Refuses an elastostatic calibration of readings all taken at one
    payload (``payload`` (N,) kg per reading): the compliances would then be
    fitted from the arm's own weight alone, and the joints it barely loads
    (a wrist) get a stiffness the readings never saw (k4 = 1462 N m/rad from
    readings at 0 kg). The library's fit keeps its rank-decides behaviour
    (:func:`check_identified`); this is the door of ``rmdrake calibrate``.

    Raises:
      ValueError: one line naming ``option`` and the one payload.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration.elastostatic import require_payloads
    >>> require_payloads(np.array([0.0, 0.0, 2.0]))  # two payloads: fine
    >>> try:
    ...     require_payloads(np.zeros(3))
    ... except ValueError as e:
    ...     print(str(e)[:68])
    --compliance needs readings at two or more payloads; these were all
    """
    masses = np.unique(np.asarray(payload, dtype=np.float64))
    if masses.size < 2:
        at = f"{masses[0]:g} kg" if masses.size else "no readings"
        raise ValueError(
            f"{option} needs readings at two or more payloads; these were all at "
            f"{at}: the compliances would rest on the arm's own weight alone; add "
            "readings under a payload (a payload column, e.g. simulate-plates "
            "--payload 0,M)"
        )


def with_compliances(
    model: RobotModel, names: list[str], compliance: bool
) -> list[str]:
    """``names`` (MDH names and ``c<j>``) plus, if ``compliance``, every joint's
    ``c<j>``: the MDH names first, then the compliances in joint order.

    Raises:
      ValueError: an unknown or duplicated name."""
    if compliance:
        names = names + [n for n in compliance_parameter_names(model) if n not in names]
    geometric, joints = split_error_parameters(model, names)
    return geometric + [f"c{j + 1}" for j in joints]


def check_identified(
    model: RobotModel,
    data: LoadedReadings,
    report: object,
    names: list[str],
    *,
    strict: bool,
    stacklevel: int = 2,
    what: str = "readings",
) -> None:
    """After the identifiability ``report`` of ``names`` on ``data``: if
    ``strict``, a ValueError naming the MDH parameters it dropped; a
    :class:`ComplianceWarning` (:func:`compliance_warning`, the torques at the
    nominal) naming the compliances it dropped. ``stacklevel`` as
    :func:`warnings.warn`'s, counted from the caller; ``what`` names the
    data in the error (``readings``, ``points``)."""
    lost = {n: w for n, w in report.dropped.items() if not is_compliance_name(n)}
    if strict and lost:
        drop = ", ".join(f"{n} ({why.split(' (')[0]})" for n, why in lost.items())
        raise ValueError(
            f"error parameters not identifiable from these {what} (rank "
            f"{report.rank} of {len(names)}): drop {drop}"
        )
    loads = JointLoads(model, data, names)
    torques = loads.torques(loads.nominal())
    message = compliance_warning(report, names, loads.payload, torques)
    if message:
        warnings.warn(message, ComplianceWarning, stacklevel=stacklevel + 1)


def compliance_warning(
    report: object, names: list[str], payload: np.ndarray, torques: np.ndarray | None
) -> str | None:
    """One line naming the compliances among ``names`` that the identifiability
    ``report`` dropped, why, and what would make them visible; None when all
    are kept. ``payload`` (N,) kg and ``torques`` (N, n) are the readings'."""
    dropped = [n for n in names if is_compliance_name(n) and n in report.dropped]
    if not dropped:
        return None
    why, hint = [], False
    for n in dropped:
        j = int(n[1:]) - 1
        if torques is not None and not np.any(torques[:, j]):
            why.append(
                f"{n}: joint {j + 1}'s gravity torque is 0 at every reading, so "
                "gravity never bends it"
            )
        else:
            why.append(f"{n}: its torque does not vary enough over the readings")
            hint = True
    masses = np.unique(payload)
    advice = ""
    if masses.size == 1 or hint:
        one = (
            f"all readings were taken with one payload ({masses[0]:g} kg): "
            if masses.size == 1
            else ""
        )
        advice = (
            f"; {one}add readings with a payload (and without), in poses that "
            "change these joints' torques (e.g. the arm stretched and folded)"
        )
    return (
        f"compliances {', '.join(dropped)} are not identifiable from these "
        f"readings and are dropped ({'; '.join(why)}){advice}"
    )


def elastic_record(
    names: list[str],
    values: np.ndarray,
    std: np.ndarray,
    passes: int,
    payload: np.ndarray,
) -> dict[str, dict]:
    """The ``compliance`` and ``elastic`` sections of a calibration record, or
    {} without compliances among ``names``.

    ``compliance``: {c<j>: compliance and std (rad/(N m) or m/N), stiffness
    1 / c (N m/rad or N/m; None when c <= 0: written as rigid) and its relative
    std}; ``elastic``: the outer ``passes`` and the readings' distinct
    ``payload`` masses (kg). ``values`` and ``std`` are those of ``names``."""
    out: dict[str, dict] = {}
    for n, v, s in zip(names, values, std, strict=True):
        if not is_compliance_name(n):
            continue
        k = float(1.0 / v) if v > 0 else None
        rel = float(s / v) if v > 0 else None
        out[n] = {
            "compliance": float(v),
            "std": float(s),
            "stiffness": k,
            "relative_std": rel,
        }
    if not out:
        return {}
    return {
        "compliance": out,
        "elastic": {
            "passes": int(passes),
            "payloads_kg": [float(m) for m in np.unique(payload)],
            "units": "compliance and std in rad/(N m) (m/N on a slide), "
            "stiffness in N m/rad (N/m), relative_std of the stiffness",
        },
    }
