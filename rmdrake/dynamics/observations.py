"""The linear system A x = b that every identification estimator solves.

Stacking the base regressor Y_base(q_k, qd_k, qdd_k) (n rows per sample k) and
the measured joint torques tau_k over N samples gives the over-determined system
(paper eq. 14-15)

    A x = b,   A: (N n, p) in N m (N) per parameter unit,   b: (N n,) in N m (N),

with x the p base parameters. Rows are sample-major: row ``k * n + j`` is joint
j of sample k, so ``A[j::n]`` are joint j's rows. The system needs more
equations than parameters (N n > p) and, for a unique solution, rank p (a
trajectory that excites every base parameter).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from rmdrake.arrays import as_finite_array

__all__ = ["Observations"]


@dataclasses.dataclass(frozen=True)
class Observations:
    """The over-determined system A x = b (see the module docstring).

    Attributes:
      A: (N n, p) stacked regressor (base columns), rows sample-major.
      b: (N n,) stacked measured efforts, N m (N on a prismatic joint).
      n_joints: n.
      names: optional names of the p parameters (columns of A).
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
        if self.A.shape[0] <= self.n_parameters:
            raise ValueError(
                f"observations: {self.A.shape[0]} equations ({self.n_samples} "
                f"samples x {self.n_joints} joints) for {self.n_parameters} "
                "parameters; expected more equations than parameters (a longer log)"
            )

    def joint_rows(self, j: int) -> slice:
        """Rows of joint j (0-based) in A and b."""
        return slice(j, None, self.n_joints)

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Efforts A x as (N, n), N m or N."""
        return (self.A @ x).reshape(-1, self.n_joints)

    def torques(self) -> np.ndarray:
        """Measured efforts b as (N, n), N m or N."""
        return self.b.reshape(-1, self.n_joints)
