"""Joint-target correction on a calibrated model ("program filtering").

A calibrated robot model knows where the real tool goes; a robot controller
still moves its joints by the nominal model. To put the real tool on a target,
the joint positions are computed with the calibrated model: for each target
(tool position p_BE in the base B, optionally orientation R_BE) the joint
positions q with ``p_BE(q) = p*`` (and ``R_BE(q) = R*``) of the *calibrated*
model. Joints are revolute (q in rad) or prismatic (q in m) as the model's
``sigma`` says; every joint vector below is in those units.
Filtering a joint program (what RoboDK calls filtering) takes the nominal
model's tool poses at the programmed joints as the targets and corrects them.

Solver: :func:`rmdrake.kinematics.ik.solve_tool_ik` (Levenberg-Marquardt with the
analytic Jacobian and the damping ``1e-12 + |r|^2``, at most ``max_step`` rad
or m per joint per step, joints clipped to the limits after each step), batched over the
targets. An orientation enters as the two points ``lever = 0.1`` m along z_E and
x_E; the solver stops at a stacked residual of ``tol`` (positions only) or
``tol lever / 3`` (poses), which bounds the position error by ``tol`` m and the
orientation error, at most ``2 sqrt(2) / lever`` times the stacked residual, by
``tol`` rad. Reported errors are measured directly: position residual
``|p_BE(q) - p*|`` (m) and orientation residual = angle of ``R*^T R_BE(q)``
(rad). A target is *reachable* when both are <= ``reach_tol`` (1e-6 m and rad
by default); a solution *at a limit* has some joint on its lower or upper limit.

Orientation inputs are (M, 3, 3) rotation matrices R_BE or (M, 3) roll, pitch,
yaw in rad with Drake's RollPitchYaw convention R = Rz(yaw) Ry(pitch) Rx(roll)
(:mod:`rmdrake.kinematics.rotations`, whose two conversions are re-exported here).

On an elastic model (``compliance``) the solved q are the LINK-side joints; the
motor-side (encoder) targets that hold them under gravity and a payload at
rest, ``Correction.q_motor``, are their pre-deflection
:func:`rmdrake.dynamics.compliance.motor_angles` (the inverse of ``link_angles``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.compliance import joint_compliances, motor_angles
from rmdrake.kinematics.forward import (
    chunk_slices,
    single_pose_chain,
    tool_jacobian,
    tool_poses,
)
from rmdrake.kinematics.ik import ToolIK, solve_tool_ik
from rmdrake.kinematics.rotations import (
    checked_rotations,
    rotation_angle,
    rotation_from_rpy,
    rpy_from_rotation,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "CHUNK_TARGETS",
    "Correction",
    "FilteredProgram",
    "correct_joint_motion",
    "correct_path",
    "correct_targets",
    "filter_program",
    "inverse_kinematics",
    "motion_map",
    "point_motion_map",
    "require_same_robot",
    "rotation_from_rpy",
    "rpy_from_rotation",
    "target_chunks",
]

_LEVER = 0.1  # m: the orientation points' distance from the tool origin

CHUNK_TARGETS = 4_096
"""Most targets :func:`inverse_kinematics` solves at once (times its starts:
65 536 IK problems with 16 starts, about 0.2 GB of work space); the targets
are independent, so the result is that of one batch."""


@dataclasses.dataclass(frozen=True)
class Correction:
    """Corrected joint angles of M targets (see the module docstring).

    Attributes:
      q: (M, n) joint positions, rad or m, within the limits.
      position_residual: (M,) |p_BE(q) - p*| of the model solved for, m.
      orientation_residual: (M,) angle of R*^T R_BE(q), rad; None when only
        positions were given (orientation free).
      iterations: (M,) solver steps taken per target.
      reachable: (M,) both residuals <= ``reach_tol``.
      at_limit: (M,) some joint of q is on its lower or upper limit.
      reach_tol: the tolerance of ``reachable``, m and rad.
      q_motor: (M, n) motor-side targets of an elastic model (q pre-deflected
        for the payload, rad or m); None on a rigid model.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.compensation import Correction, correct_targets
    >>> robot = load_robot("rv3sb")
    >>> q = np.full((3, 6), 0.3)
    >>> fix = correct_targets(robot, tool_points(robot.table, q), q_seed=q + 0.05)
    >>> isinstance(fix, Correction), fix.q.shape, bool(fix.reachable.all())
    (True, (3, 6), True)
    """

    q: np.ndarray
    position_residual: np.ndarray
    orientation_residual: np.ndarray | None
    iterations: np.ndarray
    reachable: np.ndarray
    at_limit: np.ndarray
    reach_tol: float
    q_motor: np.ndarray | None = None

    @property
    def unreachable(self) -> np.ndarray:
        """Indices of the targets that are not reachable."""
        return np.flatnonzero(~self.reachable)

    def summary(self) -> str:
        """Counts, largest residuals and iterations on one line, then one line
        per unreachable target naming it by its 1-based number (the row of a
        targets file) and its 0-based index, with its residuals, e.g.
        ``target 5 of 10 (index 4): unreachable, position residual 0.3 m``."""
        ori = self.orientation_residual
        lines = [
            f"{self.q.shape[0]} targets, {self.unreachable.size} unreachable "
            f"(residual > {self.reach_tol:g}), {int(self.at_limit.sum())} at a "
            f"joint limit; largest position residual of the reachable "
            f"{_max(self.position_residual[self.reachable]):.3g} m"
            + (
                ""
                if ori is None
                else f", orientation {_max(ori[self.reachable]):.3g} rad"
            )
            + f"; iterations <= {int(self.iterations.max())}"
        ]
        for k in self.unreachable:
            lines.append(
                f"  target {k + 1} of {self.q.shape[0]} (index {k}): unreachable, "
                f"position residual "
                f"{self.position_residual[k]:.6g} m"
                + ("" if ori is None else f", orientation residual {ori[k]:.6g} rad")
                + (", at a joint limit" if self.at_limit[k] else "")
            )
        return "\n".join(lines)


def _max(values: np.ndarray) -> float:
    return float(values.max()) if values.size else 0.0


def _targets(
    model: RobotModel, targets: object, orientation: object, q: object, q_name: str
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    p = as_finite_array(targets, "targets", (None, 3))
    if p.shape[0] < 1:
        raise ValueError("targets: expected at least one target, found none")
    M, n = p.shape[0], model.n_joints
    shape = (n,) if q_name == "q_start" else (M, n)
    return p, checked_rotations(orientation, M), as_finite_array(q, q_name, shape)


def _solve(
    model: RobotModel, q0: np.ndarray, p: np.ndarray, R: np.ndarray | None, **kw
) -> ToolIK:
    axes, tol = (None, None), kw.pop("tol")
    if R is not None:
        axes, tol = (R[:, :, 2], R[:, :, 0]), tol * _LEVER / 3
    kw.setdefault("damping", 1e-12)
    kw.update(lever=_LEVER, tol=tol, residual_damping=1.0, give_up=np.inf)
    return solve_tool_ik(model, q0, p, *axes, **kw)


def _result(
    model: RobotModel,
    ik: ToolIK,
    p: np.ndarray,
    R: np.ndarray | None,
    reach_tol: float,
    payload: object = None,
) -> Correction:
    X = ik.X_BE
    pos = np.linalg.norm(X[:, :3, 3] - p, axis=1)
    ori = None if R is None else rotation_angle(R, X[:, :3, :3])
    reachable = (pos <= reach_tol) & (True if ori is None else ori <= reach_tol)
    lo, hi = model.limits.lower, model.limits.upper
    at_limit = np.any((ik.q <= lo) | (ik.q >= hi), axis=1)
    q_m = motor_angles(model, ik.q, payload) if joint_compliances(model).any() else None
    return Correction(
        ik.q, pos, ori, ik.iterations, reachable, at_limit, reach_tol, q_m
    )


def correct_targets(
    model: RobotModel,
    targets: np.ndarray,
    *,
    q_seed: np.ndarray,
    orientation: np.ndarray | None = None,
    tol: float = 1e-10,
    max_iterations: int = 40,
    damping: float = 1e-12,
    max_step: float = 0.3,
    reach_tol: float = 1e-6,
    payload: object = None,
) -> Correction:
    """Joint positions that put ``model``'s tool on M targets, all at once.

    Args:
      model: the (calibrated) robot whose tool is to reach the targets.
      targets: (M, 3) tool origins p_BE in B, m.
      q_seed: (M, n) start joint positions, rad or m (the nominal joint
        program is the natural seed); clipped to the limits.
      orientation: None (position only; with 6 joints the solution nearest the
        seed in the Gauss-Newton sense), (M, 3, 3) R_BE or (M, 3) roll, pitch,
        yaw in rad.
      tol: convergence threshold of the position (m) and orientation (rad)
        residuals, see the module docstring.
      max_iterations: most solver steps per target.
      damping: constant part of the Levenberg-Marquardt term, m^2/rad^2
        (m^2/m^2 for a prismatic joint); the
        term is ``damping + |r|^2`` (r the stacked residual, m), which keeps
        the convergence quadratic near singular configurations.
      max_step: largest joint move per step, rad or m.
      reach_tol: residual above which a target counts as unreachable, m and rad.
      payload: kg at the tool for ``q_motor`` of an elastic model: None (the
        model's payload mass, 0 without one), a scalar or (M,).

    Raises:
      ValueError: one line, for wrong shapes, NaN or infinite values, or an
        orientation that is not a rotation.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.compensation import correct_targets
    >>> robot = load_robot("rv3sb")
    >>> q = np.full((3, 6), 0.3)
    >>> fix = correct_targets(robot, tool_points(robot.table, q), q_seed=q + 0.05)
    >>> bool(fix.position_residual.max() < 1e-9), fix.iterations.shape
    (True, (3,))
    """
    p, R, q_seed = _targets(model, targets, orientation, q_seed, "q_seed")
    kw = {"tol": tol, "max_iterations": max_iterations, "damping": damping}
    ik = _solve(model, q_seed, p, R, max_step=max_step, **kw)
    return _result(model, ik, p, R, reach_tol, payload)


def correct_path(
    model: RobotModel,
    targets: np.ndarray,
    *,
    q_start: np.ndarray,
    orientation: np.ndarray | None = None,
    tol: float = 1e-10,
    max_iterations: int = 40,
    reach_tol: float = 1e-6,
    payload: object = None,
) -> Correction:
    """Joint positions along a path of M targets, each warm-started from the
    last.

    Target 0 is solved from ``q_start``, target k from the linear extrapolation
    ``2 q_{k-1} - q_{k-2}`` of the two previous solutions (``q_{k-1}`` for
    k = 1), clipped to the limits: on a smooth path the seed is then off by
    the square of the step and one or two steps converge; the solution follows
    the branch (elbow, wrist) of ``q_start``. Sequential over the path. Other
    arguments and the result as in :func:`correct_targets`.

    Args:
      q_start: (n,) joint positions near the solution of target 0, rad or m.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.compensation import correct_path
    >>> robot = load_robot("rv3sb")
    >>> q = np.linspace(0.2, 0.4, 5)[:, None] * np.ones(6)
    >>> fix = correct_path(robot, tool_points(robot.table, q), q_start=q[0])
    >>> fix.q.shape, bool(fix.position_residual.max() < 1e-9)
    ((5, 6), True)
    """
    p, R, q_start = _targets(model, targets, orientation, q_start, "q_start")
    M, n = p.shape[0], model.n_joints
    lo, hi = model.limits.lower, model.limits.upper
    q = np.empty((M, n))
    iterations = np.zeros(M, dtype=np.int64)
    residual, X_BE = np.empty(M), np.empty((M, 4, 4))
    kw = {"tol": tol, "max_iterations": max_iterations}
    for k in range(M):
        if k == 0:
            seed = q_start
        elif k == 1:
            seed = q[0]
        else:
            seed = np.clip(2.0 * q[k - 1] - q[k - 2], lo, hi)
        Rk = None if R is None else R[k : k + 1]
        ik = _solve(model, seed[None], p[k : k + 1], Rk, **kw)
        q[k], residual[k], iterations[k], X_BE[k] = (v[0] for v in ik)
    ik = ToolIK(q, residual, iterations, X_BE)
    return _result(model, ik, p, R, reach_tol, payload)


@dataclasses.dataclass(frozen=True)
class FilteredProgram:
    """A joint program corrected for a calibrated robot.

    Attributes:
      q: (M, n) corrected joint positions, rad or m.
      dq: (M, n) corrections q - q_nominal, rad or m.
      max_dq: (n,) largest |dq| of each joint over the program, rad or m.
      correction: the solver result (residuals, reachability, limits).
      sigma: (n,) joint types of the robot (0 revolute, 1 prismatic), or None
        for all revolute.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.compensation import filter_program
    >>> robot = load_robot("rv3sb")
    >>> program = filter_program(robot, robot, np.full((2, 6), 0.3))
    >>> program.q.shape, program.max_dq.shape
    ((2, 6), (6,))
    """

    q: np.ndarray
    dq: np.ndarray
    max_dq: np.ndarray
    correction: Correction
    sigma: np.ndarray | None = None

    def summary(self) -> str:
        """Largest correction per joint (mrad, or mm for a prismatic joint),
        then the solver summary."""
        slide = np.zeros(self.max_dq.size, bool) if self.sigma is None else self.sigma
        joints = ", ".join(
            f"{v * 1e3:.3g} {'mm' if s else 'mrad'}"
            for v, s in zip(self.max_dq, slide, strict=True)
        )
        return f"largest |dq| per joint: {joints}\n{self.correction.summary()}"


def require_same_robot(nominal: RobotModel, calibrated: RobotModel) -> None:
    """ValueError unless ``calibrated`` has ``nominal``'s joint count and joint
    types (``sigma``): a calibrated model of the same robot."""
    if nominal.n_joints != calibrated.n_joints:
        raise ValueError(
            f"calibrated robot has {calibrated.n_joints} joints, the nominal one "
            f"{nominal.n_joints}: expected the same robot"
        )
    if not np.array_equal(nominal.sigma, calibrated.sigma):
        raise ValueError(
            f"calibrated robot sigma: joint types {calibrated.sigma.tolist()}, the "
            f"nominal one's {nominal.sigma.tolist()}: expected the same robot"
        )


def filter_program(
    nominal: RobotModel,
    calibrated: RobotModel,
    q_nominal: np.ndarray,
    *,
    q_seed: np.ndarray | None = None,
    orientation: bool = True,
    tol: float = 1e-10,
    max_iterations: int = 40,
    reach_tol: float = 1e-6,
    payload: object = None,
) -> FilteredProgram:
    """Filters a joint program: the joints that put the calibrated robot's tool
    where the nominal robot's tool is at the programmed joints (the same joint
    types on both).

    The targets are the nominal tool poses X_BE(q_nominal) (positions only when
    ``orientation`` is False); they are solved on ``calibrated`` by
    :func:`correct_targets` seeded with ``q_seed`` (default q_nominal).

    Args:
      nominal: the model the program was written with.
      calibrated: the calibrated model of the same robot.
      q_nominal: (M, n) programmed joint positions, rad or m.
      payload: as :func:`correct_targets` (``correction.q_motor``).

    Raises:
      ValueError: different joint counts or types, wrong shape, NaN or infinite
        values.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.compensation import FilteredProgram, filter_program
    >>> robot = load_robot("rv3sb")
    >>> q = np.full((4, 6), 0.3)
    >>> program = filter_program(robot, robot, q)
    >>> isinstance(program, FilteredProgram), bool(np.abs(program.dq).max() < 1e-9)
    (True, True)
    """
    require_same_robot(nominal, calibrated)
    q_nominal = as_finite_array(q_nominal, "q_nominal", (None, nominal.n_joints))
    if q_nominal.shape[0] < 1:
        raise ValueError("q_nominal: expected at least one joint vector, found none")
    X = tool_poses(nominal.table, q_nominal, sigma=nominal.sigma)
    correction = correct_targets(
        calibrated,
        X[:, :3, 3],
        q_seed=q_nominal if q_seed is None else q_seed,
        orientation=X[:, :3, :3] if orientation else None,
        tol=tol,
        max_iterations=max_iterations,
        reach_tol=reach_tol,
        payload=payload,
    )
    dq = correction.q - q_nominal
    max_dq = np.abs(dq).max(axis=0)
    return FilteredProgram(correction.q, dq, max_dq, correction, calibrated.sigma)


def motion_map(
    nominal: RobotModel,
    calibrated: RobotModel,
    q: np.ndarray,
    *,
    q_seed: np.ndarray | None = None,
    tol: float = 1e-10,
) -> tuple[FilteredProgram, np.ndarray]:
    """The calibrated robot's joints whose tool is where the nominal robot's
    tool is at q (M, n), and the map of joint rates between the two.

    Positions: :func:`filter_program` (full tool pose), seeded with ``q_seed``
    (default q). Rates: equal tool twists, ``J_c(q_c) qd_c = J_n(q) qd`` with
    the geometric Jacobians of :func:`rmdrake.kinematics.forward.tool_jacobian`, so
    ``qd_c = A qd`` with ``A = J_c^+ J_n`` (least squares; exact for six joints
    away from singularities).

    Returns:
      (the filtered positions with their report, A (M, n, n)).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.compensation import motion_map
    >>> robot = load_robot("rv3sb")
    >>> program, A = motion_map(robot, robot, np.full((2, 6), 0.3))
    >>> A.shape, bool(np.abs(A - np.eye(6)).max() < 1e-6)
    ((2, 6, 6), True)
    """
    rigid = (  # kinematics only
        calibrated
        if calibrated.compliance is None
        else dataclasses.replace(calibrated, compliance=None)
    )
    filtered = filter_program(nominal, rigid, q, q_seed=q_seed, tol=tol)
    q = np.asarray(q, dtype=np.float64)
    J_n = tool_jacobian(nominal.table, q, sigma=nominal.sigma)
    J_c = tool_jacobian(calibrated.table, filtered.q, sigma=calibrated.sigma)
    J_c_pinv = np.linalg.pinv(J_c)
    return filtered, J_c_pinv @ J_n


def point_motion_map(
    nominal: RobotModel,
    calibrated: RobotModel,
    q: np.ndarray,
    q_seed: np.ndarray,
    *,
    tol: float = 1e-10,
    max_iterations: int = 40,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`motion_map` of one joint vector q (n,), rad or m, without its
    report: what a controller's update solves (each update of
    :class:`~rmdrake.systems.correction.JointTargetCorrection` calls it,
    warm-started).

    The nominal tool pose and Jacobian at q and the calibrated ones at the
    solution come from the plain-float chain
    (:class:`~rmdrake.kinematics.forward.SinglePoseChain`), the solution from
    the tool IK of :func:`correct_targets` seeded with ``q_seed`` (n,)
    (``tol``, m, and ``max_iterations`` as :func:`filter_program`'s). Equal
    to :func:`motion_map`'s to round-off. Inputs are not checked (the caller's
    are).

    Returns:
      (q_c (n,) rad or m, A (n, n) the rate map qd_c = A qd).
    """
    n = nominal.n_joints
    chain = single_pose_chain(nominal.table, n, nominal.sigma == 1)
    R, p, axes = chain(q)
    R_BE = np.array([R])
    ik = _solve(
        calibrated,
        q_seed[None],
        np.array([p]),
        R_BE,
        tol=tol,
        max_iterations=max_iterations,
    )
    q_c = ik.q[0]
    fixed = single_pose_chain(calibrated.table, n, calibrated.sigma == 1)
    _, p_c, axes_c = fixed(q_c)
    J_c = fixed.tool_jacobian(axes_c, p_c)
    return q_c, np.linalg.pinv(J_c) @ chain.tool_jacobian(axes, p)


