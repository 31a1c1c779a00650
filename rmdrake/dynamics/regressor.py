"""The joint-torque regressor Y(q, qd, qdd) of a revolute serial chain.

    tau = Y(q, qd, qdd) @ chi

for the rigid-body inverse dynamics (gravity included), plus the rotor inertia
Ia_j * qdd_j, plus friction fv_j * qd_j + fc_j * sign(qd_j), with chi the link-major
standard parameters of :mod:`rmdrake.dynamics.parameters` (13 per link).

Method. In each link's canonical frame K_k (joint axis = z through the origin, see
:mod:`rmdrake.dynamics.chain`) a forward recursion gives the angular velocity w_k,
angular acceleration wd_k and the acceleration a_k of the origin minus gravity,
together with the columns S_jk (j <= k) of the body Jacobian of link k: the unit
twist of joint j expressed in K_k (angular part, linear velocity of Ko). The
wrench of link k about Ko in K_k is linear in its 10 inertial parameters,

    n = I wd + w x (I w) + c x a,   f = m a + wd x c + w x (w x c),

i.e. (n; f) = A_k(w, wd, a) @ phi_k with a 6x10 matrix A_k, and by the principle
of virtual power tau_j = sum_{k >= j} S_jk^T (n; f)_k, so the (j, k) block of Y is
S_jk^T A_k. Only the blocks j <= k are non-zero (link k acts on joints 1..k).

Layout. Everything is component-first with samples last ((6, slots, N) arrays,
as in :mod:`rmdrake.kinematics`), so every operation is one numpy call on a
contiguous block of all samples: the constant part of each joint transform is one
BLAS product, the block S^T A of a link one ``einsum``, written straight into a
transposed view of the (N, n, 13n) output. The only Python loop is over joints.
sign(0) = 0: a joint at rest has no Coulomb torque in the regressor.
"""

from __future__ import annotations

import numpy as np

from rmdrake.dynamics.chain import SerialChain
from rmdrake.dynamics.parameters import N_PER_LINK
from rmdrake.io import as_finite_array
from rmdrake.robot import RobotModel

__all__ = ["regressor", "regressor_columns", "torques"]


def _chain(chain: SerialChain | RobotModel) -> SerialChain:
    if isinstance(chain, RobotModel):
        return SerialChain.from_model(chain)
    if not isinstance(chain, SerialChain):
        raise TypeError(
            f"chain: expected a SerialChain or RobotModel, found {type(chain).__name__}"
        )
    return chain


def _states(
    n: int, q: object, qd: object, qdd: object
) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """(n, N) contiguous copies of the three joint arrays; True if 1-D input."""
    out = []
    single = False
    shape = None
    for what, unit, x in (
        ("q", "rad", q),
        ("qd", "rad/s", qd),
        ("qdd", "rad/s^2", qdd),
    ):
        arr = np.asarray(x, dtype=np.float64) if not isinstance(x, str) else x
        if isinstance(arr, np.ndarray) and arr.ndim == 1 and arr.shape == (n,):
            arr = arr[None]
            single = True
        if not isinstance(arr, np.ndarray) or arr.ndim != 2 or arr.shape[1] != n:
            found = np.shape(arr) if isinstance(arr, np.ndarray) else repr(arr)
            raise ValueError(
                f"{what}: expected shape (N, {n}) or ({n},) in {unit}, found {found}"
            )
        arr = as_finite_array(arr, what)
        if shape is not None and arr.shape != shape:
            raise ValueError(
                f"{what}: expected the shape of q {shape}, found {arr.shape}"
            )
        shape = arr.shape
        out.append(np.ascontiguousarray(arr.T))
    return out[0], out[1], out[2], single


