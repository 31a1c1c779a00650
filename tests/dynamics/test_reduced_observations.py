"""The reduced observations (triangular factors of A x = b, built block by
block) against dense oracles: the factors equal a dense QR's, the estimators
equal numpy's dense least squares, the sanity figures equal their dense
formulas, the observation matrix's rank and singular values are unchanged on
the RV-3SB, demo_rh and the real Panda log; and one identification passes the
tall matrix through a factorisation once, never whole."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from conftest import SHARED_DATA

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.identification import (
    HELDOUT_FRACTION,
    identified_model,
    identify,
    observations,
)
from rmdrake.dynamics.observations import (
    ObservationReducer,
    Observations,
    heldout_split,
)
from rmdrake.dynamics.regressor import BLOCK_SAMPLES, torques
from rmdrake.dynamics.sanity import IdentificationBounds, check_identification
from rmdrake.model.dynamic_parameters import (
    perturb_standard_parameters,
    standard_parameters,
)
from rmdrake.model.loading import load_robot

PANDA = SHARED_DATA / "panda_gaz2019"


def signed(F: np.ndarray) -> np.ndarray:
    """F with each row's sign making its diagonal entry >= 0 (a QR's R is
    unique up to these signs)."""
    d = np.sign(np.diagonal(F, axis1=-2, axis2=-1))
    return F * np.where(d == 0, 1.0, d)[..., :, None]


def random_system(rng, N=60, n=3, p=9):
    """A (N n, p) with column 2 zero in joint 0's rows, b = A x + noise."""
    Y = rng.standard_normal((N, n, p))
    Y[:, 0, 2] = 0.0
    tau = Y @ rng.standard_normal(p) + 0.1 * rng.standard_normal((N, n))
    return Observations.from_regressor(Y, tau)


@pytest.mark.parametrize("block", [4, 7, 1000])
def test_chunked_reduction_equals_dense_qr(block):
    """Segment by segment and joint by joint, the factor F built block by
    block (blocks smaller than p + 1 rows, and crossing the boundaries) has
    the Gram matrix of [A_sj b_sj] (to 1e-12 of its norm squared) and, where
    that is of full rank, is the dense QR's R (to 1e-12 of its norm); zero
    columns stay exactly zero; the whole system's factor is the dense QR's."""
    obs = random_system(np.random.default_rng(0))
    N, n, p = obs.n_samples, obs.n_joints, obs.n_parameters
    red = obs.reduce((17, 40), block=block)
    np.testing.assert_array_equal(red.sizes, [17, 23, 20])
    np.testing.assert_array_equal(red.boundaries, [0, 17, 40, 60])
    M = np.column_stack([obs.A, obs.b]).reshape(N, n, p + 1)
    for s, (a, b) in enumerate([(0, 17), (17, 40), (40, 60)]):
        for j in range(n):
            dense = np.linalg.qr(M[a:b, j], mode="r")
            scale = np.linalg.norm(dense)
            F = red.factors[s, j]
            gram = M[a:b, j].T @ M[a:b, j]
            assert np.abs(F.T @ F - gram).max() < 1e-12 * scale**2
            if j:  # full rank: R is unique up to the rows' signs
                assert np.abs(signed(F) - signed(dense)).max() < 1e-12 * scale
    assert np.all(red.factors[:, 0, :, 2] == 0.0)
    whole = np.linalg.qr(np.column_stack([obs.A, obs.b]), mode="r")
    assert np.abs(signed(red.factor()) - signed(whole)).max() < 1e-12 * np.linalg.norm(
        whole
    )


