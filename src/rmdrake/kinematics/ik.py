"""Inverse kinematics of the tool frame E on an MDH model, batched.

:func:`solve_tool_ik` is the project's one tool IK: the plate simulation places
its reading poses with it and :mod:`rmdrake.compensation` corrects joint targets
with it. It runs the chain of :mod:`rmdrake.kinematics` (the same frames, so the
same bits) and the joint-axis Jacobian of its points: z_j x (p - o_j) for a
revolute joint j (m/rad), z_j for a prismatic one (m/m), whose q_j adds to r_j
(``RobotModel.sigma``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.kinematics import forward
from rmdrake.kinematics.forward import (
    chunk_slices,
    mdh_chain,
    single_pose_chain,
    static_rotations,
)

if TYPE_CHECKING:
    from rmdrake.model.robot import RobotModel

__all__ = ["ToolIK", "solve_tool_ik"]


class ToolIK(NamedTuple):
    """Result of :func:`solve_tool_ik`.

    Attributes:
      q: (M, n) joint positions, rad (revolute) or m (prismatic), within the
        joint limits.
      residual: (M,) norm of the stacked point residual at q, m.
      iterations: (M,) Gauss-Newton steps taken by each problem.
      X_BE: (M, 4, 4) tool poses at q.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, solve_tool_ik
    >>> robot = load_robot("rv3sb")
    >>> result = solve_tool_ik(robot, np.zeros((1, 6)), np.array([[0.4, 0.0, 0.5]]))
    >>> type(result).__name__, result.q.shape, result.X_BE.shape
    ('ToolIK', (1, 6), (1, 4, 4))
    """

    q: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    X_BE: np.ndarray


def _pose(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(N, 4, 4) homogeneous poses of (N, 3, 3) rotations and (N, 3) origins."""
    X = np.zeros((R.shape[0], 4, 4))
    X[:, :3, :3], X[:, :3, 3], X[:, 3, 3] = R, p, 1.0
    return X


class _BatchedPoints:
    """The IK points of N problems and their q-Jacobian, by :func:`mdh_chain`
    with the joint types ``slide`` (n,) bool (True: prismatic).

    Points (m, in B): p_E, then p_E + lever z_E, then p_E + lever x_E (the
    first k of them). For the Jacobian of the x point the chain gets one more
    fixed row Rot_y(pi/2) after the tool (zero "joint"), whose z axis is x_E;
    its frames up to the tool equal those of the plain table (this keeps the
    plate simulation's poses what they were when the IK lived there).
    """

    def __init__(
        self, table: np.ndarray, n: int, k: int, lever: float, slide: np.ndarray
    ) -> None:
        self.n, self.k, self.lever, self.slide = n, k, lever, slide
        self.prismatic = slide
        if k == 3:
            table = np.vstack([table, [0.0, 0.0, 0.0, 0.0, np.pi / 2]])
            self.prismatic = np.append(slide, False)  # the fixed row's zero
        self.table = table[None]
        self.S_all = static_rotations(self.table)

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, list]:
        """Points (N, 3k) at q (N, n), m, and the chain frames."""
        n, lever = self.n, self.lever
        if self.k == 3:
            q = np.hstack([q, np.zeros((q.shape[0], 1))])
        _, _, frames = mdh_chain(self.table, q, True, self.S_all, self.prismatic)
        R_E, p_E = frames[n][3], frames[n][4]
        points = [p_E, p_E + lever * R_E[:, 2], p_E + lever * R_E[:, 0]]
        return np.concatenate([x[:, 0].T for x in points[: self.k]], 1), frames

    def pose(self, frames: list, mask: np.ndarray) -> np.ndarray:
        """(N', 4, 4) tool poses X_BE of the problems ``mask`` selects."""
        R_E, p_E = frames[self.n][3], frames[self.n][4]
        return _pose(np.moveaxis(R_E[:, :, 0, mask], 2, 0), p_E[:, 0, mask].T)

    def jacobian(self, frames: list, mask: np.ndarray) -> np.ndarray:
        """(N', 3k, n) d points / d q (m/rad, m/m) of the problems ``mask``
        selects.

        A revolute joint j turns about z_j through o_j, and theta_j = q_j +
        offset, so the column of a point p is z_j x (p - o_j): the theta column
        of :func:`point_jacobian`; a prismatic joint slides along z_j (r_j =
        q_j + offset), so its column is z_j for every point: the r column.
        Computed here for all joints and points at once.
        """
        n, lever = self.n, self.lever
        R_E, p_E = frames[n][3], frames[n][4]
        points = [p_E, p_E + R_E[:, 2] * lever]
        if self.k == 3:
            R_x, p_x = frames[n + 1][3], frames[n + 1][4]
            points.append(p_x + R_x[:, 2] * lever)
        pm = np.stack(points[: self.k], axis=1)[..., mask]  # (3, k, 1, N')
        z = np.stack([frames[j][3][:, 2] for j in range(n)], axis=1)[..., mask]
        o = np.stack([frames[j][4] for j in range(n)], axis=1)[..., mask]
        J = np.cross(z[:, None], pm[:, :, None] - o[:, None], axis=0)
        if self.slide.any():
            J[:, :, self.slide] = z[:, None, self.slide]
        return np.ascontiguousarray(
            J[:, :, :, 0].transpose(3, 1, 0, 2).reshape(-1, 3 * self.k, n)
        )


