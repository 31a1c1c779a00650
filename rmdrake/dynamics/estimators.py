"""Estimators of the base dynamic parameters from :class:`Observations` A x = b.

Every estimator follows the scikit-learn contract: ``__init__`` only stores its
(keyword) options, ``fit(observations)`` validates them and the data, solves and
returns ``self``, and results are attributes ending in ``_`` (``params_``: the
(p,) base parameters in SI units; ``residual_rms_``: (n,) per-joint RMS of
b - A x, N m or N). They see only A x = b, so they run on logged real data as
well as on simulation.

- :class:`OrdinaryLeastSquares`: paper eq. 18 solved directly (pivoted QR), with
  the standard deviation of every base parameter from sigma^2 (A^T A)^-1.
- :class:`WeightedLeastSquares`: Gautier's weighting; each joint's rows are
  divided by that joint's residual standard deviation from a first OLS.
- :class:`DifferentialEvolutionLeastSquares`: the paper's choice, eq. 18
  minimised by DE inside given bounds (for comparison: slow and less exact).
- :class:`PhysicalLeastSquares` (in :mod:`rmdrake.dynamics.physical_fit`,
  built on :class:`WeightedLeastSquares`): the full standard parameters chi with
  ``||A K chi - b||^2`` minimised subject to every link's 4x4 pseudo-inertia
  being positive semidefinite, mass bounds, Ia, fv, fc >= 0 (cvxpy + Clarabel).
  Its result is a physically valid parameter set that Drake can simulate.
"""

from __future__ import annotations

from typing import Protocol, Self, runtime_checkable

import numpy as np
import scipy.linalg

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.observations import Observations

__all__ = [
    "DifferentialEvolutionLeastSquares",
    "Estimator",
    "Observations",
    "OrdinaryLeastSquares",
    "WeightedLeastSquares",
]


@runtime_checkable
class Estimator(Protocol):
    """What every estimator of this module provides after ``fit``."""

    params_: np.ndarray
    """(p,) identified base parameters (SI units of each parameter)."""
    residual_rms_: np.ndarray
    """(n,) per-joint RMS of the fitting residual b - A x, N m or N."""

    def fit(self, obs: Observations) -> Self:
        """Validates, solves and returns self."""
        ...

    def predict(self, obs: Observations) -> np.ndarray:
        """Estimated efforts (N, n) for other observations, N m or N."""
        ...