def test_reducer_refuses_bad_blocks_and_no_data():
    reducer = ObservationReducer(2, 3)
    with pytest.raises(ValueError, match=r"regressor Y: expected shape \(any, 2, 3\)"):
        reducer.add(np.zeros((4, 3, 3)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="regressor Y: expected finite"):
        reducer.add(np.full((4, 2, 3), np.nan), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="at least one sample"):
        reducer.result()


@pytest.fixture(scope="module")
def rv3sb():
    """RV-3SB, a perturbed truth, 700 random states, torques + noise that
    differs per joint (so WLS weights differ)."""
    model = load_robot("rv3sb")
    rng = np.random.default_rng(4)
    chi = perturb_standard_parameters(standard_parameters(model), rng)
    q = rng.uniform(-2.5, 2.5, (700, 6))
    qd, qdd = rng.uniform(-2, 2, (700, 6)), rng.uniform(-6, 6, (700, 6))
    tau = torques(model, q, qd, qdd, chi)
    tau = tau + np.array([2.0, 1.0, 0.5, 0.1, 0.1, 0.05]) * rng.standard_normal(
        tau.shape
    )
    return model, JointSamples(np.arange(700) / 100.0, q, qd, qdd, tau, 100.0)


def dense_wls(A, b, n):
    """Gautier's WLS by numpy's dense lstsq: (x, std, joint sigma)."""
    N, p = A.shape[0] // n, A.shape[1]
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    r = (b - A @ x).reshape(N, n)
    p_j = [np.count_nonzero(np.any(A[j::n] != 0, axis=0)) for j in range(n)]
    sigma = np.sqrt(np.sum(r**2, axis=0) / (N - np.array(p_j)))
    w = np.tile(1.0 / sigma, N)
    Aw, bw = A * w[:, None], b * w
    xw = np.linalg.lstsq(Aw, bw, rcond=None)[0]
    s2 = np.sum((bw - Aw @ xw) ** 2) / (A.shape[0] - p)
    return xw, np.sqrt(np.diag(np.linalg.inv(Aw.T @ Aw)) * s2), sigma


def test_estimators_equal_dense_least_squares(rv3sb):
    """OLS, WLS and the DE's cost on the factors: the estimates, std, residual
    RMS, sigma and condition number of numpy's dense computation, to 1e-9."""
    model, samples = rv3sb
    base = base_parameters(model)
    obs = observations(model, base, samples)
    A, b, n = obs.A, obs.b, obs.n_joints
    N, p = obs.n_samples, obs.n_parameters
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    r = (b - A @ x).reshape(N, n)
    s2 = np.sum(r**2) / (A.shape[0] - p)
    std = np.sqrt(np.diag(np.linalg.inv(A.T @ A)) * s2)
    ols = OrdinaryLeastSquares().fit(obs)
    again = OrdinaryLeastSquares().fit(obs.reduce(block=50))
    for est in (ols, again):
        np.testing.assert_allclose(est.params_, x, rtol=0, atol=1e-9 * np.abs(x).max())
        np.testing.assert_allclose(est.std_, std, rtol=1e-9)
        np.testing.assert_allclose(
            est.residual_rms_, np.sqrt(np.mean(r**2, axis=0)), rtol=1e-9
        )
        assert est.sigma_ == pytest.approx(np.sqrt(s2), rel=1e-9)
        assert est.cond_ == pytest.approx(np.linalg.cond(A), rel=1e-9)
    xw, stdw, sigma = dense_wls(A, b, n)
    wls = WeightedLeastSquares().fit(obs)
    np.testing.assert_allclose(wls.joint_sigma_, sigma, rtol=1e-9)
    np.testing.assert_allclose(wls.params_, xw, rtol=0, atol=1e-9 * np.abs(xw).max())
    np.testing.assert_allclose(wls.std_, stdw, rtol=1e-9)
    # DE: at a short budget the result is poor, but its cost is the dense one.
    de = DifferentialEvolutionLeastSquares(
        prior=x, span=0.1, maxiter=3, popsize=5, progress=False
    ).fit(obs)
    cost = np.sum((A @ de.params_ - b) ** 2)
    assert de.cost_ == pytest.approx(cost, rel=1e-9)


def dense_sanity(A, b, n, x, fraction):
    """check_identification's held-out RMS, flip ratios and shares by the
    dense formulas (lstsq on the first samples; projection on range(A))."""
    N = A.shape[0] // n
    k = heldout_split(N, fraction) * n
    xf = np.linalg.lstsq(A[:k], b[:k], rcond=None)[0]
    heldout = np.sqrt(np.mean((A[k:] @ xf - b[k:]).reshape(-1, n) ** 2, axis=0))
    Q = np.linalg.qr(A)[0]

    def rms(rhs, j):
        return np.sqrt(np.mean((rhs - Q @ (Q.T @ rhs)).reshape(-1, n)[:, j] ** 2))

    flip = np.empty(n)
    for j in range(n):
        neg = b.reshape(-1, n).copy()
        neg[:, j] *= -1
        flip[j] = rms(neg.ravel(), j) / rms(b, j)
    torque = np.sqrt(np.mean(b.reshape(-1, n) ** 2, axis=0))
    parts = [(A[:, i] * x[i]).reshape(-1, n) for i in range(A.shape[1])]
    share = np.array([np.max(np.sqrt(np.mean(a**2, axis=0)) / torque) for a in parts])
    return heldout, flip, share


@pytest.mark.parametrize("method", ["ols", "physical"])
def test_sanity_figures_equal_the_dense_formulas(rv3sb, method):
    """check_identification from the factors: held-out RMS, flip ratios,
    shares and (physical: Gautier's WLS covariance at x) relative std equal
    the dense formulas to 1e-8."""
    model, samples = rv3sb
    result = identify(model, samples, method=method)
    obs = observations(model, result.base, samples)
    A, b, n = obs.A, obs.b, obs.n_joints
    x = result.params
    report = check_identification(result)
    heldout, flip, share = dense_sanity(A, b, n, x, HELDOUT_FRACTION)
    np.testing.assert_allclose(report.heldout_rms, heldout, rtol=1e-8)
    np.testing.assert_allclose(report.flip_ratio, flip, rtol=1e-8)
    np.testing.assert_allclose(report.share, share, rtol=1e-8)
    if method == "physical":
        r = b - A @ x
        joint = np.sqrt(np.mean(r.reshape(-1, n) ** 2, axis=0))
        w = np.tile(1.0 / joint, obs.n_samples)
        Aw = A * w[:, None]
        s2 = np.sum((w * r) ** 2) / (A.shape[0] - A.shape[1])
        std = np.sqrt(np.diag(np.linalg.inv(Aw.T @ Aw)) * s2)
        np.testing.assert_allclose(
            report.relative_std, 100 * std / np.abs(x), rtol=1e-8
        )


def test_heldout_fraction_is_the_reductions_boundary(rv3sb):
    """The sanity check's fitted fraction must be a boundary of the reduced
    observations: another one is refused in one line, and identify with that
    fraction gives its figures (the dense formulas')."""
    model, samples = rv3sb
    result = identify(model, samples, method="ols")
    k = heldout_split(samples.n_samples, HELDOUT_FRACTION)
    assert result.observations.boundaries.tolist() == [0, k, samples.n_samples]
    half = IdentificationBounds(fit_fraction=0.5)
    with pytest.raises(ValueError, match=r"fit_fraction 0.5: .*heldout_fraction=0.5"):
        check_identification(result, bounds=half)
    other = identify(model, samples, method="ols", heldout_fraction=0.5)
    report = check_identification(other, bounds=half)
    obs = observations(model, other.base, samples)
    heldout = dense_sanity(obs.A, obs.b, 6, other.params, 0.5)[0]
    np.testing.assert_allclose(report.heldout_rms, heldout, rtol=1e-8)


def test_prediction_across_blocks_equals_the_dense_one(rv3sb):
    model, _ = rv3sb
    rng = np.random.default_rng(8)
    N = BLOCK_SAMPLES + 37
    q, qd, qdd = rng.uniform(-2, 2, (3, N, 6))
    samples = JointSamples(np.arange(N) / 100.0, q, qd, qdd, np.zeros((N, 6)), 100.0)
    result = identify(model, rv3sb[1], method="ols")
    dense = observations(model, result.base, samples).predict(result.params)
    got = result.predict(model, samples)
    assert np.abs(got - dense).max() < 1e-12 * np.abs(dense).max()


def panda_samples():
    from rmdrake.dynamics.data import stack_samples
    from rmdrake.dynamics.log_samples import prepare_logs

    if not (PANDA / "trajectory1.csv").exists():
        pytest.skip(f"the real Panda log is not here ({PANDA})")
    model = load_robot(str(PANDA / "panda.yaml"))
    parts = prepare_logs([PANDA / "trajectory1.csv"], 7, rate=200.0, cutoff=10.0)[1]
    return model, stack_samples(parts)


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh", "panda"])
def test_observation_rank_unchanged(name):
    """The observation matrix's singular values from the factor are the
    dense matrix's (1e-9 of the largest), so its rank (= the number of base
    parameters, 52, 52 and 62) and condition are unchanged; the real Panda
    log is read in place."""
    if name == "panda":
        model, samples = panda_samples()
    else:
        model = load_robot(name)
        rng = np.random.default_rng(1)
        q, qd, qdd = rng.uniform(-2, 2, (3, 300, 6))
        tau = rng.standard_normal((300, 6))
        samples = JointSamples(np.arange(300) / 100.0, q, qd, qdd, tau, 100.0)
    result = identify(model, samples, method="ols")
    base, p = result.base, result.base.count
    dense = np.linalg.svd(observations(model, base, samples).A, compute_uv=False)
    got = np.linalg.svd(result.observations.factor()[:p, :p], compute_uv=False)
    np.testing.assert_allclose(got, dense, rtol=0, atol=1e-9 * dense[0])
    assert np.sum(got > 1e-10 * got[0]) == p == {"panda": 62}.get(name, 52)


@pytest.mark.parametrize("method", ["ols", "physical"])
def test_one_tall_factorisation_per_identification(rv3sb, monkeypatch, method):
    """identify, the sanity checks and the written model together pass the
    (N n, p) matrix through QR, lstsq, SVD or pinv about once (rows factored
    under 1.3 N n; before: over 4.5 N n) and never hold more than a block of
    it in one factorisation (at most BLOCK_SAMPLES + p + 1 rows)."""
    model = rv3sb[0]
    rng = np.random.default_rng(3)
    N = 3 * BLOCK_SAMPLES + 100
    q, qd, qdd = rng.uniform(-2, 2, (3, N, 6))
    chi = standard_parameters(model)
    tau = torques(model, q, qd, qdd, chi) + 0.1 * rng.standard_normal((N, 6))
    samples = JointSamples(np.arange(N) / 100.0, q, qd, qdd, tau, 100.0)
    rows = []

    def counted(module, name):
        original = getattr(module, name)

        def wrapper(a, *args, **kwargs):
            a = np.asarray(a)
            rows.append((a.shape[-2], int(np.prod(a.shape[:-1]))))
            return original(a, *args, **kwargs)

        monkeypatch.setattr(module, name, wrapper)

    for module, name in [
        (np.linalg, "qr"),
        (np.linalg, "lstsq"),
        (np.linalg, "svd"),
        (np.linalg, "pinv"),
        (scipy.linalg, "qr"),
        (scipy.linalg, "lstsq"),
        (scipy.linalg, "svd"),
    ]:
        counted(module, name)
    result = identify(model, samples, method=method)
    check_identification(result)
    identified_model(model, result)
    p = result.base.count
    assert max(r for r, _ in rows) <= BLOCK_SAMPLES + p + 1
    assert sum(total for _, total in rows) < 1.3 * N * 6