def _cross_const(v: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """out += v x p for (3, ...) v and constant (3,) p, skipping zero terms."""
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        if p[k] != 0.0:
            out[i] += v[j] * p[k]
        if p[j] != 0.0:
            out[i] -= v[k] * p[j]


def regressor_columns(
    chain: SerialChain,
    qT: np.ndarray,
    qdT: np.ndarray,
    qddT: np.ndarray,
    out: np.ndarray | None = None,
    columns: np.ndarray | None = None,
) -> np.ndarray:
    """The regressor in component-first layout (no input checks).

    Args:
      chain: the serial chain (n joints).
      qT, qdT, qddT: (n, N) C-contiguous float64 joint positions (rad),
        velocities (rad/s), accelerations (rad/s^2); not checked.
      out: optional zero-filled (p, n, N) array or view to write into (for
        example ``Y.transpose(2, 1, 0)`` of a zeroed (N, n, p) array); only its
        non-zero entries (joint j <= link k) are written.
      columns: optional (p,) distinct indices of the standard parameters to
        compute, in output order (default all 13n, p = 13n).

    Returns:
      ``out`` (or a new (p, n, N) array), with out[c, j, i] = Y[i, j, columns[c]].
    """
    n, N = qT.shape
    n_std = N_PER_LINK * n
    pos = np.arange(n_std)  # output row of each standard column, -1 if dropped
    if columns is not None:
        pos = np.full(n_std, -1)
        pos[columns] = np.arange(len(columns))
    if out is None:
        out = np.zeros((int(pos.max()) + 1, n, N))
    Yv = out.transpose(2, 1, 0)
    g = chain.gravity
    A = chain._A
    cq, sq = np.cos(qT), np.sin(qT)
    # Slot 0: w (ang); slot 1: wd (ang) and a (lin); slot 2 + j: column of joint j.
    V = np.zeros((6, n + 2, N))  # rows 0-2 angular, 3-5 linear
    ang, lin = V[:3], V[3:]
    Abuf = np.zeros((6, 10, N))
    lin[:, 1] = -g[:, None]
    for k in range(n):
        RAt = np.ascontiguousarray(A[k, :3, :3].T)
        p = A[k, :3, 3]
        m = k + 2  # active slots 0 .. k+1
        # Move to the parent side of joint k: lin += ang x p (point shift),
        # a += w x (w x p) (centripetal), then rotate by A^T and Rot_z(q)^T.
        if np.any(p):
            _cross_const(ang[:, 1:m], p, lin[:, 1:m])
            w = ang[:, 0]
            wxp = np.zeros((3, N))
            _cross_const(w, p, wxp)
            lin[0, 1] += w[1] * wxp[2] - w[2] * wxp[1]
            lin[1, 1] += w[2] * wxp[0] - w[0] * wxp[2]
            lin[2, 1] += w[0] * wxp[1] - w[1] * wxp[0]
        a2 = (RAt @ ang[:, :m].reshape(3, -1)).reshape(3, m, N)
        l2 = (RAt @ lin[:, 1:m].reshape(3, -1)).reshape(3, m - 1, N)
        c, s = cq[k], sq[k]
        ang[0, :m] = a2[0] * c + a2[1] * s
        ang[1, :m] = a2[1] * c - a2[0] * s
        ang[2, :m] = a2[2]
        lin[0, 1:m] = l2[0] * c + l2[1] * s
        lin[1, 1:m] = l2[1] * c - l2[0] * s
        lin[2, 1:m] = l2[2]
        # Joint rate: wd += (w' x qd z) + qdd z, w += qd z.
        qd, qdd = qdT[k], qddT[k]
        ang[0, 1] += ang[1, 0] * qd
        ang[1, 1] -= ang[0, 0] * qd
        ang[2, 1] += qdd
        ang[2, 0] += qd
        ang[2, m] = 1.0  # column of joint k: (z; 0)
        # Link k's block: Y[j, c] = S_jk^T A_k[:, c] for joints j <= k.
        _wrench_regressor(ang[:, 0], ang[:, 1], lin[:, 1], Abuf)
        b = np.einsum("rjn,rcn->cjn", V[:, 2 : k + 3], Abuf)
        T = chain._T[k]
        if T is not None:  # parameters given in a link frame C != K: Y_C = Y_K T
            b = np.tensordot(T.T, b, axes=1)
        # Written through the (N, n, p) view: for the usual out = Y.T this is
        # the contiguous Y, where numpy copies in runs of 10 (faster).
        rows = pos[N_PER_LINK * k : N_PER_LINK * (k + 1)]
        if columns is None:
            Yv[:, : k + 1, rows[0] : rows[0] + 10] = b.transpose(2, 1, 0)
        else:
            keep = rows[:10] >= 0
            Yv[:, : k + 1, rows[:10][keep]] = b[keep].transpose(2, 1, 0)
        for r, value in zip(rows[10:], (qdd, qd, np.sign(qd)), strict=True):
            if r >= 0:
                Yv[:, k, r] = value
    return out


def _wrench_regressor(
    w: np.ndarray, wd: np.ndarray, a: np.ndarray, A: np.ndarray
) -> None:
    """Fills the non-zero entries of A (6, 10, N): (n; f) = A @ phi for one link.

    n = I wd + w x (I w) + c x a and f = m a + wd x c + w x (w x c) about the
    link origin (rows n0 n1 n2 f0 f1 f2; columns XX XY XZ YY YZ ZZ MX MY MZ M).
    A[0:3, 9] and A[3:6, 0:6] stay zero.
    """
    # G = L(wd) + [w]x L(w), with I v = L(v) (XX XY XZ YY YZ ZZ):
    # L(v) = [[v0, v1, v2, 0, 0, 0], [0, v0, 0, v1, v2, 0], [0, 0, v0, 0, v1, v2]].
    w0, w1, w2 = w
    ww = w * w
    A[0, 0] = wd[0]
    A[1, 0] = w2 * w0
    A[2, 0] = -w1 * w0
    A[0, 1] = wd[1] - w2 * w0
    A[1, 1] = wd[0] + w2 * w1
    A[2, 1] = ww[0] - ww[1]
    A[0, 2] = wd[2] + w1 * w0
    A[1, 2] = ww[2] - ww[0]
    A[2, 2] = wd[0] - w1 * w2
    A[0, 3] = -w2 * w1
    A[1, 3] = wd[1]
    A[2, 3] = w0 * w1
    A[0, 4] = ww[1] - ww[2]
    A[1, 4] = wd[2] - w0 * w1
    A[2, 4] = wd[1] + w0 * w2
    A[0, 5] = w1 * w2
    A[1, 5] = -w0 * w2
    A[2, 5] = wd[2]
    # c x a: coefficient of c_m in moment row i.
    A[0, 6] = 0.0
    A[0, 7] = a[2]
    A[0, 8] = -a[1]
    A[1, 6] = -a[2]
    A[1, 7] = 0.0
    A[1, 8] = a[0]
    A[2, 6] = a[1]
    A[2, 7] = -a[0]
    A[2, 8] = 0.0
    # K = [wd]x + w w^T - |w|^2 1 (force rows, c columns); m column: a.
    n2 = ww[0] + ww[1] + ww[2]
    A[3, 6] = ww[0] - n2
    A[4, 7] = ww[1] - n2
    A[5, 8] = ww[2] - n2
    w01, w02, w12 = w0 * w1, w0 * w2, w1 * w2
    A[3, 7] = w01 - wd[2]
    A[4, 6] = w01 + wd[2]
    A[3, 8] = w02 + wd[1]
    A[5, 6] = w02 - wd[1]
    A[4, 8] = w12 - wd[0]
    A[5, 7] = w12 + wd[0]
    A[3:6, 9] = a


def regressor(
    chain: SerialChain | RobotModel,
    q: object,
    qd: object,
    qdd: object,
    columns: object = None,
) -> np.ndarray:
    """Joint-torque regressor Y with tau = Y @ chi.

    Args:
      chain: a SerialChain, or a RobotModel (its MDH chain).
      q, qd, qdd: (N, n) joint positions (rad), velocities (rad/s) and
        accelerations (rad/s^2), or (n,) for one sample; in the chain's joint
        order (for a plant chain, ``q_plant[:, chain.q_indices]``).
      columns: optional indices (or boolean mask) of the standard parameters to
        keep, e.g. the base columns of :func:`rmdrake.dynamics.base_parameters`.

    Returns:
      (N, n, 13n) (or (N, n, len(columns))) float64 array in N m per parameter
      unit, C-contiguous; (n, 13n) for a single (n,) sample. Columns are the
      link-major standard parameters ``XX1 .. fcn``.

    Raises:
      ValueError: wrong shapes (expected vs found) or non-finite inputs.
    """
    chain = _chain(chain)
    qT, qdT, qddT, single = _states(chain.n_joints, q, qd, qdd)
    n, N = qT.shape
    if columns is None:
        p = N_PER_LINK * n
    else:
        columns = np.arange(N_PER_LINK * n)[np.asarray(columns)]
        if np.unique(columns).size != columns.size:
            raise ValueError("columns: expected distinct standard-parameter indices")
        p = columns.size
    Y = np.zeros((N, n, p))
    regressor_columns(chain, qT, qdT, qddT, out=Y.transpose(2, 1, 0), columns=columns)
    return Y[0] if single else Y


def torques(
    chain: SerialChain | RobotModel, q: object, qd: object, qdd: object, chi: object
) -> np.ndarray:
    """Joint torques tau = Y(q, qd, qdd) @ chi, (N, n) in N m (see
    :func:`regressor`)."""
    chain = _chain(chain)
    chi = as_finite_array(chi, "chi", (chain.n_parameters,))
    return regressor(chain, q, qd, qdd) @ chi
