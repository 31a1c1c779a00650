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

Layout. Everything is component-first with samples last ((3, slots, N) arrays,
as in :mod:`rmdrake.kinematics`), so every operation is one numpy call on a
contiguous block of all samples; the constant part of each joint transform is one
BLAS product. The only Python loops are over joints and the 10 parameter columns.
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
) -> np.ndarray:
    """The regressor in component-first layout (no input checks).

    Args:
      chain: the serial chain (n joints).
      qT, qdT, qddT: (n, N) C-contiguous float64 joint positions (rad),
        velocities (rad/s), accelerations (rad/s^2); not checked.
      out: optional zero-filled (13n, n, N) array or view to write into (for
        example ``Y.transpose(2, 1, 0)`` of a zeroed (N, n, 13n) array); only its
        non-zero entries (joint j <= link k) are written.

    Returns:
      ``out`` (or a new (13n, n, N) array), with out[c, j, i] = Y[i, j, c].
    """
    n, N = qT.shape
    if out is None:
        out = np.zeros((N_PER_LINK * n, n, N))
    blk = np.empty((10, n, N))
    g = chain.gravity
    A = chain._A
    cq, sq = np.cos(qT), np.sin(qT)
    # Slot 0: w (ang); slot 1: wd (ang) and a (lin); slot 2 + j: column of joint j.
    ang = np.zeros((3, n + 2, N))
    lin = np.zeros((3, n + 2, N))
    lin[:, 1] = -g[:, None]
    tmp = np.empty((n, N))
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
        b = blk[:, : k + 1]
        _link_block(ang, lin, k, b, tmp)
        T = chain._T[k]
        if T is not None:  # parameters given in a link frame C != K: Y_C = Y_K T
            b = np.tensordot(T.T, b, axes=1)
        base = N_PER_LINK * k
        out[base : base + 10, : k + 1] = b
        out[base + 10, k] = qdd
        out[base + 11, k] = qd
        np.sign(qd, out=out[base + 12, k])
    return out


def _link_block(
    ang: np.ndarray, lin: np.ndarray, k: int, out: np.ndarray, tmp: np.ndarray
) -> None:
    """out[c, j] = S_j^T A_k[:, c] for the 10 inertial columns c, joints j <= k."""
    w, wd, a = ang[:, 0], ang[:, 1], lin[:, 1]
    sa, sl = ang[:, 2 : k + 3], lin[:, 2 : k + 3]
    t = tmp[: k + 1]
    N = w.shape[1]
    # G = L(wd) + [w]x L(w): moment rows of the inertia columns (3, 6, N), where
    # I v = L(v) (XX XY XZ YY YZ ZZ).
    Lw = np.zeros((3, 6, N))
    Lw[0, 0], Lw[0, 1], Lw[0, 2] = w
    Lw[1, 1], Lw[1, 3], Lw[1, 4] = w
    Lw[2, 2], Lw[2, 4], Lw[2, 5] = w
    G = np.zeros((3, 6, N))
    G[0, 0], G[0, 1], G[0, 2] = wd
    G[1, 1], G[1, 3], G[1, 4] = wd
    G[2, 2], G[2, 4], G[2, 5] = wd
    G[0] += w[1] * Lw[2] - w[2] * Lw[1]
    G[1] += w[2] * Lw[0] - w[0] * Lw[2]
    G[2] += w[0] * Lw[1] - w[1] * Lw[0]
    for col in range(6):
        o = out[col]
        np.multiply(sa[0], G[0, col], out=o)
        np.multiply(sa[1], G[1, col], out=t)
        o += t
        np.multiply(sa[2], G[2, col], out=t)
        o += t
    # First moments c: moment rows c x a, force rows K c with
    # K = [wd]x + [w]x^2 = [wd]x + w w^T - |w|^2 1 (coefficient of c_m: K[:, m]).
    ww = w * w
    w2 = ww[0] + ww[1] + ww[2]
    K = np.empty((3, 3, N))
    for i in range(3):
        np.subtract(ww[i], w2, out=K[i, i])
    for i, m, comp, sgn in ((0, 1, 2, -1.0), (0, 2, 1, 1.0), (1, 2, 0, -1.0)):
        wiwm = w[i] * w[m]
        if sgn > 0:
            np.add(wiwm, wd[comp], out=K[i, m])
            np.subtract(wiwm, wd[comp], out=K[m, i])
        else:
            np.subtract(wiwm, wd[comp], out=K[i, m])
            np.add(wiwm, wd[comp], out=K[m, i])
    # coefficient of c_m in the moment: (c x a)_i, i.e. row i of -[a]x.
    Mc = ((None, a[2], -a[1]), (-a[2], None, a[0]), (a[1], -a[0], None))
    for m in range(3):
        o = out[6 + m]
        np.multiply(sl[0], K[0, m], out=o)
        for i in (1, 2):
            np.multiply(sl[i], K[i, m], out=t)
            o += t
        for i in range(3):
            if Mc[i][m] is not None:
                np.multiply(sa[i], Mc[i][m], out=t)
                o += t
    o = out[9]
    np.multiply(sl[0], a[0], out=o)
    np.multiply(sl[1], a[1], out=t)
    o += t
    np.multiply(sl[2], a[2], out=t)
    o += t


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
        Y = np.zeros((N, n, N_PER_LINK * n))
        regressor_columns(chain, qT, qdT, qddT, out=Y.transpose(2, 1, 0))
    else:
        Yc = regressor_columns(chain, qT, qdT, qddT)
        Y = np.ascontiguousarray(Yc[np.asarray(columns)].transpose(2, 1, 0))
    return Y[0] if single else Y


def torques(
    chain: SerialChain | RobotModel, q: object, qd: object, qdd: object, chi: object
) -> np.ndarray:
    """Joint torques tau = Y(q, qd, qdd) @ chi, (N, n) in N m (see
    :func:`regressor`)."""
    chain = _chain(chain)
    chi = as_finite_array(chi, "chi", (chain.n_parameters,))
    return regressor(chain, q, qd, qdd) @ chi
