"""Pose residuals of a 6-DoF instrument, with the instrument's pose X_IB and
the marker's pose X_FM on the flange as unknowns (hand-eye).

The instrument measures the marker frame M on the tool in its own frame I:

    X_IM = X_IB X_BF(q) X_FM,   R_IM = R_IB R_BF R_FM,
    p_IM = R_IB (p_BF + R_BF p_FM) + p_IB   (m)

with X_BF(q) the pose of the flange F (the MDH chain's tool frame, the last
row of the table) in the base B, of the robot whose MDH table is the nominal
plus error parameters ("deltas", rad or m, at flat indices into
``table.ravel()``). :class:`PoseProblem` is the least-squares form: unknowns
``x = [deltas (k), w_IB (3), p_IB (3), w_FM (3), p_FM (3)]`` with
``R_IB = Exp(w_IB) R0_IB`` (a rotation increment in I, rad) and
``R_FM = Exp(w_FM) R0_FM`` (in F) about fixed estimates R0 (minimal and
singularity-free near them); the residual of row i is 6 numbers:

    e_p = (p_IM,predicted - p_IM,measured) / sigma_p          (m / m)
    e_r = Log(R_IM,measured^T R_IM,predicted) / sigma_r       (rad / rad)

(e_r a rotation vector in the measured marker frame), row-major (e_p then
e_r per row). The Jacobian is analytic: the error parameters through the
twist of the flange in B from the MDH frames
(:func:`rmdrake.kinematics.forward.link_frames`, the screws of
:func:`rmdrake.kinematics.forward.point_jacobian`), the rotations through the
left Jacobian of SO(3) and the orientation residual through the inverse right
Jacobian at e_r.

:func:`initial_alignment` finds a start with no prior on X_IB or X_FM: the
rotations from the null vector of the linear system R_IB R_BF,i = R_IM,i
R_FM^T (stacked over readings, Kronecker form, projected onto SO(3)), then
the translations by linear least squares.

Example::

    from rmdrake.calibration.poses.problem import initial_alignment
    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    sim = simulate_poses(model, poses=20, noise_p=0, noise_r=0)
    X_IB, X_FM = initial_alignment(model.table, sim.data)  # == sim.X_IB, sim.X_FM
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.so3 import (
    so3_exp_many,
    so3_left_jacobian_many,
    so3_log_many,
    so3_right_jacobian_inverse_many,
)
from rmdrake.kinematics.forward import link_frames, pose_chunks, tool_poses
from rmdrake.kinematics.rotations import skew

__all__ = ["PoseProblem", "flange_twist_jacobian", "initial_alignment", "predict_poses"]


def predict_poses(
    table: np.ndarray,
    q: np.ndarray,
    X_IB: np.ndarray,
    X_FM: np.ndarray,
    *,
    sigma: np.ndarray | None = None,
) -> np.ndarray:
    """(N, 4, 4) instrument readings X_IM = X_IB X_BF(q) X_FM of a robot with
    MDH ``table`` at q (N, n) (rad or m), X_IB and X_FM (4, 4) homogeneous, m."""
    return np.asarray(X_IB) @ tool_poses(table, q, sigma=sigma) @ np.asarray(X_FM)


def flange_twist_jacobian(
    table: np.ndarray,
    q: np.ndarray,
    indices: np.ndarray,
    p_FM: np.ndarray,
    *,
    sigma: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The derivatives of the marker pose in B with respect to table entries.

    With the screws of :func:`rmdrake.kinematics.forward.point_jacobian`:
    alpha_j turns about x'_j through o_{j-1}, d_j slides along x'_j, theta_j
    turns about z_j through o_j, r_j slides along z_j, beta_j turns about
    y_{j-1} through o_{j-1}.

    Args:
      table: (n+1, 5) MDH table; q: (N, n) joint positions, rad or m.
      indices: (k,) flat table indices.
      p_FM: (3,) marker position in F, m.
      sigma: (n,) joint types; None = all revolute.

    Returns:
      (X_BF (N, 4, 4), d p_BM / d param (N, 3, k) in m/rad or m/m,
      d phi_B / d param (N, 3, k): the rotation of the flange in B, rad/rad
      or rad/m).
    """
    table = np.asarray(table, dtype=np.float64)
    indices = np.asarray(indices, dtype=np.intp)
    R, p = link_frames(table, q, sigma=sigma)  # (n+1, 3, 3, N), (n+1, 3, N)
    N = p.shape[-1]
    R_BF = np.moveaxis(R[-1], -1, 0)
    X = np.zeros((N, 4, 4))
    X[:, :3, :3], X[:, :3, 3], X[:, 3, 3] = R_BF, p[-1].T, 1.0
    p_M = p[-1] + np.einsum("ijn,j->in", R[-1], np.asarray(p_FM, float))  # (3, N)
    lin = np.zeros((3, N, indices.size))
    ang = np.zeros((3, N, indices.size))
    eye = np.broadcast_to(np.eye(3)[:, :, None], (3, 3, N))
    for c, flat in enumerate(indices):
        row, kind = divmod(int(flat), 5)
        R_prev = R[row - 1] if row else eye
        p_prev = p[row - 1] if row else np.zeros((3, N))
        if kind in (0, 1):  # x'_j = R_{j-1} Rot_y(beta_j) e_x
            beta = table[row, 4]
            axis = R_prev[:, 0] * np.cos(beta) - R_prev[:, 2] * np.sin(beta)
            lin[..., c] = np.cross(axis, p_M - p_prev, axis=0) if kind == 0 else axis
            ang[..., c] = axis if kind == 0 else 0.0
        elif kind in (2, 3):
            axis = R[row][:, 2]
            lin[..., c] = np.cross(axis, p_M - p[row], axis=0) if kind == 2 else axis
            ang[..., c] = axis if kind == 2 else 0.0
        else:
            axis = R_prev[:, 1]
            lin[..., c] = np.cross(axis, p_M - p_prev, axis=0)
            ang[..., c] = axis
    return X, np.moveaxis(lin, 0, 1), np.moveaxis(ang, 0, 1)


