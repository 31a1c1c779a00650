"""The linear system A x = b that every identification estimator solves.

Stacking the base regressor Y_base(q_k, qd_k, qdd_k) (n rows per sample k) and
the measured joint torques tau_k over N samples gives the over-determined system
(paper eq. 14-15)

    A x = b,   A: (N n, p) in N m (N) per parameter unit,   b: (N n,) in N m (N),

with x the p base parameters. Rows are sample-major: row ``k * n + j`` is joint
j of sample k, so ``A[j::n]`` are joint j's rows. The system needs more
equations than parameters (N n > p) and, for a unique solution, rank p (a
trajectory that excites every base parameter).

Reduction. Every estimator and check needs A and b only through norms and
least-squares solutions, which an orthogonal transformation keeps, so the tall
system is reduced once to small triangular factors (:class:`ReducedObservations`):
for each joint j (and each segment of consecutive samples), the Householder QR

    [A_j  b_j] = Q_j F_j,   F_j = [[R_j, c_j], [0, rho_j]]  ((p + 1) x (p + 1))

with A_j the N_s rows of joint j, Q_j with orthonormal columns. Then for every
x, ||A_j x - b_j||^2 = ||F_j [x; -1]||^2, A_j^T A_j = R_j^T R_j, the column
norms of A_j are those of R_j, and the factor of the whole (or joint-weighted)
system is the QR of the stacked w_j F_j (n (p + 1) rows, whatever N).
:class:`ObservationReducer` builds the F_j block by block of samples (TSQR: the
factor so far stacked on the next block and factored again), so the tall
matrix is never held whole: memory O(n p^2 + block n p).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.regressor import BLOCK_SAMPLES

__all__ = [
    "ObservationReducer",
    "Observations",
    "ReducedObservations",
    "heldout_split",
    "reduced",
]


def heldout_split(n_samples: int, fraction: float) -> int:
    """The first k samples of N fitted when ``fraction`` is fitted and the rest
    held out: round(fraction N), at least 1 and at most N - 1."""
    return min(max(int(round(fraction * n_samples)), 1), n_samples - 1)


def _check_overdetermined(n_samples: int, n_joints: int, n_parameters: int) -> None:
    """Raises ValueError unless N n > p (the message of both systems)."""
    rows = n_samples * n_joints
    if rows <= n_parameters:
        raise ValueError(
            f"observations: {rows} equations ({n_samples} "
            f"samples x {n_joints} joints) for {n_parameters} "
            "parameters; expected more equations than parameters (a longer log)"
        )


@dataclasses.dataclass(frozen=True)
class Observations:
    """The over-determined system A x = b (see the module docstring).

    Attributes:
      A: (N n, p) stacked regressor (base columns), rows sample-major.
      b: (N n,) stacked measured efforts, N m (N on a prismatic joint).
      n_joints: n.
      names: optional names of the p parameters (columns of A).

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import Observations
    >>> rng = np.random.default_rng(0)
    >>> A = rng.normal(size=(200, 3))  # 100 samples x 2 joints, 3 parameters
    >>> x_true = np.array([1.0, -2.0, 0.5])
    >>> obs = Observations(A, A @ x_true, n_joints=2)
    >>> obs.A.shape, obs.n_joints
    ((200, 3), 2)
    """

    A: np.ndarray
    b: np.ndarray
    n_joints: int
    names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        A = as_finite_array(self.A, "observation matrix A", (None, None))
        b = as_finite_array(self.b, "torque vector b", (A.shape[0],))
        if A.shape[0] % self.n_joints:
            raise ValueError(
                f"observation matrix A: {A.shape[0]} rows is not a multiple of "
                f"n = {self.n_joints} joints"
            )
        if self.names is not None and len(self.names) != A.shape[1]:
            raise ValueError(
                f"names: expected {A.shape[1]} parameter names, found {len(self.names)}"
            )
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "b", b)

    @classmethod
    def from_regressor(
        cls,
        Y: np.ndarray,
        tau: np.ndarray,
        names: Sequence[str] | None = None,
    ) -> Observations:
        """Stacks a (N, n, p) regressor and (N, n) efforts (N m or N)."""
        Y = np.asarray(Y, dtype=np.float64)
        if Y.ndim != 3:
            raise ValueError(f"regressor: expected shape (N, n, p), found {Y.shape}")
        N, n, p = Y.shape
        tau = as_finite_array(tau, "tau", (N, n))
        return cls(
            Y.reshape(N * n, p),
            tau.reshape(N * n),
            n,
            None if names is None else tuple(names),
        )

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return self.A.shape[0] // self.n_joints

    @property
    def n_parameters(self) -> int:
        """Number of parameters p (columns of A)."""
        return self.A.shape[1]

    def check_overdetermined(self) -> None:
        """Raises ValueError unless there are more equations than parameters."""
        _check_overdetermined(self.n_samples, self.n_joints, self.n_parameters)

    def joint_rows(self, j: int) -> slice:
        """Rows of joint j (0-based) in A and b."""
        return slice(j, None, self.n_joints)

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Efforts A x as (N, n), N m or N."""
        return (self.A @ x).reshape(-1, self.n_joints)

    def torques(self) -> np.ndarray:
        """Measured efforts b as (N, n), N m or N."""
        return self.b.reshape(-1, self.n_joints)

    def reduce(
        self, boundaries: Sequence[int] = (), *, block: int = BLOCK_SAMPLES
    ) -> ReducedObservations:
        """The triangular factors of this system (module docstring), with a
        segment boundary before each sample index in ``boundaries``, reduced
        ``block`` samples at a time."""
        N, n, p = self.n_samples, self.n_joints, self.n_parameters
        A, b = self.A.reshape(N, n, p), self.b.reshape(N, n)
        reducer = ObservationReducer(n, p, self.names, boundaries=boundaries)
        for a in range(0, N, block):
            reducer.add(A[a : a + block], b[a : a + block])
        return reducer.result()


