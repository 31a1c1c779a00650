"""Point residuals of a laser tracker or motion capture, with the instrument's
pose and the markers as unknowns.

A marker k is fixed in the tool frame E at p_EM,k; the instrument measures it in
its own frame I, whose pose X_IB relative to the robot base B is unknown:

    p_I = R_IB p_BM(q) + p_IB,  p_BM(q) = p_BE(q) + R_BE(q) p_EM,k   (m)

with the robot's MDH table = nominal + error parameters ("deltas", rad or m,
at flat indices into ``table.ravel()``). :class:`PointProblem` is the least
squares form: unknowns ``x = [deltas (k), w (3), p_IB (3), p_EM,1 .. p_EM,M
(3 M)]`` where ``R_IB = Exp(w) R0`` is a rotation increment (rad, a rotation
vector in I) about a fixed estimate R0 (minimal and singularity-free near R0);
residual of row i: ``p_I,measured - p_I,predicted`` (3 per row, m, row-major).
Its Jacobian is analytic: the error parameters through
:func:`rmdrake.kinematics.forward.point_jacobian` with the row's marker, the rotation
through the left Jacobian of SO(3), translation and markers in closed form.

Elastic joints (elastostatic calibration, :mod:`rmdrake.calibration.elastostatic`):
the chain turns the link angles q_l = q + c * tau, with the joint torques tau
held fixed; unknown compliances c_j follow the deltas in x, and their columns
are joint j's offset column times tau_j of each row
(:class:`~rmdrake.calibration.elastostatic.ElasticJoints`).

:func:`initial_alignment` finds a start with no prior on X_IB or the markers:
block coordinate descent alternating the best rigid alignment (Kabsch) of the
predicted points to the measured ones and the linear least-squares markers
given that alignment, from markers at the tool origin.
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.elastostatic import ElasticJoints
from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.kinematics.compare import rigid_alignment
from rmdrake.kinematics.forward import pose_chunks, tool_poses
from rmdrake.kinematics.rotations import skew

__all__ = ["PointProblem", "initial_alignment", "predict_points", "so3_exp"]


def _so3_coefficients(theta: float) -> tuple[float, float, float]:
    """sin(t)/t, (1 - cos t)/t^2, (t - sin t)/t^3, with series near 0."""
    if theta < 1e-4:
        t2 = theta * theta
        return 1 - t2 / 6, 0.5 - t2 / 24, 1 / 6 - t2 / 120
    return (
        np.sin(theta) / theta,
        (1 - np.cos(theta)) / theta**2,
        (theta - np.sin(theta)) / theta**3,
    )


def so3_exp(w: np.ndarray) -> np.ndarray:
    """(3, 3) rotation Exp(w) of a rotation vector w (rad), Rodrigues."""
    a, b, _ = _so3_coefficients(float(np.linalg.norm(w)))
    W = skew(w)
    return np.eye(3) + a * W + b * W @ W


def so3_left_jacobian(w: np.ndarray) -> np.ndarray:
    """(3, 3) left Jacobian J_l(w) of SO(3): d Exp(w) v / dw = -[Exp(w) v]x
    J_l(w)."""
    _, b, c = _so3_coefficients(float(np.linalg.norm(w)))
    W = skew(w)
    return np.eye(3) + b * W + c * W @ W


def predict_points(
    table: np.ndarray,
    q: np.ndarray,
    p_EM: np.ndarray,
    R_IB: np.ndarray,
    p_IB: np.ndarray,
    *,
    sigma: np.ndarray | None = None,
) -> np.ndarray:
    """(N, 3) instrument readings p_I = R_IB (p_BE + R_BE p_EM) + p_IB, m, of a
    robot with MDH ``table`` at q (N, n) for the points p_EM (N, 3) in E."""
    X = tool_poses(table, q, sigma=sigma)
    p_BM = X[:, :3, 3] + np.einsum("nij,nj->ni", X[:, :3, :3], p_EM)
    return p_BM @ np.asarray(R_IB).T + p_IB


class PointProblem:
    """Point residuals with the instrument pose and the markers as unknowns
    (see the module docstring for the unknowns and the residual).

    Args:
      table: (n+1, 5) nominal MDH table (rad, m).
      data: the measured points.
      indices: (k,) flat table indices of the error parameters.
      R0: (3, 3) the rotation R_IB about which ``w`` is the increment.
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.
      elastic: ``torques``, ``compliance``, ``compliance_joints`` of elastic
        joints, as :class:`~rmdrake.calibration.elastostatic.ElasticJoints`
        (tau (N, n) in N m or N, c in rad/(N m) or m/N): ``x = [deltas (k_g),
        c (k_c), w, p_IB, markers]``; none: rigid.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PointLM, PointProblem, simulate_points
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=12, seed=0).data
    >>> lm = PointLM(robot, params="offsets").fit(data)
    >>> lm.markers_.shape, bool(lm.residual_rms_ < 1e-4)
    ((3, 3), True)
    """

    def __init__(
        self,
        table: np.ndarray,
        data: PointMeasurements,
        indices: np.ndarray,
        R0: np.ndarray,
        *,
        sigma: np.ndarray | None = None,
        **elastic: np.ndarray | None,
    ) -> None:
        self.table = np.array(table, dtype=np.float64)
        self.sigma = sigma
        self.q = np.asarray(data.q)
        self.p_I = np.asarray(data.p_I)
        self.indices = np.asarray(indices, dtype=np.intp)
        self.marker = data.marker_index
        self.n_markers = int(data.marker_ids.size)
        self.R0 = np.asarray(R0, dtype=np.float64)
        self.elastic = ElasticJoints(self.q, self.indices.size, sigma=sigma, **elastic)
        self.k = self.elastic.k

    @property
    def n_unknowns(self) -> int:
        """k + 6 + 3 M."""
        return self.k + 6 + 3 * self.n_markers

    def pack(
        self, deltas: np.ndarray, p_IB: np.ndarray, markers: np.ndarray
    ) -> np.ndarray:
        """x of the deltas (k,: the MDH deltas, then the unknown compliances),
        translation p_IB (3,, m) and markers (M, 3) (m, in E), with R_IB =
        R0."""
        return np.concatenate(
            [np.asarray(deltas, float), np.zeros(3), p_IB, np.ravel(markers)]
        )

    def unpack(
        self, x: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(deltas (k,), R_IB (3, 3), p_IB (3,), markers (M, 3)) of x."""
        k = self.k
        R = so3_exp(x[k : k + 3]) @ self.R0
        return x[:k], R, x[k + 3 : k + 6], x[k + 6 :].reshape(self.n_markers, 3)

    def table_of(self, deltas: np.ndarray) -> np.ndarray:
        """(n+1, 5) MDH table of the nominal plus ``deltas`` (their first k_g
        entries; compliances after them are ignored)."""
        flat = self.table.ravel().copy()
        flat[self.indices] += deltas[: self.indices.size]
        return flat.reshape(self.table.shape)

    def link_angles(self, x: np.ndarray) -> np.ndarray:
        """(N, n) joint positions the chain turns at x: q + c * tau (q when
        rigid), rad or m."""
        return self.elastic.link_angles(x)

    def predicted(self, x: np.ndarray) -> np.ndarray:
        """(N, 3) predicted readings in I, m."""
        deltas, R, p, markers = self.unpack(x)
        return predict_points(
            self.table_of(deltas),
            self.link_angles(x),
            markers[self.marker],
            R,
            p,
            sigma=self.sigma,
        )

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """(3 N,) measured minus predicted, m, row-major (x, y, z per row)."""
        return (self.p_I - self.predicted(x)).ravel()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(3 N, k + 6 + 3 M) analytic d residual / d x."""
        k = self.k
        deltas, R, _, markers = self.unpack(x)
        table = self.table_of(deltas)
        p_EM = markers[self.marker]
        q = self.link_angles(x)
        X = tool_poses(table, q, sigma=self.sigma)
        R_BE = X[:, :3, :3]
        p_BM = X[:, :3, 3] + np.einsum("nij,nj->ni", R_BE, p_EM)
        N = self.q.shape[0]
        J = np.zeros((N, 3, self.n_unknowns))
        for rows in pose_chunks(1, N) if k else ():  # only J stays
            J_pts = self.elastic.point_jacobian(
                table, q[rows], self.indices, rows, sigma=self.sigma, p_EM=p_EM[rows]
            )
            J[rows, :, :k] = np.einsum("ij,njk->nik", R, J_pts)
        # d (Exp(w) R0 p) / dw = -[R p]x J_l(w).
        J[:, :, k : k + 3] = -skew(p_BM @ R.T) @ so3_left_jacobian(x[k : k + 3])
        J[:, :, k + 3 : k + 6] = np.eye(3)
        R_IE = np.einsum("ij,njk->nik", R, R_BE)
        cols = k + 6 + 3 * self.marker[:, None] + np.arange(3)  # (N, 3)
        J[np.arange(N)[:, None, None], np.arange(3)[None, :, None], cols[:, None]] = (
            R_IE
        )
        np.negative(J, out=J)  # in place: J is the largest array here
        return J.reshape(3 * N, self.n_unknowns)


def _markers_given_pose(
    X_BE: np.ndarray,
    p_B: np.ndarray,
    marker: np.ndarray,
    n_markers: int,
) -> np.ndarray:
    """(M, 3) least-squares markers in E given measured points p_B (N, 3)
    expressed in B: the mean over each marker's rows of R_BE^T (p_B - p_BE)."""
    local = np.einsum("nji,nj->ni", X_BE[:, :3, :3], p_B - X_BE[:, :3, 3])
    sums = np.zeros((n_markers, 3))
    np.add.at(sums, marker, local)
    counts = np.bincount(marker, minlength=n_markers)[:, None]
    return sums / np.maximum(counts, 1)


