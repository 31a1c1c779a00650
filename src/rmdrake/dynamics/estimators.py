"""Estimators of the base dynamic parameters from :class:`Observations` A x = b.

Every estimator follows the scikit-learn contract: ``__init__`` only stores its
(keyword) options, ``fit(observations)`` validates them and the data, solves and
returns ``self``, and results are attributes ending in ``_`` (``params_``: the
(p,) base parameters in SI units; ``residual_rms_``: (n,) per-joint RMS of
b - A x, N m or N). They see only A x = b, so they run on logged real data as
well as on simulation. ``fit`` takes the dense :class:`Observations` or the
already reduced :class:`~rmdrake.dynamics.observations.ReducedObservations`;
either way the estimators work from the small triangular factors (one
reduction of the tall system per fit, none when given reduced observations):
solutions, residuals, covariances and condition numbers are those of A x = b
(an orthogonal Q changes no norm), at a cost independent of N.

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

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.observations import (
    Observations,
    ReducedObservations,
    reduced,
)

__all__ = [
    "DifferentialEvolutionLeastSquares",
    "Estimator",
    "IDENTIFICATION_METHODS",
    "Observations",
    "OrdinaryLeastSquares",
    "ReducedObservations",
    "WeightedLeastSquares",
]

IDENTIFICATION_METHODS: tuple[str, ...] = ("ols", "wls", "de", "physical")
"""The ``method`` names of :func:`rmdrake.dynamics.identification.identify`:
ordinary and (Gautier-)weighted least squares, the paper's differential
evolution, and the physically consistent least squares (with Gautier's joint
weights)."""


@runtime_checkable
class Estimator(Protocol):
    """What every estimator of this module provides after ``fit``.

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import Observations
    >>> rng = np.random.default_rng(0)
    >>> A = rng.normal(size=(200, 3))  # 100 samples x 2 joints, 3 parameters
    >>> x_true = np.array([1.0, -2.0, 0.5])
    >>> obs = Observations(A, A @ x_true, n_joints=2)
    >>> from rmdrake.dynamics import Estimator, OrdinaryLeastSquares
    >>> fitted: Estimator = OrdinaryLeastSquares().fit(obs)
    >>> fitted.params_.shape, fitted.std_.shape
    ((3,), (3,))
    """

    params_: np.ndarray
    """(p,) identified base parameters (SI units of each parameter)."""
    residual_rms_: np.ndarray
    """(n,) per-joint RMS of the fitting residual b - A x, N m or N."""

    def fit(self, obs: Observations | ReducedObservations) -> Self:
        """Validates, solves and returns self."""
        ...

    def predict(self, obs: Observations) -> np.ndarray:
        """Estimated efforts (N, n) for other observations, N m or N."""
        ...


def _solve_ls(
    R: np.ndarray, c: np.ndarray, rcond: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares R x ~ c (R (p, p) triangular: the factor of A, so the
    minimiser of ||A x - b||) by pivoted QR of R, whose |diagonal| is that of
    the pivoted QR of A, with a rank check. Returns x, the pivoted R, perm."""
    import scipy.linalg  # here: the method names are read with no scipy

    Q, Rp, perm = scipy.linalg.qr(R, pivoting=True)
    d = np.abs(np.diag(Rp))
    rank = int(np.sum(d > rcond * d[0])) if d.size and d[0] > 0 else 0
    if rank < R.shape[1]:
        raise ValueError(
            f"observation matrix has rank {rank} < {R.shape[1]} parameters "
            f"(|R_ii| below {rcond:g} |R_11|): the trajectory does not excite "
            "every base parameter, or the parameter set is not a base set"
        )
    y = scipy.linalg.solve_triangular(Rp, Q.T @ c)
    x = np.empty_like(y)
    x[perm] = y
    return x, Rp, perm


