"""The identification pipeline: prepared samples in, base parameters and a robot
model with physically consistent per-link dynamics out.

:func:`identify` builds the observations A x = b of the robot's 13-per-link base
parameters (:func:`reduced_observations`; :func:`observations` is the dense
system, for small data and tests), fits them with one of
:data:`IDENTIFICATION_METHODS` (the estimators of
:mod:`rmdrake.dynamics.estimators`) and returns an :class:`Identification`.
:func:`identified_model` writes the robot model: it needs all 13 standard
parameters per link, physically consistent, which only the ``physical`` method
estimates. The written model is the fitted model: for the other methods
:attr:`Identification.chi` is the physically consistent model nearest the prior
whose base parameters equal the fitted ones exactly (a feasibility SDP, cvxpy +
Clarabel, solved on first use only, so :func:`identify` itself is the fit
alone); where no such model exists (real data often give base parameters no
mass distribution has), it is the physically consistent projection (closest in
the data's metric) and :attr:`Identification.written_difference_rms` says by
how much its predictions differ from the fit's on the identification data.
A failed exact solve goes straight to the projection (no per-link diagnosis:
the projection, with the same bounds, raises what the bounds alone forbid), and
both work from the fit's reduced observations: nothing is rebuilt or
re-factored, and the ``physical`` estimate is written as fitted.

Prior and bounds. The prior is a robot model's dynamics (``prior`` argument,
else the identified robot's own ``dynamics``, e.g. CAD inertials imported with
``rmdrake import-urdf``); with a prior the ``physical`` fit's regularisation
weight is chosen by generalised cross-validation
(:class:`~rmdrake.dynamics.physical_fit.PhysicalLeastSquares`), without one it
is 1e-10 toward zero. ``mass_bounds`` (per link, kg) and ``total_mass`` (kg)
constrain every physically consistent model (the fit and the written one).

Data. :func:`identify` never holds the tall (N n, p) observation matrix: the
regressor is built block by block (:func:`reduced_observations`) and each
block folded into the triangular factors of
:class:`~rmdrake.dynamics.observations.ReducedObservations` (one pass, one
QR per block); the estimators, the written model and the sanity checks of
:mod:`rmdrake.dynamics.sanity` work from those factors only. The factors keep
a segment boundary at :data:`HELDOUT_FRACTION` of the samples for the sanity
checks' held-out prediction. Memory: O(n p^2 + block n p) beyond the samples.

Terms. The parameters fitted are those of the robot's dynamic terms
(``terms`` argument, else the model's ``model:`` entry, else the default:
Ia, fv, fc per link; :class:`~rmdrake.model.robot.DynamicTerms`). With asymmetric
Coulomb friction or offsets the fit is on the (15n,) extended vector of
:mod:`rmdrake.model.dynamic_parameters`; a term that is off is not estimated and is
written as 0 (Ia, fv, fc in the 13 per-link keys; ``fcn`` and ``tau0`` are
written only when their term is on), and the identified model records the
terms in its ``model:`` entry. A robot whose transmission has coupled motors
(:mod:`rmdrake.model.transmission`) fits the extended vector with each coupled
motor's ``Iam, fvm, fcm`` too (where Ia, fv, fc are on) and writes them in the
motor's link mapping.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterator

import numpy as np

from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.estimators import (
    IDENTIFICATION_METHODS,
    DifferentialEvolutionLeastSquares,
    Estimator,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.observations import (
    ObservationReducer,
    Observations,
    ReducedObservations,
    heldout_split,
)
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares
from rmdrake.dynamics.regressor import regressor_blocks
from rmdrake.model.dynamic_parameters import extended_parameters, term_columns
from rmdrake.model.robot import DynamicTerms, RobotModel

__all__ = [
    "HELDOUT_FRACTION",
    "Identification",
    "identified_model",
    "identify",
    "fit_summary",
    "observations",
    "parse_mass_range",
    "reduced_observations",
]

HELDOUT_FRACTION: float = 0.7
"""Share of the samples (the first ones) before the segment boundary that
:func:`identify` keeps in its reduced observations: the fitted part of the
held-out check of :func:`rmdrake.dynamics.sanity.check_identification`."""


@dataclasses.dataclass(frozen=True)
class Identification:
    """What :func:`identify` found.

    Attributes:
      method: one of :data:`IDENTIFICATION_METHODS`.
      base: the base parameter set (names, regrouping K).
      params: (nb,) identified base parameters (SI units of each).
      std: (nb,) their standard deviations (None for ``physical``).
      residual_rms: (n,) RMS effort residual on the fitting data, N m or N.
      estimator: the fitted estimator.
      observations: the fitted system A x = b (base columns), reduced to its
        triangular factors (segments split at the held-out boundary).
      prior: (13n,) standard (or (15n,) extended) parameters of the robot
        model the fit started from, the terms that are off set to 0, or None;
        they pick :attr:`chi` in the directions the data cannot see.
      coulomb_width: the Coulomb sign's width in rad/s or m/s (0: sign(qd)).
      bounds: keyword options of the mass bounds (``min_mass``, ``max_mass``,
        ``total_mass``) every physically consistent model here satisfies.

    Example:

    >>> from rmdrake import identify, load_robot, prepare_samples
    >>> from rmdrake import random_fourier_trajectory, standard_parameters
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> result = identify(robot, prepare_samples(t, q, tau, qd, qdd))
    >>> len(result.base.names) == result.params.size, result.std.shape
    (True, (52,))
    """

    method: str
    base: BaseParameters
    params: np.ndarray
    std: np.ndarray | None
    residual_rms: np.ndarray
    estimator: Estimator
    observations: ReducedObservations = dataclasses.field(repr=False)
    prior: np.ndarray | None = dataclasses.field(default=None, repr=False)
    coulomb_width: float = 0.0
    bounds: dict = dataclasses.field(default_factory=dict, repr=False)

    @functools.cached_property
    def _written(self) -> tuple[np.ndarray, bool]:
        chi, exact = self._solve_written()
        chi = chi.copy()
        off = np.setdiff1d(np.arange(chi.size), self.base.standard_columns)
        chi[off] = 0.0  # not in the model: K_full is zero there
        return chi, exact

    def _solve_written(self) -> tuple[np.ndarray, bool]:
        if isinstance(self.estimator, PhysicalLeastSquares):
            return self.estimator.chi_, True
        K = self.base.K_full
        try:  # any failure: the projection below (it raises what the bounds do)
            est = PhysicalLeastSquares(
                K=K,
                prior=self.prior,
                base_target=self.params,
                diagnose=False,
                **self.bounds,
            )
            return est.fit(self.observations).chi_, True
        except ValueError:
            pass
        projected = self.observations.with_efforts(self.params)
        est = PhysicalLeastSquares(K=K, prior=self.prior, **self.bounds)
        return est.fit(projected).chi_, False

    @property
    def chi(self) -> np.ndarray:
        """(13n,) (or (15n,) extended, :attr:`BaseParameters.width`)
        physically consistent parameters of the written model, the terms that
        are off exactly 0: the ``physical`` estimate itself; for the other methods the
        model nearest the prior with exactly the fitted base parameters, or,
        where none exists within the bounds, the projection closest in the
        data's metric (cvxpy + Clarabel on first access, then cached)."""
        return self._written[0]

    @property
    def terms(self) -> DynamicTerms:
        """The dynamic terms fitted."""
        return self.base.terms if self.base.terms is not None else DynamicTerms()

    @property
    def written_exact(self) -> bool:
        """True when :attr:`chi` reproduces the fitted base parameters."""
        return self._written[1]

    @property
    def written_difference_rms(self) -> np.ndarray:
        """(n,) RMS per joint of the difference between the predictions of
        :attr:`chi` and of the fitted base parameters on the identification
        data, N m or N (round-off when :attr:`written_exact`)."""
        obs = self.observations
        d = self.base.K_full @ self.chi - self.params
        return np.sqrt(obs.prediction_sum_squares(d) / obs.n_samples)

    def predict(self, model: RobotModel, samples: JointSamples) -> np.ndarray:
        """Efforts (N, n) of the identified base parameters at ``samples``,
        N m or N (the regressor block by block)."""
        out = np.empty(samples.q.shape)
        for s, Y in _base_blocks(model, self.base, samples, self.coulomb_width):
            out[s] = Y @ self.params
        return out