def initial_alignment(
    table: np.ndarray,
    data: PointMeasurements,
    *,
    sigma: np.ndarray | None = None,
    iterations: int = 100,
    rtol: float = 1e-3,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A start for X_IB and the markers with no prior on either.

    Alternates (block coordinate descent, each step lowering the sum of
    squared point errors): the best rigid transform from the predicted points
    p_BM in B to the measured p_I (Kabsch), then each
    marker's least-squares position in E given that transform; from markers at
    the tool origin, until the RMS falls by less than a fraction ``rtol`` in
    an iteration (a start: the least-squares fit polishes it).

    Returns:
      (R_IB (3, 3), p_IB (3,), markers (M, 3)), m.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import initial_alignment, simulate_points
    >>> robot = load_robot("rv3sb")
    >>> sim = simulate_points(robot, poses=10, noise=0.0, seed=0)
    >>> R_IB, p_IB, markers = initial_alignment(robot.table, sim.data)
    >>> bool(abs(R_IB - sim.R_IB).max() < 1e-6), markers.shape
    (True, (3, 3))
    """
    X_BE = tool_poses(table, data.q, sigma=sigma)
    marker, M = data.marker_index, int(data.marker_ids.size)
    markers = np.zeros((M, 3))
    last = np.inf
    R_BE, p_BE = X_BE[:, :3, :3], X_BE[:, :3, 3]
    for _ in range(iterations):
        p_BM = p_BE + np.einsum("nij,nj->ni", R_BE, markers[marker])
        X = rigid_alignment(p_BM, data.p_I)
        R, p = X[:3, :3], X[:3, 3]
        markers = _markers_given_pose(X_BE, (data.p_I - p) @ R, marker, M)
        p_BM = p_BE + np.einsum("nij,nj->ni", R_BE, markers[marker])
        rms = float(np.sqrt(np.mean(np.sum((p_BM @ R.T + p - data.p_I) ** 2, 1))))
        if last - rms <= rtol * rms:
            break
        last = rms
    return R, p, markers
