"""Point calibration (laser tracker, motion capture) against known truth: the
analytic Jacobian against finite differences, exact recovery from noise-free
points, the reported std against the spread over seeds, the held-out error
against the noise, cross-validation that never sees the held-out poses, and
instrument readings predicted from the saved YAML alone."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.identifiability import analyse_point_identifiability
from rmdrake.calibration.points.lm import PointLM
from rmdrake.calibration.points.problem import PointProblem, initial_alignment
from rmdrake.calibration.points.selection import cross_validate, pose_splits
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.kinematics.forward import tool_points
from rmdrake.kinematics.rotations import rotation_from_rpy
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot

NOISE = 2e-5


def _identifiable(model, data) -> list[str]:
    names = error_parameter_names(model, "full")
    return analyse_point_identifiability(model, data, names).identifiable


@pytest.fixture(scope="module")
def truth():
    """RV-3SB with 0.3 mm / 0.3 mrad errors on its point-identifiable set, and
    the poses and instrument of a 50 x 3 simulation."""
    nominal = load_robot("rv3sb")
    probe = simulate_points(nominal, poses=50, markers=3, noise=0, seed=7).data
    names = _identifiable(nominal, probe)
    deltas = 3e-4 * np.random.default_rng(3).standard_normal(len(names))
    return nominal, names, deltas, apply_deltas(nominal, names, deltas)


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
def test_jacobian_matches_finite_differences(robot, boom):
    model = load_robot("rv3sb") if robot == "rv3sb" else boom
    data = simulate_points(model, poses=8, markers=2, noise=1e-4, seed=2).data
    names = error_parameter_names(model, "full")
    idx = error_parameter_indices(model, names)
    R, p, markers = initial_alignment(model.table, data, sigma=model.sigma)
    problem = PointProblem(model.table, data, idx, R, sigma=model.sigma)
    rng = np.random.default_rng(0)
    x = problem.pack(1e-2 * rng.standard_normal(idx.size), p, markers)
    x[idx.size : idx.size + 3] = [0.3, -0.2, 0.5]  # far from R0: J_l matters
    J = problem.jacobian(x)
    h = 1e-6
    fd = np.empty_like(J)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        fd[:, i] = (problem.residuals(x + e) - problem.residuals(x - e)) / (2 * h)
    assert np.abs(J - fd).max() < 1e-7 * max(1.0, np.abs(J).max())


def test_noise_free_recovers_the_truth_from_no_prior(truth):
    nominal, names, deltas, true = truth
    sim = simulate_points(true, poses=50, markers=3, noise=0, seed=7)
    est = PointLM(nominal, params=names).fit(sim.data)
    assert est.names_ == names
    assert np.abs(est.deltas_ - deltas).max() < 1e-9
    assert np.abs(est.R_IB_ - sim.R_IB).max() < 1e-9
    assert np.abs(est.p_IB_ - sim.p_IB).max() < 1e-9
    assert np.abs(est.markers_ - sim.markers).max() < 1e-9
    assert est.residual_rms_ < 1e-10


def test_held_out_error_and_std_against_seeds(truth):
    """20 noise seeds on the same poses: the spread of each parameter over the
    seeds against its mean reported std (within a factor 1.5 at the median,
    2 for each); the held-out marker error <= 2 x the noise per coordinate."""
    nominal, names, deltas, true = truth
    clean = simulate_points(true, poses=50, markers=3, noise=0, seed=7)
    held = simulate_points(true, poses=30, markers=3, noise=0, seed=8).data
    R, p, m = clean.R_IB, clean.p_IB, clean.markers
    held = PointMeasurements(
        held.pose,
        held.marker,
        held.q,
        (tool_points(true.table, held.q, p_EM=m[held.marker - 1]) @ R.T) + p,
    )
    rng = np.random.default_rng(11)
    values, stds, worst = [], [], 0.0
    for _ in range(20):
        p_I = clean.p_I + NOISE * rng.standard_normal(clean.p_I.shape)
        d = clean.data
        est = PointLM(nominal, params="full").fit(
            PointMeasurements(d.pose, d.marker, d.q, p_I)
        )
        assert est.names_ == names
        values.append(est.deltas_)
        stds.append(est.std_)
        e = np.linalg.norm(held.p_I - est.predict(held), axis=1)
        worst = max(worst, float(np.sqrt(np.mean(e**2))))
    ratio = np.std(values, axis=0, ddof=1) / np.mean(stds, axis=0)
    assert 1 / 1.5 < np.median(ratio) < 1.5
    assert np.all((ratio > 0.5) & (ratio < 2.0))
    assert worst < 2 * NOISE


def test_prediction_from_the_saved_yaml_alone(truth, tmp_path):
    nominal, names, deltas, true = truth
    sim = simulate_points(true, poses=40, markers=3, noise=NOISE, seed=5)
    est = PointLM(nominal, params="full").fit(sim.data)
    path = est.model_.save(tmp_path / "cal.yaml")
    del est
    saved = yaml.safe_load(path.read_text())
    model = load_robot(path)
    cal = saved["calibration"]
    R = rotation_from_rpy(np.array([cal["X_IB"]["rpy"]]))[0]
    xyz = np.array(cal["X_IB"]["xyz"])
    markers = np.array(cal["markers"])  # ascending marker id
    new = simulate_points(true, poses=20, markers=3, noise=0, seed=5)
    q = simulate_points(true, poses=20, markers=3, noise=0, seed=99).data.q
    which = np.searchsorted(cal["marker_ids"], new.data.marker)
    p_E = markers[which]
    predicted = tool_points(model.table, q, p_EM=p_E, sigma=model.sigma) @ R.T + xyz
    actual = tool_points(true.table, q, p_EM=new.markers[which]) @ new.R_IB.T
    actual += new.p_IB
    err = np.linalg.norm(predicted - actual, axis=1)
    assert np.sqrt(np.mean(err**2)) < 2 * NOISE
    assert set(cal["parameters"]) == set(names)
    assert cal["residual_rms"] < 3 * NOISE


def test_cross_validation_never_sees_held_out_poses(truth):
    nominal, names, deltas, true = truth
    data = simulate_points(true, poses=20, markers=2, noise=NOISE, seed=9).data
    splits = pose_splits(data, folds=4, seed=3)
    assert np.array_equal(np.sort(np.concatenate(splits)), data.pose_ids)
    again = pose_splits(data, folds=4, seed=3)
    assert all(np.array_equal(a, b) for a, b in zip(splits, again, strict=True))
    cv = cross_validate(
        lambda: PointLM(nominal, params="offsets"), data, folds=4, seed=3
    )
    expected = []
    for test_ids in splits:
        train = data.subset(~np.isin(data.pose, test_ids))
        test = data.of_poses(test_ids)
        est = PointLM(nominal, params="offsets").fit(train)
        expected.append(np.linalg.norm(test.p_I - est.predict(test), axis=1))
    assert np.array_equal(cv.errors, np.concatenate(expected))
    one = pose_splits(data, holdout=0.25, seed=1)
    assert len(one) == 1 and one[0].size == 5


def test_auto_choice_is_reported(truth):
    """True errors on joint offsets only: the choice is the offsets (adding
    more parameters does not lower the CV error by 1 %), and the record and
    summary report every candidate's selection CV."""
    nominal = truth[0]
    names = ["dtheta2", "dtheta3", "dtheta4", "dtheta5"]
    true = apply_deltas(nominal, names, [1e-3, -2e-3, 1.5e-3, 1e-3])
    data = simulate_points(true, poses=30, markers=2, noise=NOISE, seed=2).data
    est = PointLM(nominal, params="auto", folds=3).fit(data)
    assert est.selection_.label == "offsets"
    assert set(names) <= set(est.names_)
    record = est.model_.calibration["selection"]
    assert record["chosen"] == "offsets" and record["folds"] == 3
    labels = [c["label"] for c in record["candidates"]]
    assert labels[:2] == ["base", "offsets"]
    base, offsets = record["candidates"][:2]
    assert offsets["cv_rms"] < 3 * NOISE < base["cv_rms"]
    assert "selection CV RMS" in est.summary()


