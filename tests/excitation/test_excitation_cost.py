"""The excitation design's vectorised objective (paper eq. 16-17) against
independent oracles: cond(A) and log det from a tall SVD of the stacked base
regressor of each checked trajectory, one at a time; the population's limit
factors against each trajectory's own peaks; the design's bytes for a seed."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.payload import PayloadColumns
from rmdrake.excitation.design import (
    FINALISTS,
    ExcitationCost,
    FourierParametrization,
    design_excitation,
    limit_scales,
)
from rmdrake.excitation.trajectory import FourierTrajectory, fourier_series

F = 0.1  # Hz: the paper's base frequency, a period of 10 s


def _cost(model, samples: int, *, payload: bool = False, **kw) -> ExcitationCost:
    # Half a sample off t = 0: there the motion is at rest and qd is zero only
    # up to round-off, so the Coulomb column sign(qd) is +-1 or 0 by round-off.
    times = (np.arange(samples) + 0.5) / (samples * F)
    return ExcitationCost(
        model=model,
        base=PayloadColumns(model) if payload else base_parameters(model, 13),
        parametrization=FourierParametrization(model.n_joints, 5),
        q0=0.5 * (model.limits.lower + model.limits.upper),
        base_frequency=F,
        times=times,
        **kw,
    )


def _candidates(cost: ExcitationCost, count: int, seed: int) -> np.ndarray:
    """Random coordinates in the DE's box (velocity limits, rad/s or m/s)."""
    lim = np.repeat(cost.model.limits.velocity, cost.parametrization.per_joint)
    return np.random.default_rng(seed).uniform(-lim, lim, (count, lim.size))


