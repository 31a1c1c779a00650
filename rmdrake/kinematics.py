"""Vectorised modified-DH forward kinematics and error-parameter Jacobians.

Everything here works on the (n+1, 5) MDH table of :mod:`rmdrake.robot` (columns
``alpha, d, theta, r, beta``; last row = tool) or on a stack of P tables of shape
(P, n+1, 5), and on N joint vectors q of shape (N, n), with no Python loop over P
or N: the loop runs over the n+1 rows of the chain only. Internally rotation
matrices are stored component-first, (3, 3, P, N), so that every operation is an
elementwise product of contiguous (P, N) blocks.

Frames: B = robot base (frame 0 of the MDH chain), E = tool frame (row n+1). The
measurement point of a range finder reading ``distance`` (m) is
``p_BM = p_BE + distance * z_BE``, i.e. the reading adds to the tool r. The one
inverse kinematics of the tool frame, batched over targets, is
:func:`solve_tool_ik`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from rmdrake.arrays import as_finite_array

if TYPE_CHECKING:
    from rmdrake.robot import RobotModel

__all__ = ["ToolIK", "point_jacobian", "solve_tool_ik", "tool_points", "tool_poses"]


def _inputs(table: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    table = np.asarray(table, dtype=np.float64)
    batched = table.ndim == 3
    if not batched:
        table = table[None]
    if table.ndim != 3 or table.shape[2] != 5 or table.shape[1] < 2:
        raise ValueError(
            f"MDH table: expected shape (n+1, 5) or (P, n+1, 5), found "
            f"{np.shape(table)}"
        )
    n = table.shape[1] - 1
    q = as_finite_array(q, "q", None)
    if q.ndim == 1:
        q = q[None]
    if q.ndim != 2 or q.shape[1] != n:
        raise ValueError(f"q: expected shape (N, {n}) in rad, found {np.shape(q)}")
    return table, q, batched


def _static_rotations(table: np.ndarray) -> np.ndarray:
    """(n1, 3, 3, P) static rotations S_j = Rot_y(beta_j) Rot_x(alpha_j) of the
    rows of a (P, n1, 5) table stack, one contiguous (3, 3, P) block per row."""
    alpha, beta = table[:, :, 0].T, table[:, :, 4].T  # (n1, P)
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    S = np.array(
        [
            [cb, sb * sa, sb * ca],
            [np.zeros_like(cb), ca, -sa],
            [-sb, cb * sa, cb * ca],
        ]
    )
    return np.ascontiguousarray(np.moveaxis(S, 2, 0))


def _chain(
    table: np.ndarray, q: np.ndarray, keep: bool, S_all: np.ndarray | None = None
):
    """Runs the MDH chain. Returns R (3,3,P,N), p (3,P,N) of the last row and,
    if ``keep``, per row j the tuple (R_{j-1}, p_{j-1}, x'_j, R_j, p_j).

    Rows past the joints of q (the tool, and any fixed row after it) get no
    joint angle. ``S_all`` (from :func:`_static_rotations`) may be passed by a
    caller that runs the chain of one table many times; computing it here or
    there gives the same bits (each entry is the same expression).
    """
    P, N = table.shape[0], q.shape[0]
    nq = q.shape[1]
    # Per-row views: d[j], theta[j], r[j] of shape (P, 1); q_rows[j] (1, N).
    d, theta, r = (table[:, :, k].T[:, :, None] for k in (1, 2, 3))
    q_rows = q.T[:, None, :]
    if S_all is None:
        S_all = _static_rotations(table)
    R = None  # identity before the first row
    p = np.zeros((3, P, N))
    frames = []
    for j in range(table.shape[1]):
        if R is None:
            M = np.broadcast_to(S_all[j][..., None], (3, 3, P, N))
        else:
            M = np.einsum("ijpn,jkp->ikpn", R, S_all[j])  # M = R @ S
        M0, M1, M2 = M[:, 0], M[:, 1], M[:, 2]
        p_prev, R_prev = p, R
        # x'_j = M0 = R @ Rot_y(beta) e_x: the axis of alpha and d.
        # p_j = p + d * x' + r * z_j ; R_j = M @ Rot_z(theta).
        p = p + M0 * d[j] + M2 * r[j]
        th = theta[j] + (q_rows[j] if j < nq else 0.0)
        ct, st = np.cos(th), np.sin(th)
        R = np.empty((3, 3, P, N))
        R0, R1 = R[:, 0], R[:, 1]
        np.multiply(M0, ct, out=R0)
        R0 += M1 * st
        np.multiply(M1, ct, out=R1)
        R1 -= M0 * st
        R[:, 2] = M2
        if keep:
            if R_prev is None:
                R_prev = np.broadcast_to(np.eye(3)[:, :, None, None], (3, 3, P, N))
            frames.append((R_prev, p_prev, M0, R, p))
    return R, p, frames


def _point(R: np.ndarray, p: np.ndarray, distance: np.ndarray | None) -> np.ndarray:
    if distance is None:
        return p
    return p + R[:, 2] * distance


def _distance(distance: object, N: int) -> np.ndarray | None:
    if distance is None:
        return None
    d = as_finite_array(distance, "distance", None)
    if d.ndim == 0:
        d = np.full(N, float(d))
    if d.shape != (N,):
        raise ValueError(f"distance: expected shape ({N},) in m, found {d.shape}")
    return d


def tool_poses(table: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Homogeneous tool poses X_BE.

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables (rad, m).
      q: (N, n) joint angles, rad (a single (n,) vector is taken as N = 1).

    Returns:
      (N, 4, 4) for one table, (P, N, 4, 4) for a stack.
    """
    table, q, batched = _inputs(table, q)
    R, p, _ = _chain(table, q, keep=False)
    P, N = table.shape[0], q.shape[0]
    X = np.zeros((P, N, 4, 4))
    X[..., :3, :3] = np.moveaxis(R, (0, 1), (2, 3))
    X[..., :3, 3] = np.moveaxis(p, 0, 2)
    X[..., 3, 3] = 1.0
    return X if batched else X[0]


def tool_points(
    table: np.ndarray, q: np.ndarray, distance: object = None
) -> np.ndarray:
    """Measurement points p_BM = p_BE + distance * z_BE, in m.

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables.
      q: (N, n) joint angles, rad.
      distance: None (the tool point itself), a scalar or (N,) range readings, m.

    Returns:
      (N, 3) for one table, (P, N, 3) for a stack.
    """
    table, q, batched = _inputs(table, q)
    dist = _distance(distance, q.shape[0])
    R, p, _ = _chain(table, q, keep=False)
    out = np.moveaxis(_point(R, p, dist), 0, -1)
    return out if batched else out[0]


def point_jacobian(
    table: np.ndarray,
    q: np.ndarray,
    indices: np.ndarray,
    distance: object = None,
) -> np.ndarray:
    """Analytic Jacobian of the measurement point w.r.t. table entries.

    ``indices`` are flat indices into ``table.ravel()`` (see
    :func:`rmdrake.robot.error_parameter_indices`). With the screw of each entry:
    alpha_j rotates about x'_j (= R_{j-1} Rot_y(beta_j) e_x) through o_{j-1}, d_j
    translates along x'_j, theta_j rotates about z_j through o_j, r_j translates
    along z_j, beta_j rotates about y_{j-1} through o_{j-1}.

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables.
      q: (N, n) joint angles, rad.
      indices: (k,) flat table indices.
      distance: as in :func:`tool_points`.

    Returns:
      d p_BM / d param, (N, 3, k) or (P, N, 3, k): m/rad or m/m.
    """
    table, q, batched = _inputs(table, q)
    n1 = table.shape[1]
    indices = np.asarray(indices, dtype=np.intp).ravel()
    if indices.size and (indices.min() < 0 or indices.max() >= 5 * n1):
        raise ValueError(f"indices: expected values in 0..{5 * n1 - 1}")
    dist = _distance(distance, q.shape[0])
    R, p, frames = _chain(table, q, keep=True)
    pm = _point(R, p, dist)
    J = np.empty((3, table.shape[0], q.shape[0], indices.size))
    for c, flat in enumerate(indices):
        row, kind = divmod(int(flat), 5)
        R_prev, p_prev, x_axis, R_j, p_j = frames[row]
        if kind == 0:  # alpha
            J[..., c] = np.cross(x_axis, pm - p_prev, axis=0)
        elif kind == 1:  # d
            J[..., c] = x_axis
        elif kind == 2:  # theta
            J[..., c] = np.cross(R_j[:, 2], pm - p_j, axis=0)
        elif kind == 3:  # r
            J[..., c] = R_j[:, 2]
        else:  # beta
            J[..., c] = np.cross(R_prev[:, 1], pm - p_prev, axis=0)
    J = np.moveaxis(J, 0, -2)
    return J if batched else J[0]


# ---- inverse kinematics of the tool frame -----------------------------------------
class ToolIK(NamedTuple):
    """Result of :func:`solve_tool_ik`.

    Attributes:
      q: (M, n) joint angles, rad, within the joint limits.
      residual: (M,) norm of the stacked point residual at q, m.
      iterations: (M,) Gauss-Newton steps taken by each problem.
      X_BE: (M, 4, 4) tool poses at q.
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
    """The IK points of N problems and their q-Jacobian, by :func:`_chain`.

    Points (m, in B): p_E, then p_E + lever z_E, then p_E + lever x_E (the
    first k of them). For the Jacobian of the x point the chain gets one more
    fixed row Rot_y(pi/2) after the tool (zero "joint"), whose z axis is x_E;
    its frames up to the tool equal those of the plain table (this keeps the
    plate simulation's poses what they were when the IK lived there).
    """

    def __init__(self, table: np.ndarray, n: int, k: int, lever: float) -> None:
        self.n, self.k, self.lever = n, k, lever
        if k == 3:
            table = np.vstack([table, [0.0, 0.0, 0.0, 0.0, np.pi / 2]])
        self.table = table[None]
        self.S_all = _static_rotations(self.table)

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, list]:
        """Points (N, 3k) at q (N, n), m, and the chain frames."""
        n, lever = self.n, self.lever
        if self.k == 3:
            q = np.hstack([q, np.zeros((q.shape[0], 1))])
        _, _, frames = _chain(self.table, q, True, self.S_all)
        R_E, p_E = frames[n][3], frames[n][4]
        points = [p_E, p_E + lever * R_E[:, 2], p_E + lever * R_E[:, 0]]
        return np.concatenate([x[:, 0].T for x in points[: self.k]], 1), frames

    def pose(self, frames: list, mask: np.ndarray) -> np.ndarray:
        """(N', 4, 4) tool poses X_BE of the problems ``mask`` selects."""
        R_E, p_E = frames[self.n][3], frames[self.n][4]
        return _pose(np.moveaxis(R_E[:, :, 0, mask], 2, 0), p_E[:, 0, mask].T)

    def jacobian(self, frames: list, mask: np.ndarray) -> np.ndarray:
        """(N', 3k, n) d points / d q (m/rad) of the problems ``mask`` selects.

        Joint j turns about z_j through o_j, and theta_j = q_j + offset, so the
        column of a point p is z_j x (p - o_j): the theta column of
        :func:`point_jacobian`, computed here for all joints and points at once.
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
        return np.ascontiguousarray(
            J[:, :, :, 0].transpose(3, 1, 0, 2).reshape(-1, 3 * self.k, n)
        )


class _SinglePoints:
    """The same points, poses and Jacobian for one problem (N = 1) in plain
    floats: the same chain, without numpy's per-call overhead (about 15 times
    faster at this size); the x point's Jacobian uses x_E directly."""

    def __init__(self, table: np.ndarray, n: int, k: int, lever: float) -> None:
        self.n, self.k, self.lever = n, k, lever
        S = _static_rotations(table[None])[..., 0].reshape(-1, 9)
        self.rows = list(zip(S.tolist(), *table[:, 1:4].T.tolist(), strict=True))

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, tuple]:
        n, lever, qs = self.n, self.lever, q[0].tolist()
        x0, y0, z0, x1, y1, z1, x2, y2, z2 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        px = py = pz = 0.0
        axes = []  # (z_j, o_j) of the joints
        for j, ((a, b, c, d, e, f, g, h, i), dj, theta, rj) in enumerate(self.rows):
            # M = R S, then p += d x'_j + r z_j and R = M Rot_z(theta): rows of R
            # are x0 y0 z0 / x1 y1 z1 / x2 y2 z2, S = a b c / d e f / g h i.
            # fmt: off
            x0, y0, z0 = x0*a + y0*d + z0*g, x0*b + y0*e + z0*h, x0*c + y0*f + z0*i
            x1, y1, z1 = x1*a + y1*d + z1*g, x1*b + y1*e + z1*h, x1*c + y1*f + z1*i
            x2, y2, z2 = x2*a + y2*d + z2*g, x2*b + y2*e + z2*h, x2*c + y2*f + z2*i
            px, py, pz = px + x0*dj + z0*rj, py + x1*dj + z1*rj, pz + x2*dj + z2*rj
            # fmt: on
            th = theta + qs[j] if j < n else theta
            cs, sn = math.cos(th), math.sin(th)
            x0, y0 = x0 * cs + y0 * sn, y0 * cs - x0 * sn
            x1, y1 = x1 * cs + y1 * sn, y1 * cs - x1 * sn
            x2, y2 = x2 * cs + y2 * sn, y2 * cs - x2 * sn
            if j < n:
                axes.append((z0, z1, z2, px, py, pz))
        points = [
            (px, py, pz),
            (px + lever * z0, py + lever * z1, pz + lever * z2),
            (px + lever * x0, py + lever * x1, pz + lever * x2),
        ][: self.k]
        R = ((x0, y0, z0), (x1, y1, z1), (x2, y2, z2))
        return np.array([sum(points, ())]), (points, axes, R, (px, py, pz))

    def pose(self, state: tuple, mask: np.ndarray) -> np.ndarray:
        return _pose(np.array([state[2]]), np.array([state[3]]))[mask]

    def jacobian(self, state: tuple, mask: np.ndarray) -> np.ndarray:
        J = []
        for x, y, z in state[0]:
            cols = [
                (x - ox, y - oy, z - oz, ax, ay, az)
                for ax, ay, az, ox, oy, oz in state[1]
            ]
            J.append([ay * w - az * v for u, v, w, ax, ay, az in cols])
            J.append([az * u - ax * w for u, v, w, ax, ay, az in cols])
            J.append([ax * v - ay * u for u, v, w, ax, ay, az in cols])
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
    """Batched inverse kinematics of the tool frame E: joint angles q that put E
    on M targets, all solved at once (the loop runs over iterations only).

    The residual of a problem stacks, in m: ``p_E(q) - p_BE`` (3 DOF, position
    only); with ``z_BE`` also ``p_E + lever z_E - (p_BE + lever z_BE)`` (5 DOF:
    origin and beam direction, roll about z_E free); with ``x_BE`` too the same
    for x_E (6 DOF, full pose). Damped Gauss-Newton (Levenberg-Marquardt): the
    step is ``dq = -(J^T J + lambda I)^-1 J^T r`` with the analytic Jacobian
    J = dr/dq (columns z_j x (point - o_j), see :func:`point_jacobian`) and
    ``lambda = damping + residual_damping |r|^2``, scaled down so that no joint
    moves more than ``max_step``; q is then clipped to the joint limits (a
    projection: a joint driven past a limit stays on it). A problem stops when
    its residual norm is <= ``tol`` or, from half of ``max_iterations`` on,
    >= ``give_up`` (unreachable or stuck). One problem (M = 1) is evaluated
    in plain floats instead of numpy arrays (same iteration, faster; results
    agree to round-off).

    Args:
      model: robot (its MDH table and joint limits).
      q0: (M, n) start joint angles, rad (clipped to the limits first).
      p_BE: (M, 3) target tool origins in B, m.
      z_BE: (M, 3) target unit z axes of E in B, or None.
      x_BE: (M, 3) target unit x axes of E (orthogonal to z_BE), or None; needs
        ``z_BE``.
      lever: distance of the direction points from the origin, m (weighs a
        direction error of 1 rad as ``lever`` m).
      tol: convergence threshold on the residual norm, m.
      max_iterations: largest number of steps.
      damping: constant part of lambda, m^2/rad^2.
      residual_damping: factor of |r|^2 in lambda, 1/rad^2. A lambda that
        shrinks with the residual (Yamashita and Fukushima's choice, factor 1)
        keeps the convergence quadratic where a constant one slows it down to
        linear: near singular configurations (wrist at q5 ~ 0), whose smallest
        singular value of J is comparable to sqrt(damping).
      max_step: largest joint move per step, rad.
      give_up: residual norm (m) above which a problem is dropped from half of
        ``max_iterations`` on; ``np.inf`` never drops one.

    Returns:
      :class:`ToolIK`: q, residual norm at q (m), steps taken and tool pose,
      per problem.
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
    points = kind(model.table, n, len(targets), lever)
    eye = np.eye(n)
    residual, X_BE = np.empty(M), np.empty((M, 4, 4))
    iterations, active = np.zeros(M, dtype=np.int64), np.arange(M)
    for it in range(max_iterations + 1):  # the last pass only evaluates
        at, state = points(q[active])
        r = at - target[active]
        norm = np.linalg.norm(r, axis=1)
        keep = (norm > tol) & (it < max_iterations)
        if it >= max_iterations // 2:
            keep &= norm < give_up
        if not keep.all():
            residual[active[~keep]] = norm[~keep]
            X_BE[active[~keep]] = points.pose(state, ~keep)
            active, r = active[keep], r[keep]
        if active.size == 0:
            break
        J = points.jacobian(state, keep)
        JtJ = np.einsum("mik,mil->mkl", J, J) + damping * eye
        if residual_damping:
            JtJ += (residual_damping * norm[keep] ** 2)[:, None, None] * eye
        step = -np.linalg.solve(JtJ, np.einsum("mik,mi->mk", J, r)[..., None])[..., 0]
        big = np.max(np.abs(step), axis=1, keepdims=True)
        step *= np.minimum(1.0, max_step / np.maximum(big, 1e-300))
        q[active] = np.clip(q[active] + step, lo, hi)
        iterations[active] += 1
    return ToolIK(q, residual, iterations, X_BE)