class PoseProblem:
    """Pose residuals with the instrument pose X_IB and the marker pose X_FM
    as unknowns (see the module docstring for the unknowns and the residual).

    Args:
      table: (n+1, 5) nominal MDH table (rad, m).
      data: the measured poses.
      indices: (k,) flat table indices of the error parameters.
      R0_IB, R0_FM: (3, 3) the rotations about which ``w_IB`` and ``w_FM``
        are the increments.
      sigma_p: m, the standard deviation of each position coordinate.
      sigma_r: rad, that of each component of the orientation error.
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.
    """

    def __init__(
        self,
        table: np.ndarray,
        data: PoseMeasurements,
        indices: np.ndarray,
        R0_IB: np.ndarray,
        R0_FM: np.ndarray,
        *,
        sigma_p: float = 1.0,
        sigma_r: float = 1.0,
        sigma: np.ndarray | None = None,
    ) -> None:
        if not (sigma_p > 0 and sigma_r > 0):
            raise ValueError(
                f"sigma_p, sigma_r: expected positive noises, found {sigma_p}, "
                f"{sigma_r}"
            )
        self.table = np.array(table, dtype=np.float64)
        self.sigma = sigma
        self.q = np.asarray(data.q)
        self.p_IM = np.asarray(data.p_IM)
        self.R_IM = data.R_IM
        self.indices = np.asarray(indices, dtype=np.intp)
        self.k = int(self.indices.size)
        self.R0_IB = np.asarray(R0_IB, dtype=np.float64)
        self.R0_FM = np.asarray(R0_FM, dtype=np.float64)
        self.sigma_p = float(sigma_p)
        self.sigma_r = float(sigma_r)

    @property
    def n_unknowns(self) -> int:
        """k + 12."""
        return self.k + 12

    def pack(
        self, deltas: np.ndarray, p_IB: np.ndarray, p_FM: np.ndarray
    ) -> np.ndarray:
        """x of the deltas (k,), p_IB (3,, m) and p_FM (3,, m), with R_IB =
        R0_IB and R_FM = R0_FM."""
        z = np.zeros(3)
        return np.concatenate([np.asarray(deltas, float), z, p_IB, z, p_FM])

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(deltas (k,), X_IB (4, 4), X_FM (4, 4)) of x."""
        k = self.k
        X_IB, X_FM = np.eye(4), np.eye(4)
        X_IB[:3, :3] = so3_exp_many(x[k : k + 3]) @ self.R0_IB
        X_IB[:3, 3] = x[k + 3 : k + 6]
        X_FM[:3, :3] = so3_exp_many(x[k + 6 : k + 9]) @ self.R0_FM
        X_FM[:3, 3] = x[k + 9 : k + 12]
        return x[:k], X_IB, X_FM

    def table_of(self, deltas: np.ndarray) -> np.ndarray:
        """(n+1, 5) MDH table of the nominal plus ``deltas``."""
        flat = self.table.ravel().copy()
        flat[self.indices] += deltas
        return flat.reshape(self.table.shape)

    def predicted(self, x: np.ndarray) -> np.ndarray:
        """(N, 4, 4) predicted readings X_IM, m."""
        deltas, X_IB, X_FM = self.unpack(x)
        return predict_poses(
            self.table_of(deltas), self.q, X_IB, X_FM, sigma=self.sigma
        )

    def errors(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """((N, 3) position errors p_pred - p_meas in I, m; (N, 3) orientation
        errors Log(R_meas^T R_pred) in M, rad), unweighted."""
        X = self.predicted(x)
        e_r = so3_log_many(np.swapaxes(self.R_IM, -1, -2) @ X[:, :3, :3])
        return X[:, :3, 3] - self.p_IM, e_r

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """(6 N,) weighted residuals, row-major (e_p / sigma_p, e_r / sigma_r
        per row)."""
        e_p, e_r = self.errors(x)
        return np.hstack([e_p / self.sigma_p, e_r / self.sigma_r]).ravel()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(6 N, k + 12) analytic d residual / d x."""
        k = self.k
        deltas, X_IB, X_FM = self.unpack(x)
        table = self.table_of(deltas)
        R_IB, R_FM, p_FM = X_IB[:3, :3], X_FM[:3, :3], X_FM[:3, 3]
        N = self.q.shape[0]
        J = np.zeros((N, 6, self.n_unknowns))
        for rows in pose_chunks(1, N):
            X_BF, lin, ang = flange_twist_jacobian(
                table, self.q[rows], self.indices, p_FM, sigma=self.sigma
            )
            R_BF = X_BF[:, :3, :3]
            R_IF = R_IB @ R_BF
            R_pred = R_IF @ R_FM
            p_BM = X_BF[:, :3, 3] + R_BF @ p_FM
            e_r = so3_log_many(np.swapaxes(self.R_IM[rows], -1, -2) @ R_pred)
            # d e_r = J_r(e_r)^-1 R_pred^T d phi_I for R_pred -> Exp(d phi_I) R_pred.
            G = so3_right_jacobian_inverse_many(e_r) @ np.swapaxes(R_pred, -1, -2)
            Jl_IB = so3_left_jacobian_many(x[k : k + 3])
            Jl_FM = so3_left_jacobian_many(x[k + 6 : k + 9])
            Jr = J[rows]
            Jr[:, :3, :k] = np.einsum("ij,njk->nik", R_IB, lin)
            Jr[:, 3:, :k] = G @ R_IB @ ang
            Jr[:, :3, k : k + 3] = -skew(p_BM @ R_IB.T) @ Jl_IB
            Jr[:, 3:, k : k + 3] = G @ Jl_IB
            Jr[:, :3, k + 3 : k + 6] = np.eye(3)
            Jr[:, 3:, k + 6 : k + 9] = G @ R_IF @ Jl_FM
            Jr[:, :3, k + 9 : k + 12] = R_IF
        J[:, :3] /= self.sigma_p
        J[:, 3:] /= self.sigma_r
        return J.reshape(6 * N, self.n_unknowns)


