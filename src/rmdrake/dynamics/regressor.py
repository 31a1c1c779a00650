"""The joint-effort regressor Y(q, qd, qdd) of a serial chain.

    tau = Y(q, qd, qdd) @ chi

for the rigid-body inverse dynamics (gravity included), plus the rotor inertia
Ia_j * qdd_j, plus the friction fv_j * qd_j + fc_j * s(qd_j) of
:mod:`rmdrake.dynamics.friction` (s = sign by default, or its smooth tanh), with
chi the link-major standard parameters of :mod:`rmdrake.model.dynamic_parameters` (13
per link). Joints are revolute (q_j in rad, tau_j a torque in N m) or prismatic
(q_j in m, tau_j a force in N); Ia, fv and fc act on a prismatic coordinate as
on a revolute one (in kg, N s/m and N).

Method. In each link's canonical frame K_k (joint axis = z through the origin, see
:mod:`rmdrake.dynamics.chain`) a forward recursion gives the angular velocity w_k,
angular acceleration wd_k and the acceleration a_k of the origin minus gravity,
together with the columns S_jk (j <= k) of the body Jacobian of link k: the unit
twist of joint j expressed in K_k (angular part, linear velocity of Ko); a
revolute joint's own twist is (z; 0), a prismatic joint's (0; z), and across a
prismatic joint the angular velocity and acceleration do not change while the
origin moves by q_j z (so a gains wd x q z + w x (w x q z) + 2 qd w x z + qdd z).
The
wrench of link k about Ko in K_k is linear in its 10 inertial parameters,

    n = I wd + w x (I w) + c x a,   f = m a + wd x c + w x (w x c),

i.e. (n; f) = A_k(w, wd, a) @ phi_k with a 6x10 matrix A_k, and by the principle
of virtual power tau_j = sum_{k >= j} S_jk^T (n; f)_k, so the (j, k) block of Y is
S_jk^T A_k. Only the blocks j <= k are non-zero (link k acts on joints 1..k).

Layout and cost. Everything is component-first with samples last ((6, slots, N)
arrays, as in :mod:`rmdrake.kinematics`), so each operation is one numpy call on
a contiguous block of all samples and the only Python loop is over joints (about
30 numpy calls per joint): moving all twists to the next link is one 6x6 product
plus the joint rotation, A_k two row gathers of 12 motion features, and the block
S^T A_k one ``einsum``, copied into the (N, n, 13n) output. No BLAS call: a
multi-threaded BLAS slows small products down on a busy machine, so the kernel
uses ``einsum``/``take``, whose speed does not depend on OPENBLAS_NUM_THREADS.
The Coulomb column is :func:`rmdrake.dynamics.friction.coulomb_sign` of qd
(sign(0) = 0: a joint at rest has no Coulomb torque).

Further terms. ``columns`` may also pick entries of the (15n,) extended vector
of :mod:`rmdrake.model.dynamic_parameters`: fcn_j (column min(s, 0) in joint j's
row) and the offset tau0_j (column 1 in joint j's row). With ``asymmetric``
the fc_j column is max(s, 0), so the Coulomb effort is fc_j for qd_j > 0 and
-fcn_j for qd_j < 0; without, it is s (whichever columns are requested).

Coupled motors. On a chain with a motor coupling C (``chain.coupling``, from
the robot's transmission, :mod:`rmdrake.model.transmission`) the columns
15 n + 3 i + (0, 1, 2) are the i-th coupled motor m's ``Iam, fvm, fcm``:
with c = C[m] and the motor's joint-reflected speed s = c . qd, the column
of joint j is c_j (c . qdd), c_j s and c_j s(s) (s(.) the Coulomb sign as
above, always symmetric). E.g. a coupled wrist with c = (0, 0, 0, 0, 0.8, 1):
Iam6's column is 0.8 (0.8 qdd5 + qdd6) in joint 5's row and 0.8 qdd5 + qdd6
in joint 6's.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.chain import SerialChain, as_serial_chain
from rmdrake.dynamics.friction import coulomb_sign
from rmdrake.model.dynamic_parameters import N_EXTENDED, N_PER_LINK, extended_width
from rmdrake.model.robot import RobotModel

__all__ = [
    "BLOCK_SAMPLES",
    "regressor",
    "regressor_blocks",
    "regressor_columns",
    "torques",
]

BLOCK_SAMPLES = 4096
"""Samples per block of :func:`regressor_blocks` (a (block, n, 15n) buffer is
3.9 MB for n = 6)."""


def _states(
    n: int, q: object, qd: object, qdd: object
) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """(n, N) contiguous copies of the three joint arrays; True if 1-D input."""
    out = []
    single = False
    shape = None
    for what, unit, x in (
        ("q", "rad or m", q),
        ("qd", "rad/s or m/s", qd),
        ("qdd", "rad/s^2 or m/s^2", qdd),
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


# The wrench regressor A_k (6 x 10 per sample) is linear in 12 features of the
# link's motion, F = (wd, a, w_i w_m for i <= m): each entry (row r of (n; f),
# column c of the parameters) is a sum of at most two +-features (from
# n = I wd + w x (I w) + c x a, f = m a + wd x c + w x (w x c); checked against
# Drake by the tests), so A is two row gathers and one add.
_FEATURES = ("wd0", "wd1", "wd2", "a0", "a1", "a2",
             "q00", "q01", "q02", "q11", "q12", "q22")  # fmt: skip
_COLS = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
# Rows n0 n1 n2 f0 f1 f2 (moment about the link origin, force; link axes).
_WRENCH_TABLE = {
    0: {"XX": "wd0", "XY": "wd1 -q02", "XZ": "wd2 +q01", "YY": "-q12",
        "YZ": "q11 -q22", "ZZ": "q12", "MY": "a2", "MZ": "-a1"},
    1: {"XX": "q02", "XY": "wd0 +q12", "XZ": "q22 -q00", "YY": "wd1",
        "YZ": "wd2 -q01", "ZZ": "-q02", "MX": "-a2", "MZ": "a0"},
    2: {"XX": "-q01", "XY": "q00 -q11", "XZ": "wd0 -q12", "YY": "q01",
        "YZ": "wd1 +q02", "ZZ": "wd2", "MX": "a1", "MY": "-a0"},
    3: {"MX": "-q11 -q22", "MY": "q01 -wd2", "MZ": "q02 +wd1", "M": "a0"},
    4: {"MX": "q01 +wd2", "MY": "-q00 -q22", "MZ": "q12 -wd0", "M": "a1"},
    5: {"MX": "q02 -wd1", "MY": "q12 +wd0", "MZ": "-q00 -q11", "M": "a2"},
}  # fmt: skip


def _wrench_terms() -> tuple[np.ndarray, np.ndarray]:
    """Two index arrays (60,) into the signed features G = (F, -F, 0) (25, N)
    with A.reshape(60, N) = G[i1] + G[i2] (every entry of _WRENCH_TABLE has at
    most two terms of sign +-1; empty entries take the zero row twice)."""
    nf = len(_FEATURES)
    terms = [[2 * nf, 2 * nf] for _ in range(60)]
    for r, row in _WRENCH_TABLE.items():
        for col, expr in row.items():
            for t, term in enumerate(expr.split()):
                f = _FEATURES.index(term.lstrip("+-"))
                terms[10 * r + _COLS.index(col)][t] = f + nf * (term[0] == "-")
    i1, i2 = np.array(terms).T
    return np.ascontiguousarray(i1), np.ascontiguousarray(i2)


_I1, _I2 = _wrench_terms()


def _constants(chain: SerialChain) -> tuple[np.ndarray, np.ndarray]:
    """Per joint k, constants of the move from K_(k-1) to K_k (cached on chain):

    X6[k] (6, 6): the motion transform of A_k^-1 on (angular; linear) stacks,
      (w; v) -> (R^T w; R^T (v + w x p)) with A_k = (R, p);
    Cp[k] (3, 6): [w]x^2 p = w (w.p) - |w|^2 p as a matrix on the features
      (q00 q01 q02 q11 q12 q22) of the parent's w (the centripetal term of the
      origin's acceleration).
    """
    try:
        return chain._kernel_constants
    except AttributeError:
        pass
    n = chain.n_joints
    X6 = np.zeros((n, 6, 6))
    Cp = np.zeros((n, 3, 6))
    idx = {(0, 0): 0, (0, 1): 1, (0, 2): 2, (1, 1): 3, (1, 2): 4, (2, 2): 5}
    for k in range(n):
        RAt = chain._A[k, :3, :3].T
        p = chain._A[k, :3, 3]
        P = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        X6[k, :3, :3] = X6[k, 3:, 3:] = RAt
        X6[k, 3:, :3] = -RAt @ P
        for i in range(3):
            for m in range(3):
                Cp[k, i, idx[min(i, m), max(i, m)]] += p[m]
            for d in (0, 3, 5):
                Cp[k, i, d] -= p[i]
    const = (X6, Cp)
    object.__setattr__(chain, "_kernel_constants", const)
    return const


def regressor_columns(
    chain: SerialChain,
    qT: np.ndarray,
    qdT: np.ndarray,
    qddT: np.ndarray,
    out: np.ndarray | None = None,
    columns: np.ndarray | None = None,
    coulomb_width: float = 0.0,
    asymmetric: bool = False,
) -> np.ndarray:
    """The regressor in component-first layout (no input checks).

    Args:
      chain: the serial chain (n joints).
      qT, qdT, qddT: (n, N) C-contiguous float64 joint positions (rad or m),
        velocities (rad/s or m/s), accelerations (rad/s^2 or m/s^2); not
        checked.
      out: optional zero-filled (p, n, N) array or view to write into (for
        example ``Y.transpose(2, 1, 0)`` of a zeroed (N, n, p) array); only its
        non-zero entries (joint j <= link k) are written.
      columns: optional (p,) distinct indices of the extended parameters
        (15n, or 15n + 3k with k coupled motors, module docstring) to compute,
        in output order (default the 13n standard ones, p = 13n).
      coulomb_width: width of the Coulomb column's sign in rad/s or m/s, as in
        :func:`rmdrake.dynamics.friction.coulomb_sign` (0: sign(qd)).
      asymmetric: the fc columns are max(s, 0) (asymmetric Coulomb friction,
        with fcn), else s.

    Returns:
      ``out`` (or a new (p, n, N) array), with out[c, j, i] = Y[i, j, columns[c]].

    Example:

    >>> import numpy as np
    >>> from rmdrake import SerialChain, load_robot
    >>> from rmdrake.dynamics import regressor_columns
    >>> chain = SerialChain.from_model(load_robot("rv3sb"))
    >>> qT = np.zeros((6, 5))  # component-first: (n, N)
    >>> regressor_columns(chain, qT, qT, qT).shape
    (78, 6, 5)
    """
    n, N = qT.shape
    n_std = N_PER_LINK * n
    pos = np.arange(n_std)  # output row of each standard column, -1 if dropped
    if columns is not None:
        pos = np.full(max(N_EXTENDED * n, int(np.max(columns)) + 1), -1)
        pos[columns] = np.arange(len(columns))
    extra = pos[n_std : N_EXTENDED * n].reshape(-1, n) if pos.size > n_std else None
    if out is None:
        out = np.zeros((int(pos.max()) + 1, n, N))
    Yv = out.transpose(2, 1, 0)
    X6, Cp = _constants(chain)
    cq, sq = np.cos(qT), np.sin(qT)  # unused rows for prismatic joints
    slide = chain.prismatic
    # V slots: 0 = (w; unused), 1 = (wd; a - g), 2 + j = unit twist of joint j,
    # all in the current link frame; rows 0-2 angular, 3-5 linear (of the origin).
    V = np.zeros((6, n + 2, N))
    V4 = V.reshape(2, 3, n + 2, N)  # (angular|linear, xyz, slot, sample)
    V[3:, 1] = -chain.gravity[:, None]
    G = np.zeros((25, N))  # (F, -F, 0): signed features of the current link
    F = G[:12]
    A = np.empty((6, 10, N))
    A2 = np.empty((60, N))
    t3 = np.empty((3, N))
    tmp = np.empty((2, n + 2, N))
    for k in range(n):
        m = k + 2
        if k > 0:  # a += w x (w x p), with the parent's w (features F)
            np.einsum("if,fn->in", Cp[k], F[6:], out=t3)
            V[3:, 1] += t3
        # To K_k at q = 0 (one 6x6 product), then Rot_z(q_k)^T on x, y.
        U = np.einsum("ij,jx->ix", X6[k], V[:, :m].reshape(6, -1))
        qd, qdd = qdT[k], qddT[k]
        if slide[k]:
            _slide(V, U.reshape(6, m, N), qT[k], qd, qdd, t3)
        else:
            U = U.reshape(2, 3, m, N)
            c, s = cq[k], sq[k]
            tm = tmp[:, :m]
            np.multiply(U[:, 0], c, out=V4[:, 0, :m])
            np.multiply(U[:, 1], s, out=tm)
            V4[:, 0, :m] += tm
            np.multiply(U[:, 1], c, out=V4[:, 1, :m])
            np.multiply(U[:, 0], s, out=tm)
            V4[:, 1, :m] -= tm
            V4[:, 2, :m] = U[:, 2]
            # Joint rate: wd += w' x (qd z) + qdd z, w += qd z; new twist (z; 0).
            V[0, 1] += V[1, 0] * qd
            V[1, 1] -= V[0, 0] * qd
            V[2, 1] += qdd
            V[2, 0] += qd
            V[2, m] = 1.0
        # Link k's block: Y[j, c] = S_jk^T A_k[:, c] for the joints j <= k.
        w = V[:3, 0]
        F[:6] = V[:, 1]
        np.multiply(w[0], w, out=F[6:9])
        np.multiply(w[1], w[1:], out=F[9:11])
        np.multiply(w[2], w[2], out=F[11])
        np.negative(F, out=G[12:24])
        np.take(G, _I1, axis=0, out=A.reshape(60, N))
        np.take(G, _I2, axis=0, out=A2)
        A.reshape(60, N)[...] += A2
        # Joint k's own twist is (z; 0), or (0; z) for a prismatic joint: its
        # row is the z moment row of A_k, or the z force row.
        b = np.empty((10, k + 1, N))
        b[:, k] = A[5 if slide[k] else 2]
        if k:
            np.einsum("rjn,rcn->cjn", V[:, 2 : k + 2], A, out=b[:, :k])
        T = chain._T[k]
        if T is not None:  # parameters given in a link frame C != K: Y_C = Y_K T
            b = np.tensordot(T.T, b, axes=1)
        # Written through the (N, n, p) view: for the usual out = Y.T this is
        # the contiguous Y, where numpy copies in runs of 10.
        rows = pos[N_PER_LINK * k : N_PER_LINK * (k + 1)]
        if columns is None:
            Yv[:, : k + 1, rows[0] : rows[0] + 10] = b.transpose(2, 1, 0)
        else:
            keep = rows[:10] >= 0
            Yv[:, : k + 1, rows[:10][keep]] = b[keep].transpose(2, 1, 0)
        sgn = coulomb_sign(qd, coulomb_width)
        r_fcn, r_tau0 = (-1, -1) if extra is None else extra[:, k]
        coulomb = np.maximum(sgn, 0.0) if asymmetric else sgn
        for r, value in zip(rows[10:], (qdd, qd, coulomb), strict=True):
            if r >= 0:
                Yv[:, k, r] = value
        if r_fcn >= 0:
            Yv[:, k, r_fcn] = np.minimum(sgn, 0.0)
        if r_tau0 >= 0:
            Yv[:, k, r_tau0] = 1.0
    motor_pos = pos[N_EXTENDED * n :]
    if np.any(motor_pos >= 0):
        _motor_columns(chain, qdT, qddT, Yv, motor_pos, coulomb_width)
    return out


def _motor_columns(
    chain: SerialChain,
    qdT: np.ndarray,
    qddT: np.ndarray,
    Yv: np.ndarray,
    motor_pos: np.ndarray,
    coulomb_width: float,
) -> None:
    """Writes the coupled motors' Iam, fvm, fcm columns (module docstring)
    into the (N, n, p) view ``Yv`` at the output positions ``motor_pos``
    (3 per coupled motor, -1 where not requested)."""
    for i, m in enumerate(chain.coupled_motors):
        c = chain.coupling[m]
        s = np.einsum("j,jn->n", c, qdT)
        values = (
            np.einsum("j,jn->n", c, qddT),
            s,
            coulomb_sign(s, coulomb_width),
        )
        for r, v in zip(motor_pos[3 * i : 3 * i + 3], values, strict=True):
            if r >= 0:
                np.multiply(v[:, None], c[None, :], out=Yv[:, :, r])


def _slide(
    V: np.ndarray,
    U: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    t3: np.ndarray,
) -> None:
    """Moves the m = U.shape[1] slots of V across a prismatic joint, in place.

    U (6, m, N) are the slots in A_k axes at the parent-side origin; the child
    origin is q z further on, so each slot's linear part gains (its angular
    part) x q z = q (w_y, -w_x, 0). The acceleration slot then adds
    w x (w x q z) + 2 qd w x z + qdd z, with w the (unchanged) angular
    velocity; the new twist slot m is (0; z)."""
    m = U.shape[1]
    V[:, :m] = U
    V[3, :m] += q * U[1]
    V[4, :m] -= q * U[0]
    w0, w1, w2 = V[0, 0], V[1, 0], V[2, 0]
    np.multiply(w2, q, out=t3[2])
    t3[0] = w0 * t3[2] + 2.0 * qd * w1
    t3[1] = w1 * t3[2] - 2.0 * qd * w0
    t3[2] = qdd - q * (w0 * w0 + w1 * w1)
    V[3:, 1] += t3
    V[5, m] = 1.0


# Samples per kernel call: larger batches run in equal chunks of at most this
# size: chunks of about 1500 samples beat one large call (cache) and smaller
# chunks (per-call overhead); bench/regressor.py times them.
_CHUNK = 1536


def regressor(
    chain: SerialChain | RobotModel,
    q: object,
    qd: object,
    qdd: object,
    columns: object = None,
    *,
    out: np.ndarray | None = None,
    coulomb_width: float = 0.0,
    asymmetric: bool = False,
) -> np.ndarray:
    """Joint-torque regressor Y with tau = Y @ chi.

    Args:
      chain: a SerialChain, or a RobotModel (its MDH chain).
      q, qd, qdd: (N, n) joint positions (rad or m), velocities (rad/s or
        m/s) and accelerations (rad/s^2 or m/s^2), or (n,) for one sample; in
        the chain's joint order (for a plant chain,
        ``q_plant[:, chain.q_indices]``); m for prismatic joints.
      columns: optional indices (or a boolean mask of length 13n or 15n) of
        the standard (13n) or extended (15n, or 15n + 3k with k coupled
        motors, module docstring) parameters to keep, e.g. the base columns
        of :func:`rmdrake.dynamics.base_parameters`.
      out: optional C-contiguous float64 array of the output shape to fill and
        return (its content is overwritten); reusing one across calls saves
        the page faults of a fresh array (about 20% of a 1500-sample call).
      coulomb_width: 0 (default) for the Coulomb column sign(qd); > 0 (rad/s
        or m/s) for tanh(qd / coulomb_width), the smooth sign of the simulated friction
        (:data:`rmdrake.dynamics.friction.DEFAULT_V_EPS`), when identifying
        from simulation with the simulator's own friction law.
      asymmetric: fc columns max(s, 0) for asymmetric Coulomb friction (with
        the fcn columns min(s, 0)); default s.

    Returns:
      (N, n, 13n) (or (N, n, len(columns))) float64 array in N m (revolute
      rows) or N (prismatic rows) per parameter unit, C-contiguous; (n, 13n)
      for a single (n,) sample. Columns are the
      link-major standard parameters ``XX1 .. fcn``; the friction columns
      (fv_j, fc_j) hold (qd_j, s(qd_j)) in joint j's row, so their product with
      (fv, fc) is :func:`rmdrake.dynamics.friction.friction_torque`.

    Raises:
      ValueError: wrong shapes (expected vs found) or non-finite inputs.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, regressor, standard_parameters
    >>> robot = load_robot("rv3sb")
    >>> q, qd, qdd = np.zeros((3, 4, 6))  # 4 samples at rest
    >>> Y = regressor(robot, q, qd, qdd)
    >>> Y.shape
    (4, 6, 78)
    >>> tau = Y @ standard_parameters(robot)  # (N, n) gravity torques here
    >>> tau.shape
    (4, 6)
    """
    if not np.isfinite(coulomb_width) or coulomb_width < 0:
        raise ValueError(
            f"coulomb_width: expected a width >= 0 in rad/s or m/s, found "
            f"{coulomb_width}"
        )
    chain = as_serial_chain(chain)
    qT, qdT, qddT, single = _states(chain.n_joints, q, qd, qdd)
    n, N = qT.shape
    if columns is None:
        p = N_PER_LINK * n
    else:
        idx = np.asarray(columns)
        width = extended_width(n, len(chain.coupled_motors))
        size = idx.size if idx.dtype == bool else width
        if size > width:
            raise ValueError(
                f"columns: expected indices below {width} (the extended vector "
                f"of {n} links and {len(chain.coupled_motors)} coupled motors), "
                f"found a mask or index up to {size}"
            )
        columns = np.arange(size)[idx]
        if np.unique(columns).size != columns.size:
            raise ValueError("columns: expected distinct standard-parameter indices")
        p = columns.size
    if out is None:
        Y = np.zeros((N, n, p))
    else:
        want = (N, n, p) if not single else (n, p)
        if (
            not isinstance(out, np.ndarray)
            or out.shape != want
            or out.dtype != np.float64
            or not out.flags.c_contiguous
        ):
            found = (out.shape, out.dtype) if isinstance(out, np.ndarray) else out
            raise ValueError(
                f"out: expected a C-contiguous float64 array of shape {want}, "
                f"found {found}"
            )
        Y = out.reshape(N, n, p)
        Y[...] = 0.0
    # Equal chunks of at most _CHUNK samples keep the work arrays cache-sized.
    edges = np.linspace(0, N, -(-N // _CHUNK) + 1).astype(int)
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        s = slice(a, b)
        Yt = Y[s].transpose(2, 1, 0)
        regressor_columns(
            chain,
            qT[:, s],
            qdT[:, s],
            qddT[:, s],
            Yt,
            columns,
            coulomb_width,
            asymmetric,
        )
    if out is not None:
        return out
    return Y[0] if single else Y


def regressor_blocks(
    chain: SerialChain | RobotModel,
    q: object,
    qd: object,
    qdd: object,
    columns: object = None,
    *,
    block: int = BLOCK_SAMPLES,
    coulomb_width: float = 0.0,
    asymmetric: bool = False,
) -> Iterator[tuple[slice, np.ndarray]]:
    """The regressor of :func:`regressor` block by block, so a long log never
    holds its whole (N, n, p) regressor: yields ``(s, Y)`` for consecutive
    slices ``s`` of at most ``block`` samples, Y the (len(s), n, p) regressor
    of ``q[s], qd[s], qdd[s]`` (arguments and units as :func:`regressor`;
    q, qd, qdd (N, n)). Y is a view of one buffer that the next block
    overwrites: use (or copy) it before advancing."""
    q, qd, qdd = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd))
    if q.ndim != 2:
        raise ValueError(f"q: expected shape (N, n), found {q.shape}")
    if block < 1:
        raise ValueError(f"block: expected at least 1 sample, found {block}")
    buf = None
    for a in range(0, q.shape[0], block):
        s = slice(a, min(a + block, q.shape[0]))
        Y = regressor(
            chain,
            q[s],
            qd[s],
            qdd[s],
            columns,
            out=None if buf is None else buf[: s.stop - a],
            coulomb_width=coulomb_width,
            asymmetric=asymmetric,
        )
        buf = Y if buf is None else buf
        yield s, Y


def torques(
    chain: SerialChain | RobotModel,
    q: object,
    qd: object,
    qdd: object,
    chi: object,
    *,
    coulomb_width: float = 0.0,
) -> np.ndarray:
    """Joint efforts tau = Y(q, qd, qdd) @ chi, (N, n) in N m or N (see
    :func:`regressor`); chi is the (13n,) standard or the extended vector
    ((15n,), or (15n + 3k,) with k coupled motors;
    :func:`rmdrake.model.dynamic_parameters.extended_parameters`: with
    asymmetric Coulomb friction and offsets; fcn = fc is the symmetric law).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, standard_parameters
    >>> from rmdrake.dynamics import regressor, torques
    >>> robot = load_robot("rv3sb")
    >>> q, qd, qdd = np.zeros((3, 1, 6))
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> Y = regressor(robot, q, qd, qdd)
    >>> tau.shape, bool(np.allclose(tau, Y @ standard_parameters(robot)))
    ((1, 6), True)
    """
    chain = as_serial_chain(chain)
    n = chain.n_joints
    chi = as_finite_array(chi, "chi")
    width = extended_width(n, len(chain.coupled_motors))
    if chi.shape not in ((N_PER_LINK * n,), (width,)):
        raise ValueError(
            f"chi: expected shape ({N_PER_LINK * n},) or ({width},), found {chi.shape}"
        )
    ext = chi.size == width
    Y = regressor(
        chain,
        q,
        qd,
        qdd,
        np.arange(chi.size) if ext else None,
        coulomb_width=coulomb_width,
        asymmetric=ext,
    )
    return Y @ chi
