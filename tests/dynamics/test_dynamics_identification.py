"""Identification estimators recover known truth; the pipeline fits without
cvxpy and still writes a physically consistent model."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics import (
    SerialChain,
    check_physical,
    random_standard_parameters,
    standard_parameters,
)
from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    Estimator,
    Observations,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares


@pytest.fixture(scope="module")
def setup():
    from rmdrake.model.loading import load_robot

    model = load_robot("rv3sb")
    chain = SerialChain.from_model(model)
    base = base_parameters(chain)
    rng = np.random.default_rng(7)
    # A perturbed, physically valid truth: the nominal parameters mixed with a
    # random valid set (a convex combination of valid sets is valid).
    chi = 0.8 * standard_parameters(model) + 0.2 * random_standard_parameters(6, rng)
    assert check_physical(chi).ok
    return model, chain, base, chi


def states(rng, N):
    return (
        rng.uniform(-2.5, 2.5, (N, 6)),
        rng.uniform(-2.0, 2.0, (N, 6)),
        rng.uniform(-6.0, 6.0, (N, 6)),
    )


def observations(setup, N, noise, seed):
    _, chain, base, chi = setup
    rng = np.random.default_rng(seed)
    q, qd, qdd = states(rng, N)
    Y = base.regressor(chain, q, qd, qdd)
    tau = Y @ base.regroup(chi)
    tau = tau + noise * rng.standard_normal(tau.shape)
    return Observations.from_regressor(Y, tau, base.names)


@pytest.mark.parametrize("estimator", [OrdinaryLeastSquares, WeightedLeastSquares])
def test_noise_free_recovers_base_parameters(setup, estimator):
    """Noise-free data: base parameters to 1e-6 relative (of the largest)."""
    base, chi = setup[2], setup[3]
    truth = base.regroup(chi)
    est = estimator().fit(observations(setup, 400, 0.0, 1))
    assert np.abs(est.params_ - truth).max() < 1e-6 * np.abs(truth).max()
    assert est.residual_rms_.max() < 1e-9


def test_physical_noise_free_equals_truth_and_is_valid(setup):
    base, chi = setup[2], setup[3]
    truth = base.regroup(chi)
    est = PhysicalLeastSquares(K=base.K_full).fit(observations(setup, 400, 0.0, 2))
    assert est.status_ == "optimal"
    assert np.abs(est.params_ - truth).max() < 1e-5 * np.abs(truth).max()
    assert check_physical(est.chi_).ok


def test_ols_error_shrinks_as_one_over_sqrt_samples(setup):
    """With Gaussian torque noise, the mean parameter error over 6 seeds falls
    by about 2 when the samples grow 4x (accepted: 1.5 .. 2.7)."""
    base, chi = setup[2], setup[3]
    truth = base.regroup(chi)

    scale = OrdinaryLeastSquares().fit(observations(setup, 300, 0.5, 99)).std_

    def error(N):
        errs = []
        for seed in range(6):
            est = OrdinaryLeastSquares().fit(observations(setup, N, 0.5, 100 + seed))
            errs.append(np.linalg.norm((est.params_ - truth) / scale))
        return np.mean(errs)

    ratio = error(300) / error(1200)
    assert 1.5 < ratio < 2.7


def test_ols_standard_deviations_are_calibrated(setup):
    """The reported std matches the spread of the estimates over seeds (within
    a factor accepted for 30 draws: 0.7 .. 1.4)."""
    base, chi = setup[2], setup[3]
    truth = base.regroup(chi)
    z = []
    for seed in range(30):
        est = OrdinaryLeastSquares().fit(observations(setup, 300, 0.5, 200 + seed))
        z.append((est.params_ - truth) / est.std_)
    spread = np.std(np.array(z), axis=0).mean()
    assert 0.7 < spread < 1.4


def test_wls_weights_joints_by_their_noise(setup):
    """Joint 1 noise 10x the others: WLS estimates sigma_j and beats OLS."""
    _, chain, base, chi = setup
    truth = base.regroup(chi)
    rng = np.random.default_rng(5)
    q, qd, qdd = states(rng, 600)
    Y = base.regressor(chain, q, qd, qdd)
    sigma = np.array([2.0, 0.2, 0.2, 0.2, 0.2, 0.2])
    tau = Y @ truth + sigma * rng.standard_normal((600, 6))
    obs = Observations.from_regressor(Y, tau)
    wls = WeightedLeastSquares().fit(obs)
    ols = OrdinaryLeastSquares().fit(obs)
    np.testing.assert_allclose(wls.joint_sigma_, sigma, rtol=0.15)
    err = lambda e: np.linalg.norm((e.params_ - truth) / wls.std_)  # noqa: E731
    assert err(wls) < err(ols)


def test_physical_fit_of_noisy_data_is_simulable(setup):
    base = setup[2]
    obs = observations(setup, 300, 2.0, 9)
    ols = OrdinaryLeastSquares().fit(obs)
    phys = PhysicalLeastSquares(K=base.K_full).fit(obs)
    assert check_physical(phys.chi_).ok
    # Constraints cost little fit: within 2 % of the unconstrained residual.
    assert phys.residual_rms_.mean() < 1.02 * ols.residual_rms_.mean()


def test_de_recovers_a_small_problem():
    """The paper's DE on a 4-parameter noise-free problem: to 1e-6."""
    rng = np.random.default_rng(0)
    A = rng.standard_normal((300, 4))
    x = np.array([1.0, -2.0, 0.5, 3.0])
    obs = Observations(A, A @ x, n_joints=3)
    est = DifferentialEvolutionLeastSquares(
        prior=1.3 * x, span=0.5, seed=1, progress=False
    ).fit(obs)
    assert np.abs(est.params_ - x).max() < 1e-6
    again = DifferentialEvolutionLeastSquares(
        prior=1.3 * x, span=0.5, seed=1, progress=False
    ).fit(obs)
    np.testing.assert_array_equal(again.params_, est.params_)
    with pytest.raises(ValueError, match="needs a search box"):
        DifferentialEvolutionLeastSquares().fit(obs)


