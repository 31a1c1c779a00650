"""Priors, mass bounds and the written model of the identification (issue 12
items 5-6): a prior moves only what the data cannot see, the written per-link
dynamics predict what the fit predicts, impossible bounds are refused in one
line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.dynamics import check_physical, standard_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.identification import (
    fit_summary,
    identified_model,
    identify,
    observations,
    parse_mass_range,
)
from rmdrake.dynamics.regressor import torques
from rmdrake.model.dynamic_parameters import (
    perturb_standard_parameters,
    random_standard_parameters,
)
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def case():
    """RV-3SB, a physically valid truth near the nominal (strictly inside the
    physical set: a perturbed nominal mixed with a random valid set), the
    nominal as the prior, 300 random noise-free states (sign(qd) Coulomb)."""
    model = load_robot("rv3sb")
    rng = np.random.default_rng(5)
    truth = 0.7 * perturb_standard_parameters(
        standard_parameters(model), rng
    ) + 0.3 * random_standard_parameters(6, rng)
    q = rng.uniform(-2.5, 2.5, (300, 6))
    qd, qdd = rng.uniform(-2, 2, (300, 6)), rng.uniform(-6, 6, (300, 6))
    tau = torques(model, q, qd, qdd, truth)
    samples = JointSamples(np.arange(300) / 100.0, q, qd, qdd, tau, 100.0)
    return model, truth, samples


def test_prior_moves_only_the_unidentifiable_directions(case):
    """Noise-free data with a prior (the nominal, not the truth): GCV picks the
    smallest weight, the truth's base parameters are fitted to the solver's
    accuracy, and the standard parameters are the prior's in what the data
    cannot see."""
    model, truth, samples = case
    result = identify(model, samples, method="physical")
    K = result.base.K_full
    assert result.estimator.regularization_ == pytest.approx(1e-10)
    assert result.estimator.gcv_.shape == (45, 2)
    exact = K @ truth
    # to the interior-point solver's accuracy on the squared objective (5e-5
    # here; the prior's weight alone would leave the same)
    assert np.abs(result.params - exact).max() < 2e-4 * np.abs(exact).max()
    assert check_physical(result.chi).ok
    prior = standard_parameters(model)
    # The point nearest the prior with these base parameters: nearer than the
    # truth (which has them too), and near the prior where nothing acts.
    scale = np.where(prior != 0, np.abs(prior), 1.0)
    assert np.linalg.norm((result.chi - prior) / scale) <= np.linalg.norm(
        (truth - prior) / scale
    ) * (1 + 1e-6)
    never = ~np.any(K != 0, axis=0)
    assert never.sum() >= 6  # e.g. XX1, XY1, XZ1, YY1, YZ1, MZ1

    # (the pseudo-inertia constraint may hold some of them off the prior)
    def off(x):
        return np.linalg.norm(((x - prior) / scale)[never])

    assert off(result.chi) < off(truth)


@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_written_ols_model_predicts_as_the_fit(case, noise):
    """The per-link dynamics written after OLS give the OLS predictions on the
    identification data to 1e-9 relative (a physically consistent model with
    the OLS base parameters exists: truth valid, noise small)."""
    model, truth, samples = case
    rng = np.random.default_rng(1)
    noisy = dataclasses.replace(
        samples, tau=samples.tau + noise * rng.standard_normal(samples.tau.shape)
    )
    result = identify(model, noisy, method="ols")
    written = identified_model(model, result)
    assert result.written_exact
    chi = standard_parameters(written)
    assert check_physical(chi).ok
    fitted = result.predict(model, noisy)
    obs = observations(model, result.base, noisy)
    again = obs.predict(result.base.K_full @ chi)
    assert np.abs(again - fitted).max() < 1e-9 * np.abs(fitted).max()
    record = written.calibration["written_model_difference_rms_Nm"]
    assert max(record) < 1e-9 * np.abs(fitted).max()
    assert "same base parameters" in fit_summary(result)[-1]


def test_unrealisable_base_parameters_are_projected_and_the_difference_said(case):
    """Base parameters no mass distribution has (the truth's, sign flipped):
    the written model is the nearest projection and the RMS prediction
    difference is reported (per joint, > 0) in the record and the summary."""
    model, truth, samples = case
    flipped = dataclasses.replace(samples, tau=-samples.tau)
    result = identify(model, flipped, method="ols")
    assert not result.written_exact
    diff = result.written_difference_rms
    obs = observations(model, result.base, flipped)  # dense: the oracle
    d = obs.A @ (result.base.K_full @ result.chi - result.params)
    assert np.allclose(diff, np.sqrt(np.mean(d.reshape(-1, 6) ** 2, axis=0)))
    assert diff.max() > 0.01 * np.abs(obs.b).max()
    assert "warning: no physically consistent model" in fit_summary(result)[-1]


def test_mass_bounds_hold_and_are_reported(case):
    model, truth, samples = case
    masses = truth.reshape(6, 13)[:, 9]
    bounds = np.stack([0.9 * masses, 1.1 * masses], axis=1)
    bounds[5] = [0.5, 0.6]  # link 6 forced away from its true mass
    result = identify(model, samples, method="physical", mass_bounds=bounds)
    m = result.chi.reshape(6, 13)[:, 9]
    assert np.all(m >= bounds[:, 0] * (1 - 1e-6)) and np.all(m <= bounds[:, 1] + 1e-6)
    lines = fit_summary(result)
    assert lines[1].startswith(f"total mass {m.sum():.3f} kg (prior ")
    assert len(lines) == 2 + 6 and "prior" in lines[2]


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            dict(mass_bounds=(1.0, 2.0), total_mass=(20.0, 30.0)),
            r"solver status '.*infeasible.*'; total mass bounds 20..30 kg "
            r"conflict with the links' mass bounds \(sum 6..12 kg\)",
        ),
        (dict(mass_bounds=[(1, 2)] * 5 + [(3, 2)]), r"lo > hi on link\(s\) 6"),
        (dict(mass_bounds=(1, 2, 3)), "mass_bounds: expected"),
    ],
)
@pytest.mark.parametrize("method", ["physical", "ols"])
def test_impossible_bounds_are_refused_in_one_line(case, kwargs, message, method):
    model, _, samples = case
    with pytest.raises(ValueError, match=message) as err:
        identify(model, samples, method=method, **kwargs).chi  # noqa: B018
    assert "\n" not in str(err.value)


def test_prior_with_another_joint_count_is_refused(case):
    model, _, samples = case
    limits = {k: getattr(model.limits, k)[:5] for k in vars(model.limits)}
    other = dataclasses.replace(
        model,
        name="five",
        mdh=model.mdh[:5],
        sigma=None,
        limits=type(model.limits)(**limits),
        dynamics=model.dynamics[:5],
    )
    with pytest.raises(ValueError, match=r"^prior: robot '.*' has \d joints but"):
        identify(model, samples, prior=other)


def test_parse_mass_range():
    assert parse_mass_range("0.2:10").tolist() == [[0.2, 10.0]]
    assert parse_mass_range("1:2,3:inf")[1, 1] == np.inf
    with pytest.raises(ValueError, match="--total-mass: expected LO:HI"):
        parse_mass_range("9-27", "--total-mass")


def test_solver_boundary_points_are_lifted_onto_the_cone(rng):
    """A link on the pseudo-inertia cone's boundary, pushed 1e-7 outside (as
    an interior-point solver returns), is lifted to a strict mass distribution
    with every other link kept and this one moved by about 1e-7 only."""
    from rmdrake.dynamics.physical_fit import lift_to_physical
    from rmdrake.model.dynamic_parameters import (
        check_physical,
        pseudo_inertia,
        random_standard_parameters,
    )

    chi = random_standard_parameters(3, rng)
    point = chi[13:26].copy()  # link 2 as a point mass at its centre of mass
    com = point[6:9] / point[9]
    point[:6] = point[9] * np.array(
        [com[1] ** 2 + com[2] ** 2, -com[0] * com[1], -com[0] * com[2],
         com[0] ** 2 + com[2] ** 2, -com[1] * com[2], com[0] ** 2 + com[1] ** 2]
    )  # fmt: skip
    point[[0, 3, 5]] -= 1e-7
    chi[13:26] = point
    assert not check_physical(chi).ok
    lifted = lift_to_physical(chi, 3, 13)
    assert check_physical(lifted).ok
    assert np.linalg.eigvalsh(pseudo_inertia(lifted[13:23]))[0] >= 0
    np.testing.assert_array_equal(lifted[:13], chi[:13])
    np.testing.assert_array_equal(lifted[26:], chi[26:])
    assert np.abs(lifted - chi).max() < 2e-7