def _least_squares(
    obs: ReducedObservations, rcond: float, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_solve_ls` of the (joint-weighted) system of ``obs``."""
    F = obs.factor(weights)
    p = obs.n_parameters
    return _solve_ls(F[:p, :p], F[:p, p], rcond)


class OrdinaryLeastSquares:
    """Ordinary least squares, paper eq. 18: x = argmin ||A x - b||^2.

    The attributes are set by ``fit``.

    Attributes:
      params_: (p,) base parameters.
      std_: (p,) standard deviations, sigma^2 (A^T A)^-1 with sigma^2 the
        residual variance ||b - A x||^2 / (rows - p).
      relative_std_: (p,) 100 std / |x|, %.
      sigma_: residual standard deviation, N m (N on prismatic rows).
      residual_rms_: (n,) RMS of b - A x per joint, N m or N.
      cond_: condition number of A.

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import Observations
    >>> rng = np.random.default_rng(0)
    >>> A = rng.normal(size=(200, 3))  # 100 samples x 2 joints, 3 parameters
    >>> x_true = np.array([1.0, -2.0, 0.5])
    >>> obs = Observations(A, A @ x_true, n_joints=2)
    >>> from rmdrake.dynamics import OrdinaryLeastSquares
    >>> ols = OrdinaryLeastSquares().fit(obs)
    >>> ols.params_.round(6).tolist()
    [1.0, -2.0, 0.5]
    """

    def __init__(self, *, rcond: float = 1e-10) -> None:
        self.rcond = rcond

    def _fit_weighted(self, obs: ReducedObservations, w: np.ndarray) -> None:
        """Solves with joint j's rows multiplied by w[j] (n,); std_ from the
        weighted problem."""
        import scipy.linalg

        x, R, perm = _least_squares(obs, self.rcond, w)
        m, p = obs.n_rows, obs.n_parameters
        sigma2 = float(np.sum(w**2 * obs.residual_sum_squares(x)) / (m - p))
        Rinv = scipy.linalg.solve_triangular(R, np.eye(p))
        var = np.empty(p)
        var[perm] = np.sum(Rinv**2, axis=1) * sigma2
        self._store(obs, x, var)

    def _store(self, obs: ReducedObservations, x: np.ndarray, var: np.ndarray) -> None:
        """Sets the results of solution ``x`` with parameter variances ``var``:
        params_, std_, relative_std_, residual_rms_, sigma_ and cond_."""
        m, p = obs.n_rows, obs.n_parameters
        self.params_ = x
        self.std_ = np.sqrt(var)
        with np.errstate(divide="ignore"):
            self.relative_std_ = 100.0 * self.std_ / np.abs(x)
        rss = obs.residual_sum_squares(x)
        self.residual_rms_ = np.sqrt(rss / obs.n_samples)
        self.sigma_ = float(np.sqrt(np.sum(rss) / (m - p)))
        s = np.linalg.svd(obs.factor()[:p, :p], compute_uv=False)
        self.cond_ = float(s[0] / s[-1])

    def fit(self, obs: Observations | ReducedObservations) -> OrdinaryLeastSquares:
        obs.check_overdetermined()
        obs = reduced(obs)
        self._fit_weighted(obs, np.ones(obs.n_joints))
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

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import Observations
    >>> rng = np.random.default_rng(0)
    >>> A = rng.normal(size=(200, 3))  # 100 samples x 2 joints, 3 parameters
    >>> x_true = np.array([1.0, -2.0, 0.5])
    >>> obs = Observations(A, A @ x_true, n_joints=2)
    >>> from rmdrake.dynamics import WeightedLeastSquares
    >>> wls = WeightedLeastSquares().fit(obs)  # rows weighted per joint
    >>> wls.params_.round(6).tolist()
    [1.0, -2.0, 0.5]
    """

    def fit(self, obs: Observations | ReducedObservations) -> WeightedLeastSquares:
        obs.check_overdetermined()
        obs = reduced(obs)
        x, _, _ = _least_squares(obs, self.rcond)
        N, p = obs.n_samples, obs.n_parameters
        p_j = np.count_nonzero(obs.column_sum_squares()[:, :p] > 0, axis=1)
        dof = np.maximum(N - p_j, 1)
        sigma = np.sqrt(obs.residual_sum_squares(x) / dof)
        floor = 1e-12 * max(float(sigma.max()), 1e-300)
        sigma = np.maximum(sigma, floor)
        self.joint_sigma_ = sigma
        self._fit_weighted(obs, 1.0 / sigma)
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

    The population is ``popsize`` per parameter, 5 by default: scipy draws each
    candidate's donors by reshuffling the whole population, so a generation
    costs the square of its size, and a larger population converges no
    closer to the OLS solution in the same number of generations.

    Extra attributes after ``fit``: ``cost_`` (||A x - b||^2), ``result_``.

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import Observations
    >>> rng = np.random.default_rng(0)
    >>> A = rng.normal(size=(200, 3))  # 100 samples x 2 joints, 3 parameters
    >>> x_true = np.array([1.0, -2.0, 0.5])
    >>> obs = Observations(A, A @ x_true, n_joints=2)
    >>> from rmdrake.dynamics import DifferentialEvolutionLeastSquares
    >>> bounds = np.array([[-3.0, 3.0]] * 3)
    >>> de = DifferentialEvolutionLeastSquares(
    ...     bounds=bounds, maxiter=300, progress=False
    ... )
    >>> de.fit(obs).params_.round(2).tolist()
    [1.0, -2.0, 0.5]
    """

    def __init__(
        self,
        *,
        bounds: np.ndarray | None = None,
        prior: np.ndarray | None = None,
        span: float = 1.0,
        floor: float | None = None,
        seed: int = 0,
        popsize: int = 5,
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

    def fit(
        self, obs: Observations | ReducedObservations
    ) -> DifferentialEvolutionLeastSquares:
        from rmdrake.optimize import differential_evolution

        obs.check_overdetermined()
        obs = reduced(obs)
        p, m = obs.n_parameters, obs.n_rows
        if self.bounds is not None:
            bounds = as_finite_array(self.bounds, "bounds", (p, 2))
        elif self.prior is not None:
            prior = as_finite_array(self.prior, "prior", (p,))
            if self.floor is None:
                # Data scale: the value whose torque is 20 % of the RMS torque.
                columns = obs.column_sum_squares().sum(axis=0)
                rms_a = np.sqrt(columns[:p] / m)
                rms_b = float(np.sqrt(columns[p] / m))
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
        F = obs.factor()
        R, c, rest = F[:p, :p], F[:p, p], float(F[p, p] ** 2)

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
        sigma2 = float(np.sum(obs.residual_sum_squares(x)) / (m - p))
        cov = sigma2 * np.linalg.pinv(R.T @ R)
        self._store(obs, x, np.maximum(np.diag(cov), 0.0))
        self.cost_ = float(result.fun)
        self.result_ = result
        return self