def _project_so3(M: np.ndarray) -> np.ndarray:
    """The rotation nearest (Frobenius) to a (3, 3) matrix."""
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def initial_alignment(
    table: np.ndarray, data: PoseMeasurements, *, sigma: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """A start (X_IB, X_FM), (4, 4) each, m, with no prior on either: the
    hand-eye solution of the module docstring at the model of ``table``
    (exact for noise-free readings of that model)."""
    X_BF = tool_poses(table, data.q, sigma=sigma)
    A, B = data.R_IM, X_BF[:, :3, :3]
    # R_IB B_i - A_i Z = 0 with Z = R_FM^T; vec column-major:
    # vec(Y B) = (B^T kron I) vec Y, vec(A Z) = (I kron A) vec Z.
    N = A.shape[0]
    I3 = np.eye(3)
    K1 = np.einsum("nba,ij->naibj", B, I3).reshape(N, 9, 9)  # B^T kron I
    K2 = np.einsum("ab,nij->naibj", I3, A).reshape(N, 9, 9)  # I kron A
    M = np.concatenate([K1, -K2], axis=2)  # (N, 9, 18)
    _, vecs = np.linalg.eigh(np.einsum("nij,nik->jk", M, M))
    v = vecs[:, 0]
    Y = v[:9].reshape(3, 3, order="F")
    Z = v[9:].reshape(3, 3, order="F")
    if np.linalg.det(Y) < 0:
        Y, Z = -Y, -Z
    R_IB, R_FM = _project_so3(Y), _project_so3(Z).T
    # p_IM = R_IB p_BF + R_IB R_BF p_FM + p_IB: linear in (p_IB, p_FM).
    R_IF = R_IB @ B
    lhs = np.concatenate([np.broadcast_to(I3, (N, 3, 3)), R_IF], axis=2).reshape(-1, 6)
    rhs = (data.p_IM - X_BF[:, :3, 3] @ R_IB.T).ravel()
    sol, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
    X_IB, X_FM = np.eye(4), np.eye(4)
    X_IB[:3, :3], X_IB[:3, 3] = R_IB, sol[:3]
    X_FM[:3, :3], X_FM[:3, 3] = R_FM, sol[3:]
    return X_IB, X_FM