def test_auto_choice_is_the_one_se_rule(truth):
    """A true length error beside the offsets: every candidate's recorded CV
    (RMS and its SE) matches an independent cross_validate of its names, and
    the chosen set is the one with the fewest parameters whose CV RMS is within
    one SE (std of the per-fold RMS / sqrt(K)) of the best candidate's: here
    the true set (offsets + dd3), where the smallest CV RMS (the old rule) is a
    set with spurious additions that fit the noise of the split."""
    nominal = truth[0]
    names = ["dtheta2", "dtheta3", "dtheta4", "dd3"]
    true = apply_deltas(nominal, names, [1e-3, -2e-3, 1.5e-3, 1e-3])
    data = simulate_points(true, poses=24, markers=2, noise=NOISE, seed=4).data
    sel = PointLM(nominal, params="auto", folds=3, seed=1).fit(data).selection_
    assert len(sel.candidates) >= 3  # the length error is worth an addition
    rms, se = [], []
    for _, cand, r, _, s in sel.candidates:
        cv = cross_validate(
            lambda c=cand: PointLM(nominal, params=c), data, folds=3, seed=1
        )
        assert r == pytest.approx(cv.rms, rel=1e-9)
        rms.append(cv.rms)
        se.append(np.std(cv.fold_rms, ddof=1) / np.sqrt(3))
        assert s == pytest.approx(se[-1], rel=1e-9)
    best = int(np.argmin(rms))
    assert sel.threshold == pytest.approx(rms[best] + se[best], rel=1e-9)
    sizes = [len(c[1]) for c in sel.candidates]
    ok = [i for i in range(len(rms)) if rms[i] <= rms[best] + se[best]]
    pick = min(ok, key=lambda i: sizes[i])
    assert sel.label == sel.candidates[pick][0]
    assert sel.cv_rms == pytest.approx(rms[pick], rel=1e-9)
    assert sel.label == "+ dd3" and set(names) <= set(sel.chosen)
    assert best != pick  # the noise-fitting additions lowered the CV RMS