def _tall_matrix(cost: ExcitationCost, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A (S n, p) of one trajectory, by its own checked series."""
    tr = FourierTrajectory(base_frequency=F, q0=cost.q0, a=a, b=b)
    t = cost.times
    Y = cost.base.regressor(cost.model, tr.q(t), tr.qd(t), tr.qdd(t))
    return Y.reshape(-1, Y.shape[-1])


@pytest.mark.parametrize("payload", [False, True])
def test_gram_objective_equals_tall_svd(rv3sb, payload):
    """cond(A) of each feasible candidate, through the population's Gram
    matrices, equals sigma_max / sigma_min of its own tall A to 1e-8 (the Gram
    route loses about eps cond^2 ~ 1e-12 here); log det likewise."""
    cost = _cost(rv3sb, 60, payload=payload, chunk=7)  # chunks of 7: 3 of them
    X = _candidates(cost, 16, seed=2)
    c = cost(X)
    logdet = _cost(rv3sb, 60, payload=payload, criterion="logdet")(X)
    a, b = cost.coefficients(X)
    for k in range(len(X)):
        sv = np.linalg.svd(_tall_matrix(cost, a[k], b[k]), compute_uv=False)
        assert 5 < sv[0] / sv[-1] < 1e6  # a real, well-posed case
        assert c[k] == pytest.approx(sv[0] / sv[-1], rel=1e-8)
        assert logdet[k] == pytest.approx(-np.mean(2 * np.log(sv)), rel=1e-8)


def test_eigenvalues_equal_numpy_and_flag_failures():
    G = np.random.default_rng(0).normal(size=(5, 30, 9))
    G = G.transpose(0, 2, 1) @ G
    ev = ExcitationCost.eigenvalues(G)
    np.testing.assert_allclose(ev, np.linalg.eigvalsh(G), rtol=1e-12)
    G[2, 1, 1] = np.nan
    assert np.isnan(ExcitationCost.eigenvalues(G)[2]).all()
    assert ExcitationCost.cond(G)[2] == 1e12
    singular = np.diag([0.0, 1.0, 2.0])[None]
    assert ExcitationCost.cond(singular)[0] == 1e12


@pytest.mark.parametrize("limit_samples", [0, 200])
def test_motion_is_the_series_of_the_feasible_coefficients(rv3sb, limit_samples):
    """One series evaluation, scaled per joint, gives the samples of the
    feasible coefficients' own series (to 1e-12 of the limits); with limit
    times, those coefficients keep the limits there too (their own series
    checked sample by sample)."""
    limit_times = np.arange(limit_samples) / (limit_samples * F)
    cost = _cost(rv3sb, 50, limit_times=limit_times if limit_samples else None)
    X = _candidates(cost, 9, seed=4)
    a, b, q, qd, qdd = cost.motion(X)
    a_ref, b_ref = cost.coefficients(X)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=0)
    np.testing.assert_allclose(b, b_ref, rtol=1e-12, atol=0)
    series = fourier_series(cost.times, base_frequency=F, q0=cost.q0, a=a, b=b)
    lim = rv3sb.limits
    for k in range(len(X)):
        tr = FourierTrajectory(base_frequency=F, q0=cost.q0, a=a[k], b=b[k])
        t = np.concatenate([cost.times, limit_times])
        tol = 1e-12 * (lim.upper - lim.lower)
        assert np.all(tr.q(t) <= cost.q0 + 0.95 * (lim.upper - cost.q0) + tol)
        assert np.all(tr.q(t) >= cost.q0 - 0.95 * (cost.q0 - lim.lower) - tol)
        assert np.all(np.abs(tr.qd(t)) <= 0.95 * lim.velocity * (1 + 1e-12))
        assert np.all(np.abs(tr.qdd(t)) <= 0.95 * lim.acceleration * (1 + 1e-12))
    scales = (lim.upper - lim.lower, lim.velocity, lim.acceleration)
    for got, ref, scale in zip((q, qd, qdd), series, scales, strict=True):
        assert np.max(np.abs(got - ref) / scale) < 1e-12


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
def test_limit_scales_equal_each_trajectorys_own_check(robot, request):
    """The population's factors == one trajectory at a time: its peaks at the
    same samples (FourierTrajectory.peak_values), the largest factor <= 1
    keeping each within margin x its limit; the scaled motion touches a
    limit on every joint whose factor is below 1."""
    model = request.getfixturevalue(robot)
    margin, M = 0.9, 120
    param = FourierParametrization(model.n_joints, 5)
    lim = model.limits
    q0 = 0.5 * (lim.lower + lim.upper)
    vel = np.repeat(lim.velocity, param.per_joint)
    X = np.random.default_rng(5).uniform(-vel, vel, (12, vel.size))
    X[3] *= 1e-4  # a small motion: factor 1 on every joint
    a, b = param.coefficients(X)
    t = np.arange(M) / (M * F)
    e, qd, qdd = fourier_series(t, base_frequency=F, q0=np.zeros_like(q0), a=a, b=b)
    s = limit_scales(e, qd, qdd, q0, model, margin)
    assert np.all(s[3] == 1.0) and np.mean(s < 1.0) > 0.5
    for k in range(len(X)):
        tr = FourierTrajectory(base_frequency=F, q0=q0, a=a[k], b=b[k])
        q_min, q_max, v_max, a_max = tr.peak_values(M)
        for j in range(model.n_joints):
            rooms = [
                (q_max[j] - q0[j], lim.upper[j] - q0[j]),
                (q0[j] - q_min[j], q0[j] - lim.lower[j]),
                (v_max[j], lim.velocity[j]),
                (a_max[j], lim.acceleration[j]),
            ]
            expected = min([1.0] + [margin * room / peak for peak, room in rooms])
            assert s[k, j] == pytest.approx(expected, rel=1e-12)
            used = max(s[k, j] * peak / room for peak, room in rooms)
            assert used <= margin * (1 + 1e-12)
            if s[k, j] < 1.0:
                assert used == pytest.approx(margin, rel=1e-12)


def test_design_bytes_repeat_for_a_seed(rv3sb):
    """Same seed and settings: the same YAML bytes; another seed: another
    trajectory (so the comparison can fail)."""
    kw = dict(design_samples=32, popsize=3, maxiter=4, n_random=2, progress=False)
    first = design_excitation(rv3sb, seed=7, **kw)
    again = design_excitation(rv3sb, seed=7, **kw)
    other = design_excitation(rv3sb, seed=8, **kw)
    assert first.trajectory.to_yaml() == again.trajectory.to_yaml()
    assert first.cond == again.cond
    np.testing.assert_array_equal(first.history[:, 2], again.history[:, 2])
    assert first.trajectory.to_yaml() != other.trajectory.to_yaml()


@pytest.mark.parametrize("criterion", ["cond", "logdet"])
def test_design_keeps_the_best_finalist_on_the_full_period(rv3sb, criterion):
    """The trajectory is the lowest, on the full period, of the DE's last
    bests: its cond(A) (or -log det / p) is their minimum, and with more than
    one finalist the choice is real (they differ)."""
    kw = dict(design_samples=24, popsize=3, maxiter=12, n_random=1, progress=False)
    r = design_excitation(rv3sb, seed=1, criterion=criterion, **kw)
    assert 2 <= r.finalists.size <= FINALISTS
    assert np.ptp(r.finalists) > 0
    own = r.cond if criterion == "cond" else -r.log_det
    assert own == pytest.approx(r.finalists.min(), rel=1e-12)
    assert f"the best of its last {r.finalists.size} bests" in r.summary()