@dataclasses.dataclass(frozen=True, eq=False)
class ReducedObservations:
    """A x = b reduced to triangular factors per segment and joint (module
    docstring): what the estimators and the sanity checks work from.

    Attributes:
      factors: (S, n, p + 1, p + 1) upper-triangular F_sj of [A_sj b_sj]
        (segment s, joint j; zero rows where the segment has fewer than p + 1
        samples), entries in N m (N) per parameter unit, last column N m (N).
      sizes: (S,) samples per segment, in log order (segment s holds the
        samples from ``boundaries[s]`` to ``boundaries[s + 1]``).
      names: optional names of the p parameters.
    """

    factors: np.ndarray
    sizes: np.ndarray
    names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        F = as_finite_array(self.factors, "factors", (None, None, None, None))
        S, n, q, q2 = F.shape
        if q != q2 or q < 2 or S < 1 or n < 1:
            raise ValueError(
                f"factors: expected shape (S, n, p + 1, p + 1), found {F.shape}"
            )
        sizes = np.asarray(self.sizes, dtype=np.int64)
        if sizes.shape != (S,) or (sizes < 1).any():
            raise ValueError(
                f"sizes: expected {S} positive sample counts, found {self.sizes!r}"
            )
        if self.names is not None and len(self.names) != q - 1:
            raise ValueError(
                f"names: expected {q - 1} parameter names, found {len(self.names)}"
            )
        object.__setattr__(self, "factors", F)
        object.__setattr__(self, "sizes", sizes)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.factors.shape[1]

    @property
    def n_parameters(self) -> int:
        """Number of parameters p."""
        return self.factors.shape[2] - 1

    @property
    def n_samples(self) -> int:
        """Number of samples N (all segments)."""
        return int(self.sizes.sum())

    @property
    def n_rows(self) -> int:
        """Number of equations N n."""
        return self.n_samples * self.n_joints

    @property
    def boundaries(self) -> np.ndarray:
        """(S + 1,) first sample of each segment, then N."""
        return np.concatenate([[0], np.cumsum(self.sizes)])

    def check_overdetermined(self) -> None:
        """Raises ValueError unless there are more equations than parameters."""
        _check_overdetermined(self.n_samples, self.n_joints, self.n_parameters)

    def segments_before(self, k: int) -> int:
        """The number of segments holding the first ``k`` samples.

        Raises:
          ValueError: ``k`` is not a segment boundary.
        """
        hits = np.flatnonzero(self.boundaries == k)
        if not hits.size:
            raise ValueError(
                f"observations: no segment boundary at sample {k} (boundaries "
                f"{', '.join(str(b) for b in self.boundaries)})"
            )
        return int(hits[0])

    def factor(
        self, weights: np.ndarray | None = None, segments: slice = slice(None)
    ) -> np.ndarray:
        """(p + 1, p + 1) upper-triangular factor [[R, c], [0, rho]] of the
        whole system of ``segments``, joint j's rows multiplied by
        ``weights[j]`` (1/(N m) or 1/N; None: 1): R^T R = A_w^T A_w,
        ||A_w x - b_w||^2 = ||R x - c||^2 + rho^2. One QR of the stacked
        factors (n (p + 1) rows per segment)."""
        F = self.factors[segments]
        if weights is not None:
            w = as_finite_array(weights, "weights", (self.n_joints,))
            F = F * w[None, :, None, None]
        q = F.shape[-1]
        out = np.zeros((q, q))
        R = np.linalg.qr(F.reshape(-1, q), mode="r")
        out[: R.shape[0]] = R
        return out

    def minimum_norm_solution(self, segments: slice = slice(None)) -> np.ndarray:
        """(p,) the minimum-norm least-squares x of the system of ``segments``
        (SI units of each parameter), with the singular-value cut-off numpy's
        lstsq would use on the tall system (eps max(rows, p))."""
        F, p = self.factor(segments=segments), self.n_parameters
        rows = int(self.sizes[segments].sum()) * self.n_joints
        rcond = np.finfo(np.float64).eps * max(rows, p)
        return np.linalg.lstsq(F[:p, :p], F[:p, p], rcond=rcond)[0]

    def _sum_squares(self, v: np.ndarray, segments: slice) -> np.ndarray:
        """(n,) sum over ``segments`` of ||F_sj v||^2."""
        r = self.factors[segments] @ v
        return np.sum(r**2, axis=(0, 2))

    def residual_sum_squares(
        self, x: np.ndarray, segments: slice = slice(None)
    ) -> np.ndarray:
        """(n,) ||b_j - A_j x||^2 per joint over ``segments``, (N m)^2 or N^2."""
        x = as_finite_array(x, "x", (self.n_parameters,))
        return self._sum_squares(np.append(x, -1.0), segments)

    def prediction_sum_squares(self, d: np.ndarray) -> np.ndarray:
        """(n,) ||A_j d||^2 per joint (all segments), (N m)^2 or N^2."""
        d = as_finite_array(d, "d", (self.n_parameters,))
        return self._sum_squares(np.append(d, 0.0), slice(None))

    def column_sum_squares(self) -> np.ndarray:
        """(n, p + 1) squared column norms of [A_j b_j] per joint: the
        parameters' columns, then ||b_j||^2."""
        return np.sum(self.factors**2, axis=(0, 2))

    def with_efforts(self, x: np.ndarray) -> ReducedObservations:
        """The same A with b = A x (zero residual): Q_j^T A_j x = R_j x."""
        x = as_finite_array(x, "x", (self.n_parameters,))
        F = self.factors.copy()
        p = self.n_parameters
        F[..., p] = 0.0
        F[..., :p, p] = F[..., :p, :p] @ x
        return ReducedObservations(F, self.sizes, self.names)

    def negated(self, j: int) -> ReducedObservations:
        """The same system with joint j's efforts negated."""
        F = self.factors.copy()
        F[:, j, :, -1] *= -1.0
        return ReducedObservations(F, self.sizes, self.names)