def _base_blocks(
    model: RobotModel,
    base: BaseParameters,
    samples: JointSamples,
    coulomb_width: float,
) -> Iterator[tuple[slice, np.ndarray]]:
    """:func:`~rmdrake.dynamics.regressor.regressor_blocks` of the base
    columns at ``samples``."""
    return regressor_blocks(
        model,
        samples.q,
        samples.qd,
        samples.qdd,
        base.columns,
        coulomb_width=coulomb_width,
        asymmetric=base.asymmetric,
    )


def observations(
    model: RobotModel,
    base: BaseParameters,
    samples: JointSamples,
    coulomb_width: float = 0.0,
) -> Observations:
    """Observations A x = b (eq. 14-15) of prepared samples, base columns.

    ``coulomb_width`` (rad/s or m/s): 0 for the Coulomb term sign(qd) (real robots);
    the simulator's smooth-sign width
    (:data:`rmdrake.dynamics.friction.DEFAULT_V_EPS`) to identify simulated data
    with the friction law that produced it."""
    Y = base.regressor(
        model, samples.q, samples.qd, samples.qdd, coulomb_width=coulomb_width
    )
    return Observations.from_regressor(Y, samples.tau, base.names)


def reduced_observations(
    model: RobotModel,
    base: BaseParameters,
    samples: JointSamples,
    coulomb_width: float = 0.0,
    *,
    boundaries: tuple[int, ...] = (),
) -> ReducedObservations:
    """The observations of :func:`observations` reduced to their triangular
    factors without ever holding the whole (N n, p) matrix: the regressor is
    built and folded in block by block. ``boundaries``: sample indices where
    a new segment starts (e.g. the held-out split)."""
    reducer = ObservationReducer(
        samples.n_joints, base.count, base.names, boundaries=boundaries
    )
    for s, Y in _base_blocks(model, base, samples, coulomb_width):
        reducer.add(Y, samples.tau[s])
    return reducer.result()