def _solve_ls(
    A: np.ndarray, b: np.ndarray, rcond: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares by pivoted QR with a rank check. Returns x, R, perm."""
    Q, R, perm = scipy.linalg.qr(A, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    rank = int(np.sum(d > rcond * d[0])) if d.size and d[0] > 0 else 0
    if rank < A.shape[1]:
        raise ValueError(
            f"observation matrix has rank {rank} < {A.shape[1]} parameters "
            f"(|R_ii| below {rcond:g} |R_11|): the trajectory does not excite "
            "every base parameter, or the parameter set is not a base set"
        )
    y = scipy.linalg.solve_triangular(R, Q.T @ b)
    x = np.empty_like(y)
    x[perm] = y
    return x, R, perm


class OrdinaryLeastSquares:
    """Ordinary least squares, paper eq. 18: x = argmin ||A x - b||^2.

    Attributes after ``fit``:
      params_: (p,) base parameters.
      std_: (p,) standard deviations, sigma^2 (A^T A)^-1 with sigma^2 the
        residual variance ||b - A x||^2 / (rows - p).
      relative_std_: (p,) 100 std / |x|, %.
      sigma_: residual standard deviation, N m (N on prismatic rows).
      residual_rms_: (n,) RMS of b - A x per joint, N m or N.
      cond_: condition number of A.
    """

    def __init__(self, *, rcond: float = 1e-10) -> None:
        self.rcond = rcond

    def _fit_weighted(self, obs: Observations, w: np.ndarray) -> None:
        Aw, bw = obs.A * w[:, None], obs.b * w
        x, R, perm = _solve_ls(Aw, bw, self.rcond)
        m, p = Aw.shape
        sigma2 = float(np.sum((bw - Aw @ x) ** 2) / (m - p))
        Rinv = scipy.linalg.solve_triangular(R, np.eye(p))
        var = np.empty(p)
        var[perm] = np.sum(Rinv**2, axis=1) * sigma2
        self._store(obs, x, var)

    def _store(self, obs: Observations, x: np.ndarray, var: np.ndarray) -> None:
        """Sets the results of solution ``x`` with parameter variances ``var``:
        params_, std_, relative_std_, residual_rms_, sigma_ and cond_."""
        m, p = obs.A.shape
        self.params_ = x
        self.std_ = np.sqrt(var)
        with np.errstate(divide="ignore"):
            self.relative_std_ = 100.0 * self.std_ / np.abs(x)
        residual = (obs.b - obs.A @ x).reshape(-1, obs.n_joints)
        self.residual_rms_ = np.sqrt(np.mean(residual**2, axis=0))
        self.sigma_ = float(np.sqrt(np.sum(residual**2) / (m - p)))
        s = np.linalg.svd(obs.A, compute_uv=False)
        self.cond_ = float(s[0] / s[-1])

    def fit(self, obs: Observations) -> OrdinaryLeastSquares:
        obs.check_overdetermined()
        self._fit_weighted(obs, np.ones(obs.A.shape[0]))
        return self

    def predict(self, obs: Observations) -> np.ndarray:
        """Estimated efforts (N, n) for other observations, N m or N."""
        return obs.predict(self.params_)


class WeightedLeastSquares(OrdinaryLeastSquares):
    """Gautier's weighted least squares.

    A first OLS gives each joint's residual standard deviation
    sigma_j = ||rho_j|| / sqrt(N - p_j) (p_j = columns non-zero in joint j's
    rows); the rows of joint j are then weighted by 1 / sigma_j and solved again.
    ``std_`` comes from the weighted problem.

    Extra attribute after ``fit``: ``joint_sigma_`` (n,), N m or N.
    """

    def fit(self, obs: Observations) -> WeightedLeastSquares:
        obs.check_overdetermined()
        x, _, _ = _solve_ls(obs.A, obs.b, self.rcond)
        residual = obs.b - obs.A @ x
        n, N = obs.n_joints, obs.n_samples
        sigma = np.empty(n)
        for j in range(n):
            rows = obs.joint_rows(j)
            p_j = int(np.count_nonzero(np.any(obs.A[rows] != 0, axis=0)))
            dof = max(N - p_j, 1)
            sigma[j] = np.sqrt(np.sum(residual[rows] ** 2) / dof)
        floor = 1e-12 * max(float(sigma.max()), 1e-300)
        sigma = np.maximum(sigma, floor)
        self.joint_sigma_ = sigma
        self._fit_weighted(obs, np.tile(1.0 / sigma, N))
        return self


class DifferentialEvolutionLeastSquares(OrdinaryLeastSquares):
    """The paper's estimator: eq. 18 minimised by Differential Evolution.

    DE needs a box: give ``bounds`` (p, 2), or a ``prior`` (p,) (e.g. the base
    parameters of the nominal model) and ``span``: the box is prior +- (span
    |prior| + floor), with ``floor`` by default per parameter the value whose
    torque column gives 20 % of the RMS measured torque (so parameters that are
    zero in the prior, e.g. products of inertia of symmetric CAD links, can
    still move). The cost of a whole population is one matrix product on
    the QR-compressed system. For comparison only: it is slower and less exact
    than OLS. ``std_`` is the OLS formula evaluated at the DE solution.

    Extra attributes after ``fit``: ``cost_`` (||A x - b||^2), ``result_``.
    """

    def __init__(
        self,
        *,
        bounds: np.ndarray | None = None,
        prior: np.ndarray | None = None,
        span: float = 1.0,
        floor: float | None = None,
        seed: int = 0,
        popsize: int = 15,
        maxiter: int = 3000,
        progress: bool = True,
    ) -> None:
        super().__init__()
        self.bounds = bounds
        self.prior = prior
        self.span = span
        self.floor = floor
        self.seed = seed
        self.popsize = popsize
        self.maxiter = maxiter
        self.progress = progress

    def fit(self, obs: Observations) -> DifferentialEvolutionLeastSquares:
        from rmdrake.optimize import differential_evolution

        obs.check_overdetermined()
        p = obs.n_parameters
        if self.bounds is not None:
            bounds = as_finite_array(self.bounds, "bounds", (p, 2))
        elif self.prior is not None:
            prior = as_finite_array(self.prior, "prior", (p,))
            if self.floor is None:
                # Data scale: the value whose torque is 20 % of the RMS torque.
                rms_a = np.sqrt(np.mean(obs.A**2, axis=0))
                rms_b = float(np.sqrt(np.mean(obs.b**2)))
                floor = 0.2 * rms_b / np.maximum(rms_a, 1e-300)
            else:
                floor = self.floor
            half = self.span * np.abs(prior) + floor
            bounds = np.stack([prior - half, prior + half], axis=1)
        else:
            raise ValueError(
                "DE identification needs a search box: give bounds or a prior "
                "(e.g. the nominal model's base parameters)"
            )
        Q, R = np.linalg.qr(obs.A)
        c = Q.T @ obs.b
        rest = float(obs.b @ obs.b - c @ c)

        def cost(X: np.ndarray) -> np.ndarray:
            return np.sum((X @ R.T - c) ** 2, axis=1) + rest

        result = differential_evolution(
            cost,
            bounds,
            seed=self.seed,
            popsize=self.popsize,
            maxiter=self.maxiter,
            tol=1e-12,
            progress=self.progress,
            desc="DE identification (eq. 18)",
        )
        x = result.x
        m = obs.A.shape[0]
        sigma2 = float(np.sum((obs.b - obs.A @ x) ** 2) / (m - p))
        cov = sigma2 * np.linalg.pinv(R.T @ R)
        self._store(obs, x, np.maximum(np.diag(cov), 0.0))
        self.cost_ = float(result.fun)
        self.result_ = result
        return self
