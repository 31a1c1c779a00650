"""The identification pipeline: prepared samples in, base parameters and a robot
model with physically consistent per-link dynamics out.

:func:`identify` builds the observations A x = b of the robot's 13-per-link base
parameters (:func:`observations`), fits them with one of
:data:`IDENTIFICATION_METHODS` (the estimators of
:mod:`rmdrake.dynamics.estimators`) and returns an :class:`Identification`.
:func:`identified_model` writes the robot model: it needs all 13 standard
parameters per link, physically consistent, which only the ``physical`` method
estimates; for the other methods they are the physically consistent projection
of the base parameters (:attr:`Identification.chi`, a cvxpy + Clarabel problem
solved on first use only, so :func:`identify` itself is the fit alone).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    Estimator,
    OrdinaryLeastSquares,
    PhysicalLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.observations import Observations
from rmdrake.dynamics.parameters import standard_parameters
from rmdrake.robot import RobotModel

__all__ = [
    "IDENTIFICATION_METHODS",
    "Identification",
    "identified_model",
    "identify",
    "observations",
]

IDENTIFICATION_METHODS: tuple[str, ...] = ("ols", "wls", "de", "physical")
"""The ``method`` names of :func:`identify`: ordinary and (Gautier-)weighted
least squares, the paper's differential evolution, and the physically consistent
least squares (with Gautier's joint weights)."""


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
      observations: the fitted system A x = b (base columns).
      prior: (13n,) standard parameters of the robot model the fit started
        from, or None; they pick :attr:`chi` in the directions the data
        cannot see.
      coulomb_width: the Coulomb sign's width in rad/s or m/s (0: sign(qd)).
    """

    method: str
    base: BaseParameters
    params: np.ndarray
    std: np.ndarray | None
    residual_rms: np.ndarray
    estimator: Estimator
    observations: Observations = dataclasses.field(repr=False)
    prior: np.ndarray | None = dataclasses.field(default=None, repr=False)
    coulomb_width: float = 0.0

    @functools.cached_property
    def chi(self) -> np.ndarray:
        """(13n,) physically consistent standard parameters: the ``physical``
        estimate itself, or for the other methods the physically consistent
        projection of their base parameters (closest in the data's metric,
        computed with cvxpy + Clarabel on first access, then cached)."""
        if isinstance(self.estimator, PhysicalLeastSquares):
            return self.estimator.chi_
        obs = self.observations
        projected = Observations(obs.A, obs.A @ self.params, obs.n_joints)
        return (
            PhysicalLeastSquares(K=self.base.K_full, prior=self.prior)
            .fit(projected)
            .chi_
        )

    def predict(self, model: RobotModel, samples: JointSamples) -> np.ndarray:
        """Efforts (N, n) of the identified base parameters at ``samples``,
        N m or N."""
        obs = observations(model, self.base, samples, self.coulomb_width)
        return obs.predict(self.params)


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


def identify(
    model: RobotModel,
    samples: JointSamples,
    *,
    method: str = "ols",
    seed: int = 0,
    progress: bool = False,
    de_maxiter: int = 2000,
    coulomb_width: float = 0.0,
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

    Raises:
      ValueError: unknown method, joint-count mismatch, too few samples, a
        rank-deficient observation matrix, DE without a prior.
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
    base = base_parameters(model, 13)
    obs = observations(model, base, samples, coulomb_width)
    obs.check_overdetermined()
    prior = standard_parameters(model) if model.dynamics is not None else None
    est: Estimator
    if method == "physical":
        est = PhysicalLeastSquares(K=base.K_full, prior=prior, weights="gautier")
    elif method == "ols":
        est = OrdinaryLeastSquares()
    elif method == "wls":
        est = WeightedLeastSquares()
    else:
        if prior is None:
            raise ValueError(
                "method 'de' needs a search box: give a robot YAML with dynamics "
                "(its base parameters +-100 % are the box)"
            )
        est = DifferentialEvolutionLeastSquares(
            prior=base.K_full @ prior,
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
        prior=prior,
        coulomb_width=coulomb_width,
    )


def identified_model(
    model: RobotModel, result: Identification, *, notes: dict | None = None
) -> RobotModel:
    """``model`` with the identified standard parameters (:attr:`Identification.chi`,
    physically consistent) as its dynamics and a ``calibration:`` record
    (method, base parameters with std and regrouping, residuals), in the robot
    YAML schema. For methods other than ``physical`` this solves the physical
    projection (cvxpy + Clarabel) unless ``result.chi`` was already used."""
    record: dict = {
        "method": f"identify/{result.method}",
        "standard_parameters": (
            "physically consistent least squares (cvxpy + Clarabel)"
            if result.method == "physical"
            else "physically consistent projection of the base parameters "
            "(cvxpy + Clarabel); only the base parameters are identified"
        ),
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
    if model.payload is not None:
        record["payload"] = (
            "the payload is rigid with the last link, so it is identified inside "
            "link n's parameters; the payload entry is dropped"
        )
    if notes:
        record.update(notes)
    return dataclasses.replace(
        model.with_dynamics(result.chi.reshape(model.n_joints, 13)),
        payload=None,
        calibration=record,
    )
