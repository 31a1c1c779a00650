"""The plates' automatic choice of parameters (``params="auto"``): K-fold
cross-validation over whole plates and the one-SE rule shared with the points,
each checked against a known true robot: errors inside the paper's 17 (auto
does as well as ``paper``), errors outside them (auto finds them, ``paper``
cannot), the same seed giving the same choice, and the held-out plates never
entering the fit."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.plates.cost import fit_plane
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.estimators import PlaneLM, VolumeDE, VolumeDEPlaneLM
from rmdrake.calibration.plates.selection import (
    plate_cross_validate,
    plate_distances,
    plate_splits,
)
from rmdrake.calibration.plates.simulate import random_poses, simulate_plates
from rmdrake.calibration.selection import one_se_choice, stepwise_selection
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot

NOISE = 2e-6
"""m: the range finder's simulated noise (the CLI's default)."""

OUTSIDE = ["dtheta2", "dtheta3", "dtheta4", "dtheta5", "dbeta7"]
"""The RV-3SB's identifiable parameters (``full``) that ``paper`` lacks."""


@pytest.fixture(scope="module")
def nominal():
    return load_robot("rv3sb")


@pytest.fixture(scope="module")
def q_held_out(nominal):
    """200 random poses no calibration sees."""
    return random_poses(nominal, 200, 99)


def _true_robot(nominal, seed, outside):
    """Errors of std 0.3 mm / 0.3 mrad on the paper's 17, and of std 1 mrad on
    the 5 identifiable parameters outside them when ``outside``."""
    paper = error_parameter_names(nominal, "paper")
    rng = np.random.default_rng(300 + seed)
    deltas = 3e-4 * rng.standard_normal(len(paper))
    if not outside:
        return apply_deltas(nominal, paper, deltas)
    more = 1e-3 * rng.standard_normal(len(OUTSIDE))
    return apply_deltas(nominal, paper + OUTSIDE, np.concatenate([deltas, more]))


@pytest.fixture(scope="module")
def inside(nominal):
    """Errors inside the paper set only; 8 plates x 12 readings."""
    true = _true_robot(nominal, 0, outside=False)
    sim = simulate_plates(
        true, plates=8, per_plate=12, noise=NOISE, seed=0, planning_model=nominal
    )
    return true, sim.data


@pytest.fixture(scope="module")
def outside(nominal):
    """Errors outside the paper set too; the CLI's default design, 5 plates x
    12 readings (the new user's case: ``paper`` leaves several times the
    noise)."""
    true = _true_robot(nominal, 1, outside=True)
    sim = simulate_plates(
        true, plates=5, per_plate=12, noise=NOISE, seed=1, planning_model=nominal
    )
    return true, sim.data


def _tool_error(est, true, q):
    """Mean held-out tool-point error of a fitted estimator, m."""
    return tool_point_errors(est.model_, true, q).mean


def test_errors_inside_the_paper_set_auto_does_as_well_as_paper(
    nominal, inside, q_held_out
):
    """(a) The truth is inside ``paper``: auto's held-out tool error is within
    1.2x of paper's (here it keeps the paper set: no addition beats its SE)."""
    true, data = inside
    paper = PlaneLM(nominal, params="paper").fit(data)
    auto = PlaneLM(nominal, params="auto").fit(data)
    e_paper = _tool_error(paper, true, q_held_out)
    e_auto = _tool_error(auto, true, q_held_out)
    assert e_auto <= 1.2 * e_paper
    assert auto.selection_.candidates[0][0] == "paper"
    assert set(error_parameter_names(nominal, "paper")) <= set(auto.names_)
    assert auto.selection_.label == "paper"


def test_errors_outside_the_paper_set_auto_finds_them(nominal, outside, q_held_out):
    """(b) The truth has 1 mrad errors outside ``paper``: paper's residual is
    several times the noise; auto's is within 2x of it and its held-out tool
    error at least 3x below paper's."""
    true, data = outside
    paper = PlaneLM(nominal, params="paper").fit(data)
    auto = PlaneLM(nominal, params="auto").fit(data)
    assert paper.residual_rms_ > 3 * NOISE  # the premise: paper cannot fit it
    assert NOISE / 2 < auto.residual_rms_ < 2 * NOISE
    e_paper = _tool_error(paper, true, q_held_out)
    e_auto = _tool_error(auto, true, q_held_out)
    assert e_auto < e_paper / 3
    assert len(auto.names_) > 17
    sel = auto.selection_
    assert sel.threshold == pytest.approx(
        min(c[2] for c in sel.candidates) + min(sel.candidates, key=lambda c: c[2])[4],
        rel=1e-12,
    )
    record = auto.model_.calibration["selection"]
    assert record["chosen"] == sel.label and record["folds"] == 5
    assert [c["label"] for c in record["candidates"]][0] == "paper"
    text = auto.summary()
    assert "automatic parameter choice (5-fold CV over plates" in text
    assert f"{sel.label:<24}" in text and "<- chosen" in text


def test_de_lm_takes_the_choice_of_its_lm(nominal, outside):
    """de+lm with auto: the same choice as lm's (same split seed), then its DE
    and LM on the chosen set; the DE alone refuses auto in one line."""
    _, data = outside
    lm = PlaneLM(nominal, params="auto").fit(data)
    both = VolumeDEPlaneLM(nominal, params="auto", maxiter=20).fit(data)
    assert both.selection_.chosen == lm.selection_.chosen
    assert both.de_.names_ == both.names_
    assert both.model_.calibration["selection"]["chosen"] == lm.selection_.label
    assert both.residual_rms_ == pytest.approx(lm.residual_rms_, rel=1e-3)
    with pytest.raises(ValueError, match=r"^params 'auto' is chosen by cross-val"):
        VolumeDE(nominal, params="auto").fit(data)