def test_bad_observations():
    A = np.ones((12, 5))
    with pytest.raises(ValueError, match="4 equations .* for 5 parameters"):
        OrdinaryLeastSquares().fit(Observations(A[:4], np.zeros(4), n_joints=2))
    with pytest.raises(ValueError, match="rank 1 < 5"):
        OrdinaryLeastSquares().fit(Observations(A, np.zeros(12), n_joints=2))
    with pytest.raises(ValueError, match="not a multiple of n = 5"):
        Observations(A, np.zeros(12), n_joints=5)
    with pytest.raises(ValueError, match="torque vector b: expected shape"):
        Observations(A, np.zeros(11), n_joints=2)


def test_infeasible_physical_fit_names_the_link(setup):
    base = setup[2]
    obs = observations(setup, 100, 0.0, 3)
    max_mass = np.full(6, 100.0)
    max_mass[3] = 0.5  # below min_mass: link 4 cannot satisfy both
    with pytest.raises(ValueError, match="solver status .*infeasible.*link 4"):
        PhysicalLeastSquares(K=base.K_full, min_mass=1.0, max_mass=max_mass).fit(obs)
    max_mass[3] = 1e-4  # a gap below the solver's tolerance: caught on return
    with pytest.raises(ValueError, match="link 4 mass .* (<|>) "):
        PhysicalLeastSquares(K=base.K_full, max_mass=max_mass).fit(obs)


def test_estimators_follow_the_protocol(setup):
    """fit returns self; a fitted estimator satisfies the Estimator protocol."""
    obs = observations(setup, 200, 0.1, 11)
    for est in (
        OrdinaryLeastSquares(),
        WeightedLeastSquares(),
        PhysicalLeastSquares(K=setup[2].K_full),
    ):
        assert not isinstance(est, Estimator)  # no results before fit
        assert est.fit(obs) is est
        assert isinstance(est, Estimator)


