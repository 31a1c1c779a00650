"""Vectorised modified-DH forward kinematics and error-parameter Jacobians.

Everything here works on the (n+1, 5) MDH table of :mod:`rmdrake.model.robot` (columns
``alpha, d, theta, r, beta``; last row = tool) or on a stack of P tables of shape
(P, n+1, 5), and on N joint vectors q of shape (N, n), with no Python loop over P
or N: the loop runs over the n+1 rows of the chain only. Internally rotation
matrices are stored component-first, (3, 3, P, N), so that every operation is an
elementwise product of contiguous (P, N) blocks.

Joint types: ``sigma`` (n,) is 0 for a revolute joint (q_j adds to theta_j) and
1 for a prismatic one (q_j adds to r_j, in m); None means all revolute. Every
function takes it as a keyword; pass ``model.sigma`` of a
:class:`~rmdrake.model.robot.RobotModel`.

Frames: B = robot base (frame 0 of the MDH chain), E = tool frame (row n+1). The
measurement point of a range finder reading ``distance`` (m) is
``p_BM = p_BE + distance * z_BE``, i.e. the reading adds to the tool r. The one
inverse kinematics of the tool frame, batched over targets, is
:func:`rmdrake.kinematics.ik.solve_tool_ik`.

Memory: the chain keeps a few (3, 3, P, N) blocks per row (about 1.5 kB per
joint vector on a 6-joint arm when the frames are kept), so
:func:`tool_poses`, :func:`tool_points`, :func:`point_jacobian` and
:func:`tool_jacobian` run it on at most :data:`CHUNK_POSES` (table, joint
vector) pairs at a time and fill their output chunk by chunk: memory is the
output's plus a bounded work space, and the values are those of one call
(every entry is computed by the same expression).
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.arrays import as_finite_array

if TYPE_CHECKING:
    pass

__all__ = [
    "CHUNK_POSES",
    "SinglePoseChain",
    "single_pose_chain",
    "chunk_slices",
    "link_frames",
    "point_jacobian",
    "pose_chunks",
    "robot_reach",
    "tool_jacobian",
    "tool_points",
    "tool_poses",
]


CHUNK_POSES = 16_384
"""Most (table, joint vector) pairs one pass of the chain evaluates: about
25 MB of work space with the frames kept (a 6-joint arm)."""


def chunk_slices(count: int, most: int) -> list[slice]:
    """Consecutive slices of ``count`` items in the fewest equal parts (sizes
    differing by at most one) of at most ``most`` items each: with ``most``
    >= 3, no part holds a single item unless ``count`` is 1. One empty slice
    when ``count`` is 0."""
    parts = max(1, -(-count // max(1, most)))
    ends = [count * i // parts for i in range(parts + 1)]
    return [slice(a, b) for a, b in zip(ends[:-1], ends[1:], strict=True)]


def pose_chunks(n_tables: int, n_poses: int) -> list[slice]:
    """:func:`chunk_slices` of the N = ``n_poses`` joint vectors such that
    each slice holds at most :data:`CHUNK_POSES` (table, joint vector) pairs
    with ``n_tables`` tables (at least one vector); one slice when all fit."""
    return chunk_slices(n_poses, max(1, CHUNK_POSES // max(1, n_tables)))


def robot_reach(robot: object) -> float:
    """A bound on the distance from the base to the tool, and the robot's size,
    m: the sum of |d| and |r| over the MDH rows (tool included) plus, for a
    :class:`~rmdrake.model.robot.RobotModel`, each prismatic joint's largest |q|
    within its limits. ``robot``: a RobotModel or an (n+1, 5) table.

    Example:

    >>> from rmdrake import load_robot, robot_reach
    >>> round(robot_reach(load_robot("rv3sb")), 2)
    1.18
    """
    table = np.asarray(getattr(robot, "table", robot), dtype=np.float64)
    reach = float(np.sum(np.abs(table[:, [1, 3]])))
    sigma = getattr(robot, "sigma", None)
    if sigma is not None and np.any(sigma == 1):
        lim = robot.limits  # type: ignore[attr-defined]
        travel = np.maximum(np.abs(lim.lower), np.abs(lim.upper))
        reach += float(np.sum(travel[sigma == 1]))
    return reach


def _sigma(sigma: object, n: int) -> np.ndarray:
    """(n,) bool, True for prismatic joints, from ``sigma`` (None: revolute)."""
    if sigma is None:
        return np.zeros(n, dtype=bool)
    s = np.asarray(sigma)
    if s.shape != (n,) or not np.all((s == 0) | (s == 1)):
        raise ValueError(f"sigma: expected {n} values 0 (revolute) or 1 (prismatic)")
    return s == 1


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
        raise ValueError(f"q: expected shape (N, {n}) in rad or m, found {np.shape(q)}")
    return table, q, batched


def static_rotations(table: np.ndarray) -> np.ndarray:
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


def mdh_chain(
    table: np.ndarray,
    q: np.ndarray,
    keep: bool,
    S_all: np.ndarray | None = None,
    prismatic: np.ndarray | None = None,
):
    """Runs the MDH chain. Returns R (3,3,P,N), p (3,P,N) of the last row and,
    if ``keep``, per row j the tuple (R_{j-1}, p_{j-1}, x'_j, R_j, p_j).

    Rows past the joints of q (the tool, and any fixed row after it) get no
    joint variable; ``prismatic`` (nq,) bool says where q_j adds to r_j
    instead of theta_j (None: all revolute). ``S_all`` (from
        :func:`static_rotations`) may be passed by a caller that runs the chain of one
    table many times; computing it here or
    there gives the same bits (each entry is the same expression).
    """
    P, N = table.shape[0], q.shape[0]
    nq = q.shape[1]
    # Per-row views: d[j], theta[j], r[j] of shape (P, 1); q_rows[j] (1, N).
    d, theta, r = (table[:, :, k].T[:, :, None] for k in (1, 2, 3))
    q_rows = q.T[:, None, :]
    if S_all is None:
        S_all = static_rotations(table)
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
        slide = j < nq and prismatic is not None and prismatic[j]
        turn = j < nq and not slide
        p = p + M0 * d[j] + M2 * (r[j] + q_rows[j] if slide else r[j])
        th = theta[j] + q_rows[j] if turn else theta[j]
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


class SinglePoseChain:
    """The MDH chain of one table at one pose in plain Python floats: the frames
    of :func:`mdh_chain` without numpy's per-call overhead (about 15 times
    faster for one pose, what a controller or a one-target IK evaluates). The
    same products, summed in another order: equal to round-off, not to the bit.

    Each row carries the index of the q entry added to its theta and to its r
    (n, the index of an appended 0.0, where none is): q_j goes to theta_j for a
    revolute joint, to r_j for a prismatic one.

    Args:
      table: (rows, 5) MDH table (rows >= n; rows past the joints are fixed).
      n: number of joints.
      slide: (n,) bool, True for a prismatic joint.
    """

    def __init__(self, table: np.ndarray, n: int, slide: np.ndarray) -> None:
        self.n = n
        S = static_rotations(table[None])[..., 0].reshape(-1, 9)
        # Rows past the joints (the tool) get the appended zero in both.
        at_theta, at_r = np.full(table.shape[0], n), np.full(table.shape[0], n)
        at_theta[:n] = np.where(slide, n, np.arange(n))
        at_r[:n] = np.where(slide, np.arange(n), n)
        columns = (*table[:, 1:4].T.tolist(), at_theta.tolist(), at_r.tolist())
        self.rows = list(zip(S.tolist(), *columns, strict=True))
        self.slides = np.flatnonzero(slide).tolist()

    def __call__(self, q: object) -> tuple[tuple, tuple, list]:
        """(R, p, axes) at joint positions q (n,) (rad or m): the last row's
        rotation R_B (rows (x0, y0, z0), (x1, y1, z1), (x2, y2, z2)) and origin p
        (m), and per joint (z_j, o_j) as (zx, zy, zz, ox, oy, oz)."""
        qs = np.asarray(q, dtype=np.float64).tolist() + [0.0]
        x0, y0, z0, x1, y1, z1, x2, y2, z2 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        px = py = pz = 0.0
        axes = []  # (z_j, o_j) of the joints
        for j, ((a, b, c, d, e, f, g, h, i), dj, theta, r, jt, jr) in enumerate(
            self.rows
        ):
            rj = r + qs[jr]
            # M = R S, then p += d x'_j + r z_j and R = M Rot_z(theta): rows of R
            # are x0 y0 z0 / x1 y1 z1 / x2 y2 z2, S = a b c / d e f / g h i.
            # fmt: off
            x0, y0, z0 = x0*a + y0*d + z0*g, x0*b + y0*e + z0*h, x0*c + y0*f + z0*i
            x1, y1, z1 = x1*a + y1*d + z1*g, x1*b + y1*e + z1*h, x1*c + y1*f + z1*i
            x2, y2, z2 = x2*a + y2*d + z2*g, x2*b + y2*e + z2*h, x2*c + y2*f + z2*i
            px, py, pz = px + x0*dj + z0*rj, py + x1*dj + z1*rj, pz + x2*dj + z2*rj
            # fmt: on
            th = theta + qs[jt]
            cs, sn = math.cos(th), math.sin(th)
            x0, y0 = x0 * cs + y0 * sn, y0 * cs - x0 * sn
            x1, y1 = x1 * cs + y1 * sn, y1 * cs - x1 * sn
            x2, y2 = x2 * cs + y2 * sn, y2 * cs - x2 * sn
            if j < self.n:
                axes.append((z0, z1, z2, px, py, pz))
        return ((x0, y0, z0), (x1, y1, z1), (x2, y2, z2)), (px, py, pz), axes

    def point_columns(self, axes: list, point: tuple) -> list[list[float]]:
        """d point / d q (3 rows of n, m/rad or m/m) from ``axes``: z_j x (point -
        o_j) for a revolute joint, z_j for a prismatic one."""
        x, y, z = point
        cols = [(x - ox, y - oy, z - oz, ax, ay, az) for ax, ay, az, ox, oy, oz in axes]
        J = [
            [ay * w - az * v for u, v, w, ax, ay, az in cols],
            [az * u - ax * w for u, v, w, ax, ay, az in cols],
            [ax * v - ay * u for u, v, w, ax, ay, az in cols],
        ]
        for j in self.slides:
            for c in range(3):
                J[c][j] = axes[j][c]
        return J

    def tool_jacobian(self, axes: list, p: tuple) -> np.ndarray:
        """The geometric Jacobian (6, n) of the last row's frame at ``axes``
        and its origin ``p`` (from a call): rows [w; v] in B, a revolute joint's
        column [z_j; z_j x (p - o_j)] (per rad/s), a prismatic one's [0; z_j]
        (per m/s)."""
        J = np.array(
            [[a[k] for a in axes] for k in range(3)] + self.point_columns(axes, p)
        )
        J[:3, self.slides] = 0.0
        return J


@functools.lru_cache(maxsize=64)
def _cached_chain(table: bytes, rows: int, n: int, slide: bytes) -> SinglePoseChain:
    return SinglePoseChain(
        np.frombuffer(table).reshape(rows, 5), n, np.frombuffer(slide, dtype=bool)
    )


def single_pose_chain(table: np.ndarray, n: int, slide: np.ndarray) -> SinglePoseChain:
    """The :class:`SinglePoseChain` of ``table`` (rows, 5) with joint types
    ``slide`` (n,) bool, built once per distinct table: a controller or a
    one-target IK evaluates the same few tables thousands of times."""
    table = np.ascontiguousarray(table, dtype=np.float64)
    slide = np.ascontiguousarray(slide, dtype=bool)
    return _cached_chain(table.tobytes(), table.shape[0], n, slide.tobytes())


def link_frames(
    table: np.ndarray, q: np.ndarray, *, sigma: object = None
) -> tuple[np.ndarray, np.ndarray]:
    """Poses X_Bj of every MDH frame j = 1..n+1 (the last is the tool E).

    Args:
      table: (n+1, 5) MDH table; q: (N, n) joint positions, rad or m.
      sigma: (n,) joint types; None = all revolute.

    Returns:
      (R, p): R (n+1, 3, 3, N) rotations R_Bj, p (n+1, 3, N) origins p_Bj in
      m, component-first (R[j, :, 2] is z_j of every pose).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.kinematics import link_frames
    >>> robot = load_robot("rv3sb")
    >>> R, p = link_frames(robot.table, np.zeros((1, 6)))
    >>> R.shape, p.shape
    ((7, 3, 3, 1), (7, 3, 1))
    """
    table, q, _ = _inputs(table, q)
    _, _, frames = mdh_chain(table, q, True, None, _sigma(sigma, q.shape[1]))
    R = np.stack([f[3][:, :, 0] for f in frames])
    p = np.stack([f[4][:, 0] for f in frames])
    return R, p


def _point(R: np.ndarray, p: np.ndarray, distance: np.ndarray | None) -> np.ndarray:
    """p_BM of the tool frame (R, p) and an offset: None (M = E), (N,) along z_E
    (a range reading), or (N, 3) p_EM in E."""
    if distance is None:
        return p
    if distance.ndim == 2:
        return p + np.einsum("ijpn,nj->ipn", R, distance)
    return p + R[:, 2] * distance


def _distance(distance: object, N: int, p_EM: object = None) -> np.ndarray | None:
    """The point offset of :func:`_point`: (N,) readings or (N, 3) p_EM."""
    if p_EM is not None:
        if distance is not None:
            raise ValueError("give either distance or p_EM, not both")
        m = as_finite_array(p_EM, "p_EM", None)
        if m.shape == (3,):
            m = np.broadcast_to(m, (N, 3))
        if m.shape != (N, 3):
            raise ValueError(f"p_EM: expected shape (3,) or ({N}, 3) in m")
        return np.ascontiguousarray(m)
    if distance is None:
        return None
    d = as_finite_array(distance, "distance", None)
    if d.ndim == 0:
        d = np.full(N, float(d))
    if d.shape != (N,):
        raise ValueError(f"distance: expected shape ({N},) in m, found {d.shape}")
    return d


def tool_poses(table: np.ndarray, q: np.ndarray, *, sigma: object = None) -> np.ndarray:
    """Homogeneous tool poses X_BE (one pose of one table by
    :class:`SinglePoseChain`: equal to the batch's to round-off).

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables (rad, m).
      q: (N, n) joint positions, rad or m (a single (n,) vector is N = 1).
      sigma: (n,) joint types (see module docstring); None = all revolute.

    Returns:
      (N, 4, 4) for one table, (P, N, 4, 4) for a stack.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_poses
    >>> robot = load_robot("rv3sb")
    >>> X_BE = tool_poses(robot.table, np.zeros((2, 6)), sigma=robot.sigma)
    >>> X_BE.shape, (X_BE[0, :3, 3].round(3) + 0.0).tolist()
    ((2, 4, 4), [0.45, 0.0, 0.73])
    """
    table, q, batched = _inputs(table, q)
    if table.shape[0] == 1 and q.shape[0] == 1:  # one pose: plain floats
        n = q.shape[1]
        R, p, _ = single_pose_chain(table[0], n, _sigma(sigma, n))(q[0])
        X = np.eye(4)
        X[:3, :3], X[:3, 3] = R, p
        return X[None, None] if batched else X[None]
    slide, S_all = _sigma(sigma, q.shape[1]), static_rotations(table)
    P, N = table.shape[0], q.shape[0]
    X = np.zeros((P, N, 4, 4))
    for rows in pose_chunks(P, N):
        R, p, _ = mdh_chain(table, q[rows], False, S_all, slide)
        X[:, rows, :3, :3] = np.moveaxis(R, (0, 1), (2, 3))
        X[:, rows, :3, 3] = np.moveaxis(p, 0, 2)
    X[..., 3, 3] = 1.0
    return X if batched else X[0]


def tool_points(
    table: np.ndarray,
    q: np.ndarray,
    distance: object = None,
    *,
    sigma: object = None,
    p_EM: object = None,
) -> np.ndarray:
    """Measurement points p_BM = p_BE + distance * z_BE, or p_BE + R_BE p_EM,
    in m.

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables.
      q: (N, n) joint positions, rad or m.
      distance: None (the tool point itself), a scalar or (N,) range readings, m.
      sigma: (n,) joint types; None = all revolute.
      p_EM: instead of ``distance``, points fixed in the tool frame E (a marker
        or a tracker target), (3,) or (N, 3), m.

    Returns:
      (N, 3) for one table, (P, N, 3) for a stack.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> robot = load_robot("rv3sb")
    >>> p_BM = tool_points(robot.table, np.zeros((2, 6)), distance=[0.1, 0.2])
    >>> p_BM.shape
    (2, 3)
    """
    table, q, batched = _inputs(table, q)
    dist = _distance(distance, q.shape[0], p_EM)
    slide, S_all = _sigma(sigma, q.shape[1]), static_rotations(table)
    out = np.empty((table.shape[0], q.shape[0], 3))
    for rows in pose_chunks(*out.shape[:2]):
        R, p, _ = mdh_chain(table, q[rows], False, S_all, slide)
        at = None if dist is None else dist[rows]
        out[:, rows] = np.moveaxis(_point(R, p, at), 0, -1)
    return out if batched else out[0]


def point_jacobian(
    table: np.ndarray,
    q: np.ndarray,
    indices: np.ndarray,
    distance: object = None,
    *,
    sigma: object = None,
    p_EM: object = None,
) -> np.ndarray:
    """Analytic Jacobian of the measurement point w.r.t. table entries.

    ``indices`` are flat indices into ``table.ravel()`` (see
    :func:`rmdrake.model.error_parameters.error_parameter_indices`). With the screw of
    each entry:
    alpha_j rotates about x'_j (= R_{j-1} Rot_y(beta_j) e_x) through o_{j-1}, d_j
    translates along x'_j, theta_j rotates about z_j through o_j, r_j translates
    along z_j, beta_j rotates about y_{j-1} through o_{j-1}. The screws are
    the same for prismatic joints (their q adds to r_j).

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables.
      q: (N, n) joint positions, rad or m.
      indices: (k,) flat table indices.
      distance, p_EM: as in :func:`tool_points`.
      sigma: (n,) joint types; None = all revolute.

    Returns:
      d p_BM / d param, (N, 3, k) or (P, N, 3, k): m/rad or m/m.

    Example:

    >>> import numpy as np
    >>> from rmdrake import error_parameter_indices, error_parameter_names, load_robot
    >>> from rmdrake import point_jacobian
    >>> robot = load_robot("rv3sb")
    >>> names = error_parameter_names(robot)
    >>> indices = error_parameter_indices(robot, names)
    >>> J = point_jacobian(robot.table, np.zeros((4, 6)), indices)
    >>> J.shape
    (4, 3, 17)
    """
    table, q, batched = _inputs(table, q)
    n1 = table.shape[1]
    indices = np.asarray(indices, dtype=np.intp).ravel()
    if indices.size and (indices.min() < 0 or indices.max() >= 5 * n1):
        raise ValueError(f"indices: expected values in 0..{5 * n1 - 1}")
    dist = _distance(distance, q.shape[0], p_EM)
    slide, S_all = _sigma(sigma, q.shape[1]), static_rotations(table)
    out = np.empty((table.shape[0], q.shape[0], 3, indices.size))
    for rows in pose_chunks(*out.shape[:2]):
        R, p, frames = mdh_chain(table, q[rows], True, S_all, slide)
        pm = _point(R, p, None if dist is None else dist[rows])
        J = np.empty((3, *pm.shape[1:], indices.size))
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
        out[:, rows] = np.moveaxis(J, 0, -2)
    return out if batched else out[0]


def tool_jacobian(
    table: np.ndarray, q: np.ndarray, *, sigma: object = None
) -> np.ndarray:
    """Geometric Jacobian of the tool frame E w.r.t. the joint positions, in B
    (one pose of one table by :class:`SinglePoseChain`: equal to the batch's to
    round-off).

    Rows [w_BE; v_BE]: a revolute joint j turns about z_j through o_j, so its
    column is [z_j; z_j x (p_BE - o_j)] (per rad/s); a prismatic joint slides
    along z_j, so its column is [0; z_j] (per m/s).

    Args:
      table: (n+1, 5) or (P, n+1, 5) MDH tables; q: (N, n) joint positions.
      sigma: (n,) joint types; None = all revolute.

    Returns:
      (N, 6, n) or (P, N, 6, n).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_jacobian
    >>> robot = load_robot("rv3sb")
    >>> tool_jacobian(robot.table, np.zeros(6)).shape
    (1, 6, 6)
    """
    table, q, batched = _inputs(table, q)
    n = q.shape[1]
    if table.shape[0] == 1 and q.shape[0] == 1:  # one pose: plain floats
        chain = single_pose_chain(table[0], n, _sigma(sigma, n))
        _, p, axes = chain(q[0])
        J = chain.tool_jacobian(axes, p)
        return J[None, None] if batched else J[None]
    slide, S_all = _sigma(sigma, n), static_rotations(table)
    out = np.empty((table.shape[0], q.shape[0], 6, n))
    for rows in pose_chunks(*out.shape[:2]):
        _, _, frames = mdh_chain(table, q[rows], True, S_all, slide)
        p_E = frames[n][4]
        z = np.stack([frames[j][3][:, 2] for j in range(n)], axis=1)  # (3,n,P,N)
        o = np.stack([frames[j][4] for j in range(n)], axis=1)
        lin = np.cross(z, p_E[:, None] - o, axis=0)
        lin[:, slide] = z[:, slide]
        z[:, slide] = 0.0
        J = np.concatenate([z, lin], axis=0)
        out[:, rows] = np.moveaxis(J, (0, 1), (-2, -1))
    return out if batched else out[0]