class ObservationReducer:
    """Reduces A x = b block by block of samples to :class:`ReducedObservations`
    (module docstring): the factor of the current segment so far is stacked on
    each new block and factored again (one batched QR per block), so memory is
    O(n p^2) besides the caller's block.

    Args:
      n_joints, n_parameters: n and p.
      names: optional names of the p parameters.
      boundaries: sample indices (counted over every block added) where a
        new segment starts; blocks that cross one are cut there.
    """

    def __init__(
        self,
        n_joints: int,
        n_parameters: int,
        names: Sequence[str] | None = None,
        *,
        boundaries: Sequence[int] = (),
    ) -> None:
        self.n_joints = n_joints
        self.n_parameters = n_parameters
        self.names = None if names is None else tuple(names)
        self._cuts = sorted({int(k) for k in boundaries if int(k) > 0})
        self._closed: list[np.ndarray] = []
        self._sizes: list[int] = []
        self._F: np.ndarray | None = None  # (n, k <= p + 1, p + 1)
        self._count = 0  # samples in the current segment
        self._seen = 0  # samples added

    def add(self, Y: np.ndarray, tau: np.ndarray) -> None:
        """Adds a block: regressor rows Y (B, n, p), N m (N) per parameter
        unit, and efforts tau (B, n), N m or N."""
        n, p = self.n_joints, self.n_parameters
        Y = as_finite_array(Y, "regressor Y", (None, n, p))
        tau = as_finite_array(tau, "tau", (Y.shape[0], n))
        start = 0
        while start < Y.shape[0]:
            if self._cuts and self._cuts[0] == self._seen:
                self._cuts.pop(0)
                self.split()
            stop = Y.shape[0]
            if self._cuts:
                stop = min(stop, self._cuts[0] - self._seen + start)
            self._fold(Y[start:stop], tau[start:stop])
            self._seen += stop - start
            start = stop

    def _fold(self, Y: np.ndarray, tau: np.ndarray) -> None:
        """One batched QR: the current factor stacked on the block."""
        n, p = self.n_joints, self.n_parameters
        B = Y.shape[0]
        k = 0 if self._F is None else self._F.shape[1]
        M = np.empty((n, k + B, p + 1))
        if k:
            M[:, :k] = self._F
        M[:, k:, :p] = Y.transpose(1, 0, 2)
        M[:, k:, p] = tau.T
        self._F = np.linalg.qr(M, mode="r")
        self._count += B

    def split(self) -> None:
        """Ends the current segment: later blocks start a new one (no-op when
        the current segment is empty)."""
        if self._F is None:
            return
        q = self.n_parameters + 1
        F = np.zeros((self.n_joints, q, q))
        F[:, : self._F.shape[1]] = self._F
        self._closed.append(F)
        self._sizes.append(self._count)
        self._F, self._count = None, 0

    def result(self) -> ReducedObservations:
        """The factors of every segment (ends the current one).

        Raises:
          ValueError: no samples were added.
        """
        self.split()
        if not self._closed:
            raise ValueError("observations: expected at least one sample, found 0")
        return ReducedObservations(
            np.stack(self._closed), np.array(self._sizes), self.names
        )


def reduced(obs: Observations | ReducedObservations) -> ReducedObservations:
    """``obs`` reduced to triangular factors (itself when already reduced)."""
    return obs if isinstance(obs, ReducedObservations) else obs.reduce()
