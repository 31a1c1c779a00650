"""Pose (6-DoF) calibration against known truth: SO(3) helpers against
scipy, the analytic Jacobian against finite differences, the identifiable set,
exact recovery from noise-free readings with no prior, the held-out error
against the Cramer-Rao bound over seeds, the D-optimal pose choice, the
sanity checks against the declared noises, and the automatic choice."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.identifiability import analyse_pose_identifiability
from rmdrake.calibration.poses.lm import PoseLM, pose_errors
from rmdrake.calibration.poses.pose_selection import select_d_optimal_poses
from rmdrake.calibration.poses.problem import PoseProblem, initial_alignment
from rmdrake.calibration.poses.selection import cross_validate
from rmdrake.calibration.poses.simulate import simulate_poses
from rmdrake.calibration.poses.so3 import (
    so3_exp_many,
    so3_log_many,
    so3_right_jacobian_inverse_many,
)
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot

SIGMA_P, SIGMA_R = 2e-5, 5e-5  # m, rad


def _identifiable(model, data) -> list[str]:
    names = error_parameter_names(model, "full")
    return analyse_pose_identifiability(model, data, names).identifiable


@pytest.fixture(scope="module")
def truth():
    """RV-3SB with 0.3 mm / 0.3 mrad errors on its pose-identifiable set."""
    nominal = load_robot("rv3sb")
    probe = simulate_poses(nominal, poses=50, noise_p=0, noise_r=0, seed=7).data
    names = _identifiable(nominal, probe)
    deltas = 3e-4 * np.random.default_rng(3).standard_normal(len(names))
    return nominal, names, deltas, apply_deltas(nominal, names, deltas)


def test_so3_helpers_against_scipy(rng):
    from scipy.spatial.transform import Rotation

    r = rng.standard_normal((200, 3))
    r *= (rng.uniform(0, np.pi, 200) / np.linalg.norm(r, axis=1))[:, None]
    r[:4] = [[0, 0, 0], [1e-9, 0, 0], [0, np.pi - 1e-9, 0], [0, 0, np.pi - 1e-3]]
    R = so3_exp_many(r)
    assert np.abs(R - Rotation.from_rotvec(r).as_matrix()).max() < 1e-14
    assert np.abs(so3_log_many(R) - r).max() < 1e-12
    at_pi = so3_log_many(so3_exp_many(np.array([[0.0, np.pi, 0.0]])))
    assert np.allclose(np.abs(at_pi), [[0, np.pi, 0]], atol=1e-12)
    # Exp(e) Exp(u) = Exp(e + J_r(e)^-1 u) to first order in u.
    u = 1e-7 * rng.standard_normal((200, 3))
    lhs = so3_log_many(so3_exp_many(r) @ so3_exp_many(u))
    rhs = r + np.einsum("nij,nj->ni", so3_right_jacobian_inverse_many(r), u)
    assert np.abs(lhs - rhs)[4:].max() < 1e-12


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
def test_jacobian_matches_finite_differences(robot, boom):
    model = load_robot("rv3sb") if robot == "rv3sb" else boom
    data = simulate_poses(model, poses=8, noise_p=1e-4, noise_r=1e-3, seed=2).data
    names = error_parameter_names(model, "full")
    idx = error_parameter_indices(model, names)
    X_IB, X_FM = initial_alignment(model.table, data, sigma=model.sigma)
    problem = PoseProblem(
        model.table,
        data,
        idx,
        X_IB[:3, :3],
        X_FM[:3, :3],
        sigma_p=1e-3,
        sigma_r=1e-2,
        sigma=model.sigma,
    )
    rng = np.random.default_rng(0)
    x = problem.pack(1e-2 * rng.standard_normal(idx.size), X_IB[:3, 3], X_FM[:3, 3])
    k = idx.size
    x[k : k + 3] = [0.3, -0.2, 0.5]  # far from R0: J_l and J_r^-1 matter
    x[k + 6 : k + 9] = [-0.4, 0.1, 0.2]
    J = problem.jacobian(x)
    h = 1e-6
    fd = np.empty_like(J)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        fd[:, i] = (problem.residuals(x + e) - problem.residuals(x - e)) / (2 * h)
    assert np.abs(J - fd).max() < 1e-7 * np.abs(J).max()


def test_identifiable_set_drops_what_the_base_and_marker_absorb(truth):
    nominal, names, _, _ = truth
    n = nominal.n_joints
    # 4 R + 2 P + 6 minimal parameters, minus the 12 of X_IB and X_FM.
    assert len(names) == 4 * n + 6 - 12
    full = error_parameter_names(nominal, "full")
    first = [p for p in full if p.endswith("1") and not p.endswith("11")]
    tool = [p for p in full if p.endswith(str(n + 1))]
    assert not set(first + tool + [f"dtheta{n}", f"dr{n}"]) & set(names)


@pytest.mark.parametrize("absorbed", [False, True])
def test_noise_free_recovers_the_truth_from_no_prior(truth, absorbed):
    nominal, names, deltas, true = truth
    if absorbed:  # errors the base and marker transforms take exactly
        n = nominal.n_joints
        extra = ["dalpha1", "dd1", "dtheta1", "dr1", "dbeta1", f"dtheta{n}", f"dr{n}"]
        extra += [f"d{k}{n + 1}" for k in ("alpha", "d", "theta", "r", "beta")]
        more = 5e-3 * np.random.default_rng(4).standard_normal(len(extra))
        true = apply_deltas(true, extra, more)
    sim = simulate_poses(true, poses=40, noise_p=0, noise_r=0, seed=7)
    est = PoseLM(nominal, params=names, noise_p=SIGMA_P, noise_r=SIGMA_R).fit(sim.data)
    assert est.names_ == names
    assert np.abs(est.deltas_ - deltas).max() < 1e-9 * np.abs(deltas).max()
    assert est.residual_rms_p_ < 1e-11 and est.residual_rms_r_ < 1e-11
    if not absorbed:
        assert np.abs(est.X_IB_ - sim.X_IB).max() < 1e-10
        assert np.abs(est.X_FM_ - sim.X_FM).max() < 1e-10


def test_held_out_error_meets_the_cramer_rao_bound(truth):
    """The mean squared held-out prediction error (position and angle, against
    the noise-free truth) over noise seeds is within 1.2x of the one the
    Cramer-Rao bound predicts: C = (J^T J)^-1 of the whitened training
    Jacobian at the truth, E|e|^2 = mean over held-out rows of trace(G C G^T)
    with G the prediction Jacobian there. A mis-weighted fit (sigma_r 30x too
    large) gives 1.7x in position and 21x in angle."""
    nominal, names, deltas, true = truth
    n_train, n_test, seeds = 30, 20, 100
    sim = simulate_poses(true, poses=n_train + n_test, noise_p=0, noise_r=0, seed=11)
    train = sim.data.subset(slice(0, n_train))
    test = sim.data.subset(slice(n_train, None))
    idx = error_parameter_indices(nominal, names)

    def problem(data, sp, sr):
        R_IB, R_FM = sim.X_IB[:3, :3], sim.X_FM[:3, :3]
        return PoseProblem(
            nominal.table, data, idx, R_IB, R_FM, sigma_p=sp, sigma_r=sr,
            sigma=nominal.sigma,
        )  # fmt: skip

    at = problem(train, SIGMA_P, SIGMA_R)
    x_true = at.pack(deltas, sim.X_IB[:3, 3], sim.X_FM[:3, 3])
    J = at.jacobian(x_true)
    C = np.linalg.inv(J.T @ J)
    G = problem(test, 1.0, 1.0).jacobian(x_true).reshape(n_test, 6, -1)
    crb_p = np.mean(np.einsum("nik,kl,nil->n", G[:, :3], C, G[:, :3]))
    crb_r = np.mean(np.einsum("nik,kl,nil->n", G[:, 3:], C, G[:, 3:]))
    X = sim.X_IM[:n_train]
    mse_p, mse_r = [], []
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        noisy = PoseMeasurements(
            train.q,
            X[:, :3, 3] + SIGMA_P * rng.standard_normal((n_train, 3)),
            so3_log_many(
                X[:, :3, :3] @ so3_exp_many(SIGMA_R * rng.standard_normal((n_train, 3)))
            ),
        )
        est = PoseLM(nominal, params=names, noise_p=SIGMA_P, noise_r=SIGMA_R)
        e_p, e_r = pose_errors(sim.X_IM[n_train:], est.fit(noisy).predict(test))
        mse_p.append(np.mean(e_p**2))
        mse_r.append(np.mean(e_r**2))
    ratio_p, ratio_r = np.mean(mse_p) / crb_p, np.mean(mse_r) / crb_r
    assert 1 / 1.2 < ratio_p < 1.2, ratio_p
    assert 1 / 1.2 < ratio_r < 1.2, ratio_r


def test_d_optimal_poses_beat_the_first_drawn(truth):
    nominal, *_ = truth
    first = simulate_poses(nominal, poses=15, noise_p=0, noise_r=0, seed=5)
    best = simulate_poses(
        nominal, poses=15, noise_p=0, noise_r=0, seed=5, selection="d-optimal"
    )

    def logdet(sim) -> float:
        names = error_parameter_names(nominal, "full")
        report = analyse_pose_identifiability(
            nominal, sim.data, names, start=(sim.X_IB, sim.X_FM)
        )
        idx = error_parameter_indices(nominal, report.identifiable)
        p = PoseProblem(
            nominal.table, sim.data, idx, sim.X_IB[:3, :3], sim.X_FM[:3, :3],
            sigma_p=SIGMA_P, sigma_r=SIGMA_R, sigma=nominal.sigma,
        )  # fmt: skip
        J = p.jacobian(p.pack(np.zeros(idx.size), sim.X_IB[:3, 3], sim.X_FM[:3, 3]))
        return float(np.linalg.slogdet(J.T @ J)[1])

    assert np.array_equal(first.X_FM, best.X_FM)  # the same draws before step 3
    assert logdet(best) > logdet(first) + 1.0
    kept = select_d_optimal_poses(nominal, first.data.q, first.X_FM, 5)
    assert kept.size == 5 and np.all(np.diff(kept) > 0)


def test_sanity_against_declared_noises(truth):
    nominal, names, _, true = truth
    sim = simulate_poses(true, poses=40, noise_p=SIGMA_P, noise_r=SIGMA_R, seed=3)
    est = PoseLM(nominal, params=names, noise_p=SIGMA_P, noise_r=SIGMA_R).fit(sim.data)
    assert est.sanity_.ok, est.sanity_.reasons
    assert 0.7 < est.sanity_.residual_rms / SIGMA_P < 1.3
    assert not est.check(noise=(SIGMA_P / 100, SIGMA_R / 100)).ok
    assert not est.check(noise=(SIGMA_P * 100, SIGMA_R * 100)).ok
    # the nominal model misses 0.3 mm errors: 18x the declared noises, warned
    base = PoseLM(nominal, params="base", noise_p=SIGMA_P, noise_r=SIGMA_R)
    assert "misses something" in " ".join(base.fit(sim.data).sanity_.warnings)
    # undeclared noises are estimated within 30 %
    free = PoseLM(nominal, params=names).fit(sim.data)
    assert abs(free.sigma_p_ / SIGMA_P - 1) < 0.3
    assert abs(free.sigma_r_ / SIGMA_R - 1) < 0.3
    record = est.model_.calibration
    assert record["noise"]["source"] == "declared" and len(record["parameters"]) == 18


def test_named_unidentifiable_parameter_is_refused(truth):
    nominal, names, _, true = truth
    data = simulate_poses(true, poses=20, seed=1).data
    with pytest.raises(ValueError, match="dtheta1") as info:
        PoseLM(nominal, params=["dtheta1", *names[:3]]).fit(data)
    assert "\n" not in str(info.value)


def test_auto_choice_and_cross_validation(truth):
    nominal, names, _, _ = truth
    errors = {"dtheta2": 1e-3, "dd3": 1e-3, "dalpha4": -1e-3}  # rad, m
    true = apply_deltas(nominal, list(errors), list(errors.values()))
    sim = simulate_poses(true, poses=30, noise_p=SIGMA_P, noise_r=SIGMA_R, seed=4)
    est = PoseLM(nominal, params="auto", noise_p=SIGMA_P, noise_r=SIGMA_R, folds=3)
    est.fit(sim.data)
    assert set(errors) <= set(est.names_) <= set(names)
    assert est.selection_.cv_rms < 1.5  # normalised: 1 is the noise level
    assert est.sanity_.ok, est.sanity_.reasons

    def make():
        return PoseLM(nominal, params=names, noise_p=SIGMA_P, noise_r=SIGMA_R)

    cv = cross_validate(make, sim.data, folds=3, seed=0)
    assert cv.errors_p.size == sim.data.n_rows
    assert cv.rms_p < 3 * SIGMA_P * np.sqrt(3) and cv.rms_r < 3 * SIGMA_R * np.sqrt(3)