def identify(
    model: RobotModel,
    samples: JointSamples,
    *,
    method: str = "ols",
    seed: int = 0,
    progress: bool = False,
    de_maxiter: int = 3000,
    coulomb_width: float = 0.0,
    prior: RobotModel | None = None,
    mass_bounds: np.ndarray | tuple[float, float] | None = None,
    total_mass: tuple[float, float] | None = None,
    terms: DynamicTerms | None = None,
    heldout_fraction: float = HELDOUT_FRACTION,
) -> Identification:
    """Identifies the base parameters of ``model``'s 13 standard parameters per
    link from prepared samples.

    Args:
      model: robot kinematics; its ``dynamics`` (if any) serve as the prior of
        the physically consistent fit (regularised toward them in directions
        the data cannot see) and as the centre of the DE search box.
      samples: prepared samples (:func:`rmdrake.dynamics.data.prepare_samples`).
      method: one of :data:`IDENTIFICATION_METHODS`: ``ols``, ``wls``, ``de``
        (the paper's) or ``physical`` (with Gautier's joint weights, as WLS).
        Only ``physical`` solves a cvxpy problem here; for the others the
        physically consistent standard parameters are computed on first use
        of :attr:`Identification.chi` (e.g. by :func:`identified_model`).
      seed, progress, de_maxiter: of the DE method.
      coulomb_width: see :func:`observations` (0 = sign(qd)).
      prior: a robot whose ``dynamics`` are the prior instead of ``model``'s
        (same joint count); with a prior the ``physical`` fit's weight is
        chosen by generalised cross-validation (module docstring).
      mass_bounds: kg, (lo, hi) for every link or (n, 2) per link (hi may be
        inf); default lo 1e-3 kg, no hi.
      total_mass: kg, (lo, hi) on the sum of the link masses.
      terms: the dynamic terms to fit (module docstring); None: the model's
        (``model.dynamic_terms``).
      heldout_fraction: the share of the first samples before the reduced
        observations' segment boundary (the sanity checks' fitted part).

    Raises:
      ValueError: unknown method, joint-count mismatch (log or prior), too few
        samples, a rank-deficient observation matrix, DE without a prior,
        infeasible bounds (solver status and conflicting links).

    Example:

    >>> from rmdrake import identify, load_robot, prepare_samples
    >>> from rmdrake import random_fourier_trajectory, standard_parameters
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> samples = prepare_samples(t, q, tau, qd, qdd)
    >>> result = identify(robot, samples, method="ols")
    >>> result.method, result.params.shape, bool(result.residual_rms.max() < 1e-6)
    ('ols', (52,), True)
    """
    if method not in IDENTIFICATION_METHODS:
        raise ValueError(
            f"method: expected one of {', '.join(IDENTIFICATION_METHODS)}, "
            f"found {method!r}"
        )
    if samples.n_joints != model.n_joints:
        raise ValueError(
            f"log has {samples.n_joints} joints but robot '{model.name}' has "
            f"{model.n_joints}"
        )
    terms = model.dynamic_terms if terms is None else terms
    base = base_parameters(model, terms=terms)
    split = heldout_split(samples.n_samples, heldout_fraction)
    obs = reduced_observations(model, base, samples, coulomb_width, boundaries=(split,))
    obs.check_overdetermined()
    prior_model = model if prior is None else prior
    if prior_model.n_joints != model.n_joints:
        raise ValueError(
            f"prior: robot '{prior_model.name}' has {prior_model.n_joints} joints "
            f"but robot '{model.name}' has {model.n_joints}"
        )
    if prior is not None and prior.dynamics is None:
        raise ValueError(f"prior: robot '{prior.name}' has no dynamics section")
    chi0 = None
    if prior_model.dynamics is not None:
        chi0 = extended_parameters(prior_model)  # a prior without coupled motors: 0
        chi0 = np.concatenate([chi0, np.zeros(max(0, base.width - chi0.size))])
        chi0 = chi0[: base.width]
        cols = term_columns(model.n_joints, terms, len(base.motors))
        off = np.setdiff1d(np.arange(base.width), cols)
        chi0[off] = 0.0
    bounds = _bounds(model.n_joints, mass_bounds, total_mass)
    est: Estimator
    if method == "physical":
        est = PhysicalLeastSquares(
            K=base.K_full,
            prior=chi0,
            weights="gautier",
            regularization="gcv" if chi0 is not None else 1e-10,
            **bounds,
        )
    elif method == "ols":
        est = OrdinaryLeastSquares()
    elif method == "wls":
        est = WeightedLeastSquares()
    else:
        if chi0 is None:
            raise ValueError(
                "method 'de' needs a search box: give a robot YAML with dynamics "
                "(its base parameters +-100 % are the box)"
            )
        est = DifferentialEvolutionLeastSquares(
            prior=base.K_full @ chi0,
            span=1.0,
            seed=seed,
            progress=progress,
            maxiter=de_maxiter,
        )
    est.fit(obs)
    return Identification(
        method=method,
        base=base,
        params=est.params_,
        std=getattr(est, "std_", None),
        residual_rms=est.residual_rms_,
        estimator=est,
        observations=obs,
        prior=chi0,
        coulomb_width=coulomb_width,
        bounds=bounds,
    )


