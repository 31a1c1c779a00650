"""The physically consistent least-squares estimator (cvxpy + Clarabel).

:class:`PhysicalLeastSquares` follows the estimator contract of
:mod:`rmdrake.dynamics.estimators` (which re-exports it): it fits the full
standard parameters under each link's pseudo-inertia >= 0 (Wensing et al.
2017), mass bounds per link and in total, and non-negative friction, with a
prior and a regularisation weight (fixed, or chosen by generalised
cross-validation); or, given base parameters, finds the physically consistent
model nearest the prior that reproduces them exactly.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.estimators import WeightedLeastSquares
from rmdrake.dynamics.observations import (
    Observations,
    ReducedObservations,
    reduced,
)
from rmdrake.model.dynamic_parameters import pseudo_inertia

__all__ = ["PhysicalLeastSquares", "lift_to_physical", "pseudo_inertia_map"]


def lift_to_physical(chi: np.ndarray, n: int, per: int) -> np.ndarray:
    """``chi`` with each link's pseudo-inertia lifted onto the PSD cone.

    An interior-point solver returns points on the cone's boundary with
    eigenvalues of about -1e-10 kg m^2; every consumer (the plant, the
    controllers) checks strictly. Adding eps to J's diagonal, i.e. eps kg of
    mass at the link origin (M += eps, XX, YY, ZZ += 2 eps, first moments kept),
    with eps = the negative eigenvalue plus 1e-12 of the largest, makes it a
    mass distribution and moves the predictions by round-off only.

    Args:
      chi: (per n + extra,) parameters, link-major, ``per`` (>= 10) per link.
    """
    x = np.array(chi, dtype=np.float64)
    for j in range(n):
        c = x[j * per : (j + 1) * per]
        eig = np.linalg.eigvalsh(pseudo_inertia(c))
        if eig[0] < 0:
            eps = -eig[0] + 1e-12 * max(abs(eig[-1]), 1e-300)
            c[9] += eps
            c[[0, 3, 5]] += 2 * eps
    return x


def pseudo_inertia_map() -> np.ndarray:
    """(16, 10): vec(J) = T @ (first 10 standard parameters of a link)."""
    return np.stack([pseudo_inertia(e).ravel() for e in np.eye(10)], axis=1)


def _prior_scale(prior: np.ndarray, per: int, n: int | None = None) -> np.ndarray:
    """(m,) scale of each standard parameter in the prior's distance: |prior|,
    at least a tenth of the largest |prior| of its kind in its link (inertia
    entries, first moments, mass, Ia, fv, fc), else 1 SI unit when that kind is
    zero in the prior."""
    groups = [slice(0, 6), slice(6, 9), *(slice(k, k + 1) for k in range(9, per))]
    n = prior.size // per if n is None else n
    links = np.abs(prior[: per * n]).reshape(-1, per)
    floor = np.empty_like(links)
    for g in groups:
        top = links[:, g].max(axis=1, keepdims=True)
        floor[:, g] = np.where(top > 0, 0.1 * top, 1.0)
    out = [np.maximum(links, floor).ravel()]
    rest = np.abs(prior[per * n : 15 * n]) if per == 13 else np.zeros(0)
    for extra in rest.reshape(-1, n):  # fcn, tau0 (each n)
        top = extra.max()
        out.append(np.maximum(extra, 0.1 * top if top > 0 else 1.0))
    motors = np.abs(prior[15 * n :]).reshape(-1, 3) if per == 13 else np.zeros((0, 3))
    for m in motors:  # a coupled motor's Iam, fvm, fcm: like the links' Ia, fv, fc
        top = links[:, 10:].max(axis=0) if links.shape[1] > 10 else np.zeros(3)
        out.append(np.maximum(m, np.where(top > 0, 0.1 * top, 1.0)))
    return np.concatenate(out)


class PhysicalLeastSquares:
    """Physically consistent least squares (cvxpy + Clarabel).

    Decision variables: the full standard parameters chi (13 per link, or the
    per-link count of ``K``; or the (15n,) extended vector of
    :mod:`rmdrake.model.dynamic_parameters` when ``K`` has 15n columns, with
    fcn_j >= 0 and the offsets tau0_j free; or 15n + 3k columns with k
    coupled motors, whose Iam, fvm, fcm are >= 0 like each link's Ia, fv,
    fc). Problem::

        minimise    ||A K chi - b||^2 + lambda ||(chi - prior) / scale||^2
        subject to  J_j(chi) >= 0 (4x4 pseudo-inertia, PSD),
                    min_mass_j <= M_j <= max_mass_j, Ia_j, fv_j, fc_j >= 0
                    for every link j, and total_mass[0] <= sum_j M_j <= total_mass[1]

    where A K chi are the torques of the base parameters K chi. The problem
    is posed on the triangular factor of A x = b
    (:class:`~rmdrake.dynamics.observations.ReducedObservations`):
    ||A K chi - b||^2 = ||R K chi - c||^2 + rho^2, p rows whatever N (same
    minimiser, much smaller problem; given dense observations, ``fit``
    reduces them once).
    ``scale`` is |prior|, at least a tenth of the largest |prior| of the same
    kind in the same link (1 SI unit where that kind is all zero).
    lambda = rho ||A K||_F^2 / (number of chi), with rho = ``regularization``:

    - a number (default 1e-10: tiny, so the data decide every identifiable
      combination and the prior, or zero when none is given, only picks the
      point in the unidentifiable directions);
    - ``"gcv"``: rho minimising the generalised cross-validation score
      (Golub, Heath and Wahba 1979) of the same problem without the physical
      constraints (a ridge regression toward the prior, closed form from one
      SVD), GCV(rho) = N ||r(rho)||^2 / (N - tr H(rho))^2 over rho in
      10^-10 .. 10^1 (45 values, log-spaced); the constrained problem is then
      solved with that rho. Noise-free data give the smallest rho.

    Stage 2: the weight cannot fix the directions the data do not see (it is
    small next to the solver's tolerance there), so the result is then moved,
    keeping its base parameters K chi exactly, to the physically consistent
    point nearest the prior (the ``base_target`` problem below; stage 1's
    point is kept if that solve fails).

    With ``base_target`` (nb,) the problem is instead the feasibility problem
    of writing given base parameters as a physically consistent model: minimise
    ||(chi - prior) / scale||^2 subject to K chi = base_target and the
    constraints above (no data term); the solution is then corrected onto
    K chi = base_target exactly (minimum-norm step, round-off size).

    With ``weights="gautier"`` each joint's rows are
    first divided by that joint's residual standard deviation from an OLS fit,
    as in :class:`WeightedLeastSquares` (joints whose torques are 50x smaller,
    like a wrist's, then count as much as the shoulder's).

    With ``diagnose`` (default) a failed solve is explained by solving each
    link's constraints alone (n + 1 more solves) to name the infeasible ones;
    ``diagnose=False`` reports the solver status only (for callers that fall
    back to another problem on any failure).

    The attributes are set by ``fit``.

    Attributes:
      chi_: (m,) physically consistent standard parameters.
      params_: (p,) base parameters K chi_.
      regularization_: the rho used; gcv_: (45, 2) [rho, GCV score] or None.
      status_: Clarabel's status string; solve_time_: s (build + solve).
      residual_rms_: (n,) per joint, N m or N.

    The errors below are raised by ``fit``.

    Raises:
      ValueError: if the problem is infeasible (e.g. impossible mass bounds,
        or ``base_target`` with no physically consistent realisation), with
        the solver status and the links whose constraints conflict.

    Example:

    >>> from rmdrake import Observations, PhysicalLeastSquares, base_parameters
    >>> from rmdrake import load_robot, random_fourier_trajectory, standard_parameters
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> chi = standard_parameters(robot)
    >>> base = base_parameters(robot)
    >>> Y = base.regressor(robot, q, qd, qdd)
    >>> obs = Observations.from_regressor(Y, torques(robot, q, qd, qdd, chi))
    >>> fit = PhysicalLeastSquares(K=base.K_full).fit(obs)
    >>> fit.chi_.shape, bool(abs(fit.params_ - base.regroup(chi)).max() < 1e-4)
    ((78,), True)
    """

    def __init__(
        self,
        *,
        K: np.ndarray,
        prior: np.ndarray | None = None,
        regularization: float | str = 1e-10,
        min_mass: float | np.ndarray = 1e-3,
        max_mass: np.ndarray | None = None,
        total_mass: tuple[float, float] | None = None,
        base_target: np.ndarray | None = None,
        solver: str = "CLARABEL",
        solver_options: dict | None = None,
        weights: str | None = None,
        diagnose: bool = True,
    ) -> None:
        self.K = K
        self.diagnose = diagnose
        self.weights = weights
        self.prior = prior
        self.regularization = regularization
        self.min_mass = min_mass
        self.max_mass = max_mass
        self.total_mass = total_mass
        self.base_target = base_target
        self.solver = solver
        # Clarabel's default tolerances (1e-8) left 3e-5 relative error on
        # noise-free base parameters of the RV-3SB; 1e-10 (and a regulariser of
        # 1e-10) gives 2e-7 in the same time.
        self.solver_options = (
            dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
            if solver_options is None and solver == "CLARABEL"
            else dict(solver_options or {})
        )

    def _mass_bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(n,) lower and upper mass bounds per link, kg (upper may be inf)."""
        lo = np.broadcast_to(np.asarray(self.min_mass, dtype=np.float64), (n,))
        hi = (
            np.full(n, np.inf)
            if self.max_mass is None
            else np.broadcast_to(np.asarray(self.max_mass, dtype=np.float64), (n,))
        )
        return lo, hi

    def _constraints(self, chi, n: int, per: int, links=None) -> list:
        import cvxpy as cp

        T = pseudo_inertia_map()
        lo, hi = self._mass_bounds(n)
        cons = []
        for j in range(n) if links is None else links:
            c = chi[j * per : (j + 1) * per]
            J = cp.reshape(T @ c[:10], (4, 4), order="C")
            cons.append(0.5 * (J + J.T) >> 0)
            cons.append(c[9] >= float(lo[j]))
            if np.isfinite(hi[j]):
                cons.append(c[9] <= float(hi[j]))
            if per > 10:
                cons.append(c[10:] >= 0)
        if links is None and chi.shape[0] >= 15 * n:  # fcn >= 0 (tau0 free)
            cons.append(chi[13 * n : 14 * n] >= 0)
        if links is None and chi.shape[0] > 15 * n:  # coupled motors' terms
            cons.append(chi[15 * n :] >= 0)
        if links is None and self.total_mass is not None:
            total = cp.sum(chi[9 : per * n : per])
            t_lo, t_hi = (float(v) for v in self.total_mass)
            if np.isfinite(t_lo):
                cons.append(total >= t_lo)
            if np.isfinite(t_hi):
                cons.append(total <= t_hi)
        return cons

    @staticmethod
    def _gcv(
        AK: np.ndarray, r0: np.ndarray, scale: np.ndarray, rest: float, rows: int
    ) -> np.ndarray:
        """(45, 2) [rho, GCV(rho)] of the ridge problem without constraints
        (class docstring); AK, r0 = c - AK prior are the QR-compressed system."""
        s, U = np.linalg.svd(AK * scale, full_matrices=False)[1::-1]
        cu = U.T @ r0
        rho = np.logspace(-10.0, 1.0, 45)
        lam = rho[:, None] * float(np.sum(AK**2)) / AK.shape[1]
        shrink = lam / (s**2 + lam)
        resid = rest + np.sum((shrink * cu) ** 2, axis=1)
        dof = rows - np.sum(s**2 / (s**2 + lam), axis=1)
        return np.stack([rho, rows * resid / np.maximum(dof, 1e-300) ** 2], axis=1)

    def fit(self, obs: Observations | ReducedObservations) -> PhysicalLeastSquares:
        import cvxpy as cp

        t0 = time.perf_counter()
        obs.check_overdetermined()
        obs = reduced(obs)
        K = as_finite_array(self.K, "K", (obs.n_parameters, None))
        m = K.shape[1]
        n = obs.n_joints
        motors = (m - 15 * n) // 3 if m > 15 * n else 0
        if (m - 3 * motors) % n or (m - 3 * motors) // n not in (10, 11, 13, 15):
            raise ValueError(
                f"K: expected 10, 11, 13 (or 15: extended, plus 3 per coupled "
                f"motor) parameters per link for {n} links, found {m} columns"
            )
        per = min(m // n, 13)
        prior = (
            np.zeros(m)
            if self.prior is None
            else as_finite_array(self.prior, "prior", (m,))
        )
        scale = _prior_scale(prior, per, n)
        if self.weights not in (None, "gautier"):
            raise ValueError(
                f"weights: expected None or 'gautier', found {self.weights!r}"
            )
        chi = cp.Variable(m)
        cons = self._constraints(chi, n, per)
        self.gcv_ = None
        if self.base_target is not None:
            target = as_finite_array(self.base_target, "base_target", (K.shape[0],))
            self.regularization_ = 0.0
            objective = cp.sum_squares(cp.multiply(1.0 / scale, chi - prior))
            row = np.maximum(np.abs(K).max(axis=1), 1e-300)
            cons.append((K / row[:, None]) @ chi == target / row)
        else:
            objective = self._data_objective(obs, K, prior, scale, chi)
        problem = cp.Problem(cp.Minimize(objective), cons)
        with warnings.catch_warnings():
            # cvxpy warns on 'optimal_inaccurate'; status_ records it and the
            # solution is re-checked against every constraint below.
            warnings.filterwarnings("ignore", "Solution may be inaccurate")
            try:
                problem.solve(solver=self.solver, **self.solver_options)
                self.status_ = str(problem.status)
            except cp.error.SolverError:  # numerical failure, not a verdict
                self.status_ = f"{self.solver} failed"
        if self.status_ not in ("optimal", "optimal_inaccurate"):
            if not self.diagnose:
                raise ValueError(
                    "physically consistent fit failed: solver status "
                    f"'{self.status_}' (not diagnosed)"
                )
            raise ValueError(self._diagnose(self.status_, n, per, m))
        x = np.asarray(chi.value, dtype=np.float64)
        if self.base_target is not None:
            # Onto K chi = target exactly: the smallest step in the scale metric.
            S = scale**2
            x = x + S * (K.T @ np.linalg.solve((K * S) @ K.T, target - K @ x))
        violated = self._violations(x, n, per)
        if violated:
            raise ValueError(
                f"physically consistent fit failed: solver status '{problem.status}'"
                f" but the solution violates {'; '.join(violated)} (contradictory "
                "bounds?)"
            )
        if self.base_target is None:
            x = self._nearest_prior(obs, K @ x, x)
        x = lift_to_physical(x, n, per)
        self.chi_ = x
        self.params_ = K @ x
        rss = obs.residual_sum_squares(self.params_)
        self.residual_rms_ = np.sqrt(rss / obs.n_samples)
        self.solve_time_ = time.perf_counter() - t0
        return self

    def _nearest_prior(
        self, obs: ReducedObservations, target: np.ndarray, x: np.ndarray
    ) -> np.ndarray:
        """Stage 2 (class docstring): the model nearest the prior with base
        parameters ``target``; ``x`` (stage 1, feasible) if the solver fails."""
        options = {k: getattr(self, k) for k in ("min_mass", "max_mass")}
        again = PhysicalLeastSquares(
            K=self.K,
            prior=self.prior,
            base_target=target,
            total_mass=self.total_mass,
            solver=self.solver,
            solver_options=self.solver_options,
            diagnose=False,
            **options,
        )
        try:
            return again.fit(obs).chi_
        except ValueError:
            return x

    def _data_objective(self, obs: ReducedObservations, K, prior, scale, chi):
        """The least-squares objective of the class docstring (cvxpy), with
        rho chosen (and ``regularization_``, ``gcv_`` set)."""
        import cvxpy as cp

        p = obs.n_parameters
        w = None
        if self.weights == "gautier":
            sigma = WeightedLeastSquares().fit(obs).joint_sigma_
            torque_rms = np.sqrt(obs.column_sum_squares()[:, p].sum() / obs.n_rows)
            # Noise-free data leave residuals at round-off: no weights then.
            if sigma.max() > 1e-9 * float(torque_rms):
                w = 1.0 / sigma
        F = obs.factor(w)
        R, c = F[:p, :p], F[:p, p]
        AK = R @ K
        m = K.shape[1]
        norm = max(float(np.linalg.norm(AK)), 1e-300)
        if isinstance(self.regularization, str):
            if self.regularization != "gcv":
                raise ValueError(
                    "regularization: expected a number or 'gcv', found "
                    f"{self.regularization!r}"
                )
            rest = float(F[p, p] ** 2)
            self.gcv_ = self._gcv(AK, c - AK @ prior, scale, rest, obs.n_rows)
            self.regularization_ = float(self.gcv_[np.argmin(self.gcv_[:, 1]), 0])
        else:
            self.regularization_ = float(self.regularization)
        lam = self.regularization_ * norm**2 / m
        return cp.sum_squares((AK @ chi - c) / norm) + (lam / norm**2) * (
            cp.sum_squares(cp.multiply(1.0 / scale, chi - prior))
        )

    def _violations(self, x: np.ndarray, n: int, per: int) -> list[str]:
        """Constraints the returned solution breaks beyond solver tolerance."""
        out = []
        lo, hi = self._mass_bounds(n)
        for j in range(n):
            c = x[j * per : (j + 1) * per]
            tol = 1e-6 * max(abs(c[9]), lo[j], 1e-9)
            if c[9] < lo[j] - tol:
                out.append(f"link {j + 1} mass {c[9]:.3g} < min_mass {lo[j]:g}")
            if c[9] > hi[j] + tol:
                out.append(f"link {j + 1} mass {c[9]:.3g} > max_mass {hi[j]:g}")
            eig = np.linalg.eigvalsh(pseudo_inertia(c))
            if eig[0] < -1e-6 * max(abs(eig[-1]), 1e-12):
                out.append(f"link {j + 1} pseudo-inertia eigenvalue {eig[0]:.3g} < 0")
        if self.total_mass is not None:
            total, (t_lo, t_hi) = float(np.sum(x[9 : per * n : per])), self.total_mass
            if not t_lo - 1e-6 * abs(t_lo) <= total <= t_hi + 1e-6 * abs(t_hi):
                out.append(f"total mass {total:.4g} outside {t_lo:g}..{t_hi:g}")
        return out

    def _diagnose(self, status: str, n: int, per: int, m: int) -> str:
        """Names the links whose own constraints are infeasible, or the total
        mass bound against the links' bounds, or the base-parameter target."""
        import cvxpy as cp

        bad = []
        for j in range(n):
            chi = cp.Variable(m)
            prob = cp.Problem(cp.Minimize(0), self._constraints(chi, n, per, [j]))
            try:
                prob.solve(solver=self.solver, **self.solver_options)
            except cp.error.SolverError:
                continue  # a numerical failure says nothing about the link
            if prob.status not in ("optimal", "optimal_inaccurate"):
                bad.append(f"link {j + 1}")
        lo, hi = self._mass_bounds(n)
        t_lo, t_hi = self.total_mass if self.total_mass is not None else (0, np.inf)
        if bad:
            where = (
                f"infeasible constraints on {', '.join(bad)} (mass bounds vs "
                "pseudo-inertia >= 0)"
            )
        elif lo.sum() > t_hi or hi.sum() < t_lo:
            where = (
                f"total mass bounds {t_lo:g}..{t_hi:g} kg conflict with the links' "
                f"mass bounds (sum {lo.sum():g}..{hi.sum():g} kg)"
            )
        elif self.base_target is not None:
            where = (
                "the base parameters have no physically consistent realisation "
                "within the bounds"
            )
        else:
            where = "no single link is infeasible alone; check the bounds together"
        return f"physically consistent fit failed: solver status '{status}'; {where}"

    def predict(self, obs: Observations) -> np.ndarray:
        """Estimated efforts (N, n) for other observations, N m or N."""
        return obs.predict(self.params_)