def correct_joint_motion(
    nominal: RobotModel,
    calibrated: RobotModel,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    *,
    tol: float = 1e-10,
) -> tuple[FilteredProgram, np.ndarray, np.ndarray]:
    """The calibrated robot's joint motion whose tool moves as the nominal
    robot's tool at the programmed motion (q, qd, qdd), each (M, n).

    Positions and rates by :func:`motion_map`: ``qd_c = A qd``. Accelerations:
    ``qdd_c = A qdd``; this leaves out ``dJ_n/dt qd - dJ_c/dt qd_c``, a term of
    the order of the calibration's relative size (about 1e-3 for mm errors on a
    m-sized arm) times ``|qd|^2``.

    Returns:
      (the filtered positions with their report, qd_c (M, n) rad/s or m/s,
      qdd_c (M, n) rad/s^2 or m/s^2).

    Raises:
      ValueError: as :func:`filter_program`, or rates of another shape.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.compensation import correct_joint_motion
    >>> robot = load_robot("rv3sb")
    >>> q, qd = np.full((2, 6), 0.3), np.full((2, 6), 0.1)
    >>> program, qd_c, qdd_c = correct_joint_motion(robot, robot, q, qd, 0 * qd)
    >>> qd_c.round(6)
    array([[0.1, 0.1, 0.1, 0.1, 0.1, 0.1],
           [0.1, 0.1, 0.1, 0.1, 0.1, 0.1]])
    """
    filtered, A = motion_map(nominal, calibrated, q, tol=tol)
    qd = as_finite_array(qd, "qd", filtered.q.shape)
    qdd = as_finite_array(qdd, "qdd", filtered.q.shape)
    return filtered, np.einsum("mij,mj->mi", A, qd), np.einsum("mij,mj->mi", A, qdd)