def _bounds(
    n: int,
    mass_bounds: np.ndarray | tuple[float, float] | None,
    total_mass: tuple[float, float] | None,
) -> dict:
    """PhysicalLeastSquares' mass options from :func:`identify`'s arguments."""
    out: dict = {}
    if mass_bounds is not None:
        mb = np.asarray(mass_bounds, dtype=np.float64)
        if mb.shape == (2,):
            mb = np.tile(mb, (n, 1))
        if mb.shape != (n, 2) or np.isnan(mb).any() or (mb[:, 0] < 0).any():
            raise ValueError(
                f"mass_bounds: expected (lo, hi) or {n} pairs with 0 <= lo, "
                f"found shape {mb.shape}"
            )
        bad = np.flatnonzero(mb[:, 0] > mb[:, 1])
        if bad.size:
            raise ValueError(
                f"mass_bounds: lo > hi on link(s) {', '.join(str(j + 1) for j in bad)}"
            )
        out["min_mass"] = np.maximum(mb[:, 0], 1e-6)
        out["max_mass"] = mb[:, 1]
    if total_mass is not None:
        lo, hi = (float(v) for v in total_mass)
        if not 0 <= lo <= hi:
            raise ValueError(f"total_mass: expected 0 <= lo <= hi, found {lo}:{hi}")
        out["total_mass"] = (lo, hi)
    return out


def parse_mass_range(text: str, what: str = "mass bounds") -> np.ndarray:
    """(k, 2) kg from ``LO:HI`` or a comma-separated list ``LO:HI,LO:HI,...``
    (HI may be ``inf``). Raises a one-line ValueError naming ``what``."""
    try:
        pairs = [tuple(float(v) for v in item.split(":")) for item in text.split(",")]
        out = np.array(pairs, dtype=np.float64)
    except ValueError:
        out = np.empty(0)
    if out.ndim != 2 or out.shape[1] != 2 or np.isnan(out).any():
        raise ValueError(f"{what}: expected LO:HI in kg (or a list), found {text!r}")
    return out