class _SinglePoints:
    """The same points, poses and Jacobian for one problem (N = 1) on the
    plain-float chain :class:`~rmdrake.kinematics.forward.SinglePoseChain`
    (much faster for one pose); the x point's Jacobian uses x_E
    directly."""

    def __init__(
        self, table: np.ndarray, n: int, k: int, lever: float, slide: np.ndarray
    ) -> None:
        self.k, self.lever = k, lever
        self.chain = single_pose_chain(table, n, slide)

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, tuple]:
        R, (px, py, pz), axes = self.chain(q[0])
        lever = self.lever
        (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = R
        points = [
            (px, py, pz),
            (px + lever * z0, py + lever * z1, pz + lever * z2),
            (px + lever * x0, py + lever * x1, pz + lever * x2),
        ][: self.k]
        return np.array([sum(points, ())]), (points, axes, R, (px, py, pz))

    def pose(self, state: tuple, mask: np.ndarray) -> np.ndarray:
        return _pose(np.array([state[2]]), np.array([state[3]]))[mask]

    def jacobian(self, state: tuple, mask: np.ndarray) -> np.ndarray:
        J = [
            row
            for point in state[0]
            for row in self.chain.point_columns(state[1], point)
        ]
        return np.array([J])[mask]


def solve_tool_ik(
    model: RobotModel,
    q0: np.ndarray,
    p_BE: np.ndarray,
    z_BE: np.ndarray | None = None,
    x_BE: np.ndarray | None = None,
    *,
    lever: float = 0.1,
    tol: float = 1e-10,
    max_iterations: int = 40,
    damping: float = 1e-6,
    residual_damping: float = 0.0,
    max_step: float = 0.3,
    give_up: float = 1e-2,
) -> ToolIK:
    """Batched inverse kinematics of the tool frame E: joint positions q that put
    E on M targets, all solved at once (the loop runs over iterations only).
    Joints are revolute (q in rad) or prismatic (q in m) as ``model.sigma``
    says.

    The residual of a problem stacks, in m: ``p_E(q) - p_BE`` (3 DOF, position
    only); with ``z_BE`` also ``p_E + lever z_E - (p_BE + lever z_BE)`` (5 DOF:
    origin and beam direction, roll about z_E free); with ``x_BE`` too the same
    for x_E (6 DOF, full pose). Damped Gauss-Newton (Levenberg-Marquardt): the
    step is ``dq = -(J^T J + lambda I)^-1 J^T r`` with the analytic Jacobian
    J = dr/dq (columns z_j x (point - o_j) for a revolute joint and z_j for a
    prismatic one, see :func:`point_jacobian`) and
    ``lambda = damping + residual_damping |r|^2``, scaled down so that no joint
    moves more than ``max_step``; q is then clipped to the joint limits (a
    projection: a joint driven past a limit stays on it). A problem stops when
    its residual norm is <= ``tol`` or, from half of ``max_iterations`` on,
    >= ``give_up`` (unreachable or stuck). One problem (M = 1) is evaluated
    in plain floats instead of numpy arrays (same iteration, faster; results
    agree to round-off). The problems are independent: they are solved in
    chunks of at most :data:`~rmdrake.kinematics.forward.CHUNK_POSES` (about
    3 kB of work space each), so memory is the output's plus a bounded work
    space; no chunk holds a single problem unless M = 1.

    Args:
      model: robot (its MDH table, joint types and joint limits).
      q0: (M, n) start joint positions, rad or m (clipped to the limits first).
      p_BE: (M, 3) target tool origins in B, m.
      z_BE: (M, 3) target unit z axes of E in B, or None.
      x_BE: (M, 3) target unit x axes of E (orthogonal to z_BE), or None; needs
        ``z_BE``.
      lever: distance of the direction points from the origin, m (weighs a
        direction error of 1 rad as ``lever`` m).
      tol: convergence threshold on the residual norm, m.
      max_iterations: largest number of steps.
      damping: constant part of lambda, m^2/rad^2 (m^2/m^2 for a prismatic
        joint).
      residual_damping: factor of |r|^2 in lambda, 1/rad^2 (1/m^2). A lambda that
        shrinks with the residual (Yamashita and Fukushima's choice, factor 1)
        keeps the convergence quadratic where a constant one slows it down to
        linear: near singular configurations (wrist at q5 ~ 0), whose smallest
        singular value of J is comparable to sqrt(damping).
      max_step: largest joint move per step, rad or m.
      give_up: residual norm (m) above which a problem is dropped from half of
        ``max_iterations`` on; ``np.inf`` never drops one.

    Returns:
      :class:`ToolIK`: q, residual norm at q (m), steps taken and tool pose,
      per problem.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, solve_tool_ik, tool_poses
    >>> robot = load_robot("rv3sb")
    >>> q_true = np.array([[0.1, 0.2, 0.3, 0.1, 0.4, 0.2]])
    >>> X = tool_poses(robot.table, q_true)
    >>> ik = solve_tool_ik(robot, q_true + 0.05, X[:, :3, 3], X[:, :3, 2], X[:, :3, 0])
    >>> ik.q.shape, bool(ik.residual.max() < 1e-9)
    ((1, 6), True)
    """
    n = model.n_joints
    lo, hi = model.limits.lower, model.limits.upper
    q = np.clip(as_finite_array(q0, "q0", (None, n)), lo, hi)
    M = q.shape[0]
    p_BE = as_finite_array(p_BE, "p_BE", (M, 3))
    targets = [p_BE]
    for name, axis in (("z_BE", z_BE), ("x_BE", x_BE)):
        if axis is not None:
            if name == "x_BE" and z_BE is None:
                raise ValueError("x_BE: needs z_BE (a full pose gives both axes)")
            targets.append(p_BE + lever * as_finite_array(axis, name, (M, 3)))
    target = np.concatenate(targets, axis=1)
    kind = _SinglePoints if M == 1 else _BatchedPoints
    points = kind(model.table, n, len(targets), lever, model.sigma == 1)
    options = _Options(
        lo, hi, tol, max_iterations, damping, residual_damping, max_step, give_up
    )
    if M == 1:  # one problem: the plain-float path without the batch's masks
        return ToolIK(*_iterate_one(points, q, target, options))
    residual, X_BE = np.empty(M), np.empty((M, 4, 4))
    iterations = np.zeros(M, dtype=np.int64)
    # Equal parts of at most CHUNK_POSES problems: none of one problem (the
    # plain-float path).
    for rows in chunk_slices(M, forward.CHUNK_POSES):
        q[rows], residual[rows], iterations[rows], X_BE[rows] = _iterate(
            points, q[rows], target[rows], options
        )
    return ToolIK(q, residual, iterations, X_BE)


class _Options(NamedTuple):
    """The iteration's settings (see :func:`solve_tool_ik`)."""

    lo: np.ndarray
    hi: np.ndarray
    tol: float
    max_iterations: int
    damping: float
    residual_damping: float
    max_step: float
    give_up: float

    def keeps(self, norm: float | np.ndarray, it: int) -> bool | np.ndarray:
        """Where a problem of residual ``norm`` (m) takes another step at
        iteration ``it``: not converged, steps left, and (from half of the
        steps on) not given up."""
        keep = (norm > self.tol) & (it < self.max_iterations)
        return keep & (norm < self.give_up) if it >= self.max_iterations // 2 else keep

    def step(
        self, q: np.ndarray, J: np.ndarray, r: np.ndarray, norm: np.ndarray
    ) -> np.ndarray:
        """q (m, n) after the damped Gauss-Newton step of m problems with
        Jacobians J (m, 3k, n), residuals r (m, 3k) and their norms (m,), m:
        each step scaled so that no joint moves more than ``max_step``, then
        clipped to the limits."""
        eye = np.eye(J.shape[2])
        JtJ = np.einsum("mik,mil->mkl", J, J) + self.damping * eye
        if self.residual_damping:
            JtJ += (self.residual_damping * norm**2)[:, None, None] * eye
        step = -np.linalg.solve(JtJ, np.einsum("mik,mi->mk", J, r)[..., None])[..., 0]
        big = np.max(np.abs(step), axis=1, keepdims=True)
        step *= np.minimum(1.0, self.max_step / np.maximum(big, 1e-300))
        return np.clip(q + step, self.lo, self.hi)


def _iterate_one(
    points: _SinglePoints, q: np.ndarray, target: np.ndarray, options: _Options
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_iterate` of one problem (q (1, n), target (1, 3k)): the same
    steps, without the batch's bookkeeping (what a controller's update solves)."""
    one = np.ones(1, dtype=bool)
    for it in range(options.max_iterations + 1):  # the last pass only evaluates
        at, state = points(q)
        r = at - target
        norm = np.linalg.norm(r, axis=1)
        if not options.keeps(norm[0], it):
            return q, norm, np.array([it]), points.pose(state, one)
        q = options.step(q, points.jacobian(state, one), r, norm)
    raise AssertionError("unreachable: the last pass stops")


def _iterate(
    points: _BatchedPoints | _SinglePoints,
    q: np.ndarray,
    target: np.ndarray,
    options: _Options,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The damped Gauss-Newton iteration of :func:`solve_tool_ik` on the M
    problems of q (M, n) and their stacked targets (M, 3k), m: (q, residual
    norm, steps, tool poses), each per problem."""
    M = q.shape[0]
    q = q.copy()
    residual, X_BE = np.empty(M), np.empty((M, 4, 4))
    iterations, active = np.zeros(M, dtype=np.int64), np.arange(M)
    for it in range(options.max_iterations + 1):  # the last pass only evaluates
        at, state = points(q[active])
        r = at - target[active]
        norm = np.linalg.norm(r, axis=1)
        keep = options.keeps(norm, it)
        if not keep.all():
            residual[active[~keep]] = norm[~keep]
            X_BE[active[~keep]] = points.pose(state, ~keep)
            active, r = active[keep], r[keep]
        if active.size == 0:
            break
        J = points.jacobian(state, keep)
        q[active] = options.step(q[active], J, r, norm[keep])
        iterations[active] += 1
    return q, residual, iterations, X_BE