def inverse_kinematics(
    model: RobotModel,
    targets: np.ndarray,
    *,
    orientation: object = None,
    starts: int = 16,
    tol: float = 1e-10,
) -> Correction:
    """Joint positions of ``model`` for tool targets with no joint seed at hand.

    Each target is solved by :func:`correct_targets` from ``starts`` fixed
    seeds (the middle of the joint ranges, and unscrambled Halton points over
    the ranges: the same seeds every call), all at once; per target the solution
    with the smallest residual is kept, ties (within ``tol``) going to the seed
    listed first. Targets are solved in chunks (:func:`target_chunks`), so
    memory is the result's plus a bounded work space.

    Args:
      targets: (M, 3) tool positions p_BE, m.
      orientation: None, (M, 3, 3) rotations R_BE or (M, 3) roll, pitch, yaw.
      starts: number of seeds (>= 1).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.compensation import inverse_kinematics
    >>> robot = load_robot("rv3sb")
    >>> targets = tool_points(robot.table, np.full((2, 6), 0.3))
    >>> fix = inverse_kinematics(robot, targets, starts=4)
    >>> bool(fix.reachable.all()), bool(fix.position_residual.max() < 1e-9)
    (True, True)
    """
    from scipy.stats import qmc

    p = as_finite_array(targets, "targets", (None, 3))
    M, n = p.shape[0], model.n_joints
    if starts < 1:
        raise ValueError(f"starts: expected >= 1, found {starts}")
    lo, hi = model.limits.lower, model.limits.upper
    halton = qmc.Halton(d=n, scramble=False).random(starts)[1:]
    seeds = np.vstack([np.clip(np.zeros(n), lo, hi), lo + halton * (hi - lo)])
    R = checked_rotations(orientation, M)
    parts = [
        _best_start(model, p[rows], None if R is None else R[rows], seeds, tol)
        for rows in target_chunks(M)
    ]
    return _concatenate(parts)