def fit_summary(result: Identification) -> list[str]:
    """Lines: the prior weight when chosen by GCV; the total mass and each
    link's mass (kg) and centre of mass (m, in the link frame) of
    :attr:`Identification.chi`, next to the prior's; for methods other than
    ``physical``, whether the written model is the fitted one, else the RMS
    difference of their predictions on the identification data."""
    lines = []
    if getattr(result.estimator, "gcv_", None) is not None:
        rho = result.estimator.regularization_
        lines.append(f"prior weight rho = {rho:.3g} (generalised cross-validation)")
    n = result.observations.n_joints
    links = result.chi[: 13 * n].reshape(n, 13)
    prior = None if result.prior is None else result.prior[: 13 * n].reshape(n, 13)

    def describe(p: np.ndarray) -> str:
        com = p[6:9] / p[9] if p[9] > 0 else np.full(3, np.nan)
        return f"{p[9]:7.3f} kg at [{', '.join(f'{c:+.3f}' for c in com)}] m"

    head = f"total mass {links[:, 9].sum():.3f} kg"
    if prior is not None:
        head += f" (prior {prior[:, 9].sum():.3f} kg)"
    lines.append(head + "; per link: mass, centre of mass in the link frame")
    for j in range(n):
        line = f"  link {j + 1}: {describe(links[j])}"
        if prior is not None:
            line += f"   prior {describe(prior[j])}"
        lines.append(line)
    if result.method != "physical":
        diff = ", ".join(f"{v:.3g}" for v in result.written_difference_rms)
        lines.append(
            "written dynamics = the fitted model (same base parameters)"
            if result.written_exact
            else "warning: no physically consistent model has the fitted base "
            "parameters; the written dynamics (nearest projection) predict "
            f"differently on the identification data by RMS [N m]: {diff}"
        )
    return lines


def identified_model(
    model: RobotModel, result: Identification, *, notes: dict | None = None
) -> RobotModel:
    """``model`` with the identified standard parameters (:attr:`Identification.chi`,
    physically consistent) as its dynamics and a ``calibration:`` record
    (method, base parameters with std and regrouping, residuals), in the robot
    YAML schema. For methods other than ``physical`` this solves the written
    model (module docstring; cvxpy + Clarabel) unless ``result.chi`` was
    already used. ``written_model_difference_rms_Nm`` records, per joint, how
    far the written dynamics' predictions are from the fit's on the
    identification data (round-off when they are the same model).

    Example:

    >>> from rmdrake import identified_model, identify, load_robot, prepare_samples
    >>> from rmdrake import random_fourier_trajectory, standard_parameters
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> result = identify(robot, prepare_samples(t, q, tau, qd, qdd), method="physical")
    >>> model = identified_model(robot, result)
    >>> model.calibration["method"], model.dynamics.shape
    ('identify/physical', (6, 13))
    """
    if result.method == "physical":
        how = "physically consistent least squares (cvxpy + Clarabel)"
    elif result.written_exact:
        how = (
            "the physically consistent model nearest the prior with exactly the "
            "identified base parameters (cvxpy + Clarabel): it predicts as the fit"
        )
    else:
        how = (
            "physically consistent projection of the base parameters (cvxpy + "
            "Clarabel): no physically consistent model has them; its predictions "
            "differ by written_model_difference_rms_Nm"
        )
    record: dict = {
        "method": f"identify/{result.method}",
        "standard_parameters": how,
        "written_model_difference_rms_Nm": [
            float(v) for v in result.written_difference_rms
        ],
        "base_parameters": {
            name: (
                {"value": float(v)}
                if result.std is None
                else {"value": float(v), "std": float(s)}
            )
            for name, v, s in zip(
                result.base.names,
                result.params,
                result.std if result.std is not None else result.params,
                strict=True,
            )
        },
        "regrouping": result.base.expressions(),
        "residual_rms_Nm": [float(v) for v in result.residual_rms],
    }
    if not result.terms.is_default:
        record["terms"] = str(result.terms)
    if model.payload is not None:
        record["payload"] = (
            "the payload is rigid with the last link, so it is identified inside "
            "link n's parameters; the payload entry is dropped"
        )
    if notes:
        record.update(notes)
    n, chi, terms = model.n_joints, result.chi, result.terms
    return dataclasses.replace(
        model.with_dynamics(chi[: 13 * n].reshape(n, 13)),
        payload=None,
        calibration=record,
        terms=None if terms.is_default and model.terms is None else terms,
        fcn=chi[13 * n : 14 * n] if terms.coulomb_asymmetric else None,
        tau0=chi[14 * n : 15 * n] if terms.offset else None,
        motor_terms=chi[15 * n :].reshape(-1, 3) if chi.size > 15 * n else None,
    )