# ---- the pipeline -------------------------------------------------------------------
def test_a_solver_failure_is_a_one_line_refusal_and_the_written_model_falls_back(
    setup, samples, monkeypatch
):
    """Clarabel failing numerically (the real Panda's DE fit, a 1e308 torque)
    raised cvxpy's SolverError through the command as an internal error. It is
    now the fit's ValueError, and the written model of a non-physical method
    falls back to the nearest projection, as when no realisation exists."""
    import cvxpy as cp

    from rmdrake.dynamics.identification import identified_model, identify

    base = setup[2]
    obs = observations(setup, 100, 0.0, 3)
    solve = cp.Problem.solve
    calls = []

    def first_fails(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise cp.error.SolverError("Solver 'CLARABEL' failed.")
        return solve(self, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(cp.Problem, "solve", first_fails)
        with pytest.raises(ValueError, match=r"solver status 'CLARABEL failed'"):
            PhysicalLeastSquares(K=base.K_full).fit(obs)
    model = setup[0]
    result = identify(model, samples, method="ols", coulomb_width=1e-3)
    calls.clear()
    with monkeypatch.context() as patch:
        patch.setattr(cp.Problem, "solve", first_fails)
        written = identified_model(model, result)
    assert len(calls) > 1  # the exact realisation failed, the projection ran
    assert check_physical(standard_parameters(written)).ok


@pytest.fixture(scope="module")
def samples(setup):
    """400 samples of a physically valid truth, noise-free, with the
    simulator's smooth Coulomb sign."""
    from rmdrake.dynamics.data import JointSamples
    from rmdrake.dynamics.regressor import torques

    model, chain, _, chi = setup
    q, qd, qdd = states(np.random.default_rng(12), 400)
    tau = torques(chain, q, qd, qdd, chi, coulomb_width=1e-3)
    return JointSamples(np.arange(400) / 100.0, q, qd, qdd, tau, 100.0)


def test_identify_ols_is_the_fit_alone(setup, samples, monkeypatch):
    """identify(method='ols') never solves the physical problem (no cvxpy);
    identified_model then writes a physically consistent per-link model whose
    base parameters are the identified ones."""
    import sys

    import rmdrake.dynamics.physical_fit as physical_fit
    from rmdrake.dynamics.estimators import IDENTIFICATION_METHODS
    from rmdrake.dynamics.identification import (
        identified_model,
        identify,
    )

    model, _, base, chi = setup
    assert IDENTIFICATION_METHODS == ("ols", "wls", "de", "physical")

    def refuse(*args, **kwargs):
        raise AssertionError("the physical problem was solved")

    with monkeypatch.context() as patch:
        patch.setattr(physical_fit.PhysicalLeastSquares, "fit", refuse)
        patch.setitem(sys.modules, "cvxpy", None)  # any `import cvxpy` fails
        result = identify(model, samples, method="ols", coulomb_width=1e-3)
    truth = base.regroup(chi)
    assert np.abs(result.params - truth).max() < 1e-6 * np.abs(truth).max()
    assert isinstance(result.estimator, OrdinaryLeastSquares)
    assert "_written" not in vars(result)  # the written model: not computed yet

    written = identified_model(model, result)
    found = standard_parameters(written)
    assert check_physical(found).ok
    # The projection keeps the base parameters to the solver's accuracy (the
    # truth is physically valid): 3e-5 of the largest on these random states.
    assert np.abs(base.regroup(found) - truth).max() < 1e-4 * np.abs(truth).max()
    assert written.calibration["method"] == "identify/ols"
    assert result.chi is result.chi  # computed once, then cached


def test_identify_refuses_unknown_methods(setup, samples):
    from rmdrake.dynamics.identification import identify

    with pytest.raises(ValueError, match="expected one of ols, wls, de, physical"):
        identify(setup[0], samples, method="sgd")