def test_same_seed_same_choice(nominal, inside):
    """(c) The split is a seeded permutation of the plate ids: the same seed
    gives the same folds and the same candidates and choice; another seed
    deals other folds."""
    _, data = inside
    a, b = (plate_splits(data, folds=3, seed=4) for _ in range(2))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert sorted(np.concatenate(a).tolist()) == data.plate_ids.tolist()
    other = plate_splits(data, folds=3, seed=5)
    assert not all(np.array_equal(x, y) for x, y in zip(a, other, strict=True))
    first = PlaneLM(nominal, params="auto", folds=3, seed=4).fit(data).selection_
    again = PlaneLM(nominal, params="auto", folds=3, seed=4).fit(data).selection_
    assert first == again


def test_held_out_plates_never_enter_the_fit(nominal, inside):
    """(d) Corrupting the plates held out in fold 0 leaves fold 0's fit
    unchanged bit for bit (and raises its held-out score), while the folds
    that train on them change; the fold's score is the pooled RMS of the
    distances to each held-out plate's own SVD plane over its readings - 3."""
    _, data = inside
    names = error_parameter_names(nominal, "paper")
    splits = plate_splits(data, folds=4, seed=2)
    fits: list[list] = [[], []]

    def make(run):
        def build():
            est = PlaneLM(nominal, params=names)
            fits[run].append(est)
            return est

        return build

    clean = plate_cross_validate(make(0), data, folds=4, seed=2)
    held = np.isin(data.plane, splits[0])
    rng = np.random.default_rng(0)
    q = data.q.copy()
    q[held] += 1e-3 * rng.standard_normal(q[held].shape)
    distance = data.distance + np.where(held, 1e-4, 0.0)
    dirty = PlaneMeasurements(data.plane, q, distance)
    corrupted = plate_cross_validate(make(1), dirty, folds=4, seed=2)
    assert np.array_equal(fits[0][0].deltas_, fits[1][0].deltas_)
    for k in range(1, 4):
        assert not np.array_equal(fits[0][k].deltas_, fits[1][k].deltas_)
    assert corrupted.fold_rms[0] > 10 * clean.fold_rms[0]
    # Fold 0's score by hand: the held-out points of the training fit, one
    # SVD plane per plate, sum d^2 / sum (m_p - 3).
    model = fits[0][0].model_
    test = data.subset(held)
    pts = tool_points(model.table, test.q, test.distance, sigma=model.sigma)
    sq, dof = 0.0, 0
    for plate in splits[0]:
        p = pts[test.plane == plate]
        n, h = fit_plane(p)
        sq += float(np.sum((p @ n - h) ** 2))
        dof += p.shape[0] - 3
    assert clean.fold_rms[0] == pytest.approx(np.sqrt(sq / dof), rel=1e-12)
    d, dofs = plate_distances(model, test)
    assert dofs.sum() == dof and d.size == test.n_readings
    pooled = np.sqrt(np.sum(clean.distances**2) / np.sum(clean.dof))
    assert clean.rms == pytest.approx(pooled, rel=1e-12)


def test_too_few_plates_to_split(nominal, inside):
    _, data = inside
    with pytest.raises(ValueError, match=r"folds: expected 2\.\.8"):
        plate_splits(data, folds=9)
    three = data.subset(np.isin(data.plane, data.plate_ids[:3]))
    with pytest.raises(ValueError, match="fewer than 2 plates to fit on"):
        plate_splits(three, folds=2)
    assert len(plate_splits(three, folds=3)) == 3


def test_stepwise_and_one_se_rule_on_known_scores():
    """The shared rule on a made-up score: additions while one gains >= 1 %,
    the ``after`` set scored once, and the smallest candidate within the best
    CV RMS + its SE; a floor makes round-off differences ties."""
    table = {
        (): (10.0, 20.0, 0.5),
        ("a",): (5.0, 9.0, 0.5),
        ("a", "b"): (4.0, 8.0, 0.5),
        ("a", "b", "c"): (3.97, 8.0, 0.5),  # 0.75 %: not an addition
        ("a", "b", "d"): (4.5, 8.0, 0.5),
        ("a", "b", "c", "d"): (3.0, 6.0, 1.5),
    }
    scored = []

    def score(names):
        scored.append(tuple(names))
        return table.get(tuple(sorted(names)), (np.inf, np.inf, np.inf))

    got = stepwise_selection(
        score,
        [],
        ["a", "b", "c", "d"],
        start_label="none",
        after=[("all", ["a", "b", "c", "d"]), ("again", ["b", "a"])],
    )
    assert [c[0] for c in got.candidates] == ["none", "+ a", "+ b", "all"]
    assert scored.count(("a", "b", "c", "d")) == 1 and ("b", "a") not in scored
    # best: all (3.0 +- 1.5) -> threshold 4.5: the smallest within is + b
    assert (got.label, got.chosen, got.threshold) == ("+ b", ["a", "b"], 4.5)
    tiny = [("s", ["x"], 1e-15, 0.0, 1e-16), ("t", ["x", "y"], 1e-16, 0.0, 0.0)]
    assert one_se_choice(tiny)[0] == "t"
    assert one_se_choice(tiny, floor=1e-9)[:2] == ("s", ["x"])