def target_chunks(count: int) -> list[slice]:
    """Consecutive slices of ``count`` targets in equal parts of at most
    :data:`CHUNK_TARGETS` (:func:`~rmdrake.kinematics.forward.chunk_slices`)."""
    return chunk_slices(count, CHUNK_TARGETS)


def _concatenate(parts: list[Correction]) -> Correction:
    """One :class:`Correction` of the targets of ``parts``, in order."""
    if len(parts) == 1:
        return parts[0]
    fields = {}
    for f in dataclasses.fields(Correction):
        values = [getattr(c, f.name) for c in parts]
        arrays = isinstance(values[0], np.ndarray)
        fields[f.name] = np.concatenate(values) if arrays else values[0]
    return Correction(**fields)


def _best_start(
    model: RobotModel,
    p: np.ndarray,
    R: np.ndarray | None,
    seeds: np.ndarray,
    tol: float,
) -> Correction:
    """:func:`inverse_kinematics` of targets p (M, 3), m, and rotations R
    (M, 3, 3) or None, from every seed of ``seeds`` (S, n)."""
    M = p.shape[0]
    rep = np.repeat(np.arange(M)[None], seeds.shape[0], axis=0).ravel()
    all_q = np.repeat(seeds, M, axis=0)
    solved = correct_targets(
        model,
        p[rep],
        q_seed=all_q,
        orientation=None if R is None else R[rep],
        tol=tol,
    )
    cost = solved.position_residual.reshape(-1, M)
    if solved.orientation_residual is not None:
        cost = cost + solved.orientation_residual.reshape(-1, M)
    best = np.argmax(cost <= cost.min(axis=0) + tol, axis=0) * M + np.arange(M)
    fields = dataclasses.fields(Correction)
    return Correction(
        **{
            f.name: (
                getattr(solved, f.name)[best]
                if isinstance(getattr(solved, f.name), np.ndarray)
                else getattr(solved, f.name)
            )
            for f in fields
        }
    )