def test_auto_repeats_pool_the_splits(truth):
    """``repeats=2``: each candidate's selection CV is the RMS of the held-out
    errors pooled over the 3-fold splits at seeds 1 and 2 (independent
    cross_validate of its names), its SE std(the 6 per-fold RMS) / sqrt(3)."""
    nominal = truth[0]
    names = ["dtheta2", "dtheta3", "dtheta4", "dd3"]
    true = apply_deltas(nominal, names, [1e-3, -2e-3, 1.5e-3, 1e-3])
    data = simulate_points(true, poses=24, markers=2, noise=NOISE, seed=4).data
    est = PointLM(nominal, params="auto", folds=3, seed=1, repeats=2).fit(data)
    sel = est.selection_
    assert sel.repeats == 2 and est.model_.calibration["selection"]["repeats"] == 2
    for _, cand, r, mx, s in sel.candidates[:3]:
        cvs = [
            cross_validate(
                lambda c=cand: PointLM(nominal, params=c), data, folds=3, seed=k
            )
            for k in (1, 2)
        ]
        e = np.concatenate([cv.errors for cv in cvs])
        folds = np.concatenate([cv.fold_rms for cv in cvs])
        assert r == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-9)
        assert mx == pytest.approx(e.max(), rel=1e-9)
        assert s == pytest.approx(np.std(folds, ddof=1) / np.sqrt(3), rel=1e-9)
    assert set(names) <= set(est.names_)
