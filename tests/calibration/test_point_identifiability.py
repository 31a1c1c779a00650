"""Identifiability from measured tool points: the instrument pose and the
markers are projected out first, then the fixed MDH preference order; checked
for determinism (seeds, name order) and against an SVD oracle."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.points.identifiability import analyse_point_identifiability
from rmdrake.calibration.points.problem import PointProblem, initial_alignment
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot


def _jacobian(model, data, names):
    idx = error_parameter_indices(model, names)
    R, p, markers = initial_alignment(model.table, data, sigma=model.sigma)
    problem = PointProblem(model.table, data, idx, R, sigma=model.sigma)
    J = problem.jacobian(problem.pack(np.zeros(len(names)), p, markers))
    return J / np.linalg.norm(J, axis=0)


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
def test_kept_set_is_deterministic_and_svd_oracle(robot, boom):
    model = load_robot("rv3sb") if robot == "rv3sb" else boom
    names = error_parameter_names(model, "full")
    kept = None
    for seed in (1, 2, 3):
        data = simulate_points(model, poses=30, markers=3, seed=seed).data
        shuffled = list(np.random.default_rng(seed).permutation(names))
        report = analyse_point_identifiability(model, data, shuffled)
        got = sorted(report.identifiable)
        assert kept is None or got == kept
        kept = got
    # The base row and the tool row never survive (base pose, markers).
    assert not any(
        n.endswith("1") and n[1:-1] in ("alpha", "d", "theta", "r", "beta")
        for n in kept
    )
    n1 = model.n_joints + 1
    assert not any(n.endswith(str(n1)) for n in kept)
    # Oracle: kept + nuisance has full column rank; adding any dropped
    # parameter collapses the smallest singular value.
    J = _jacobian(model, data, kept)
    sv = np.linalg.svd(J, compute_uv=False)
    assert sv[-1] > 1e-4 * sv[0]
    for name in set(names) - set(kept):
        Jd = _jacobian(model, data, [*kept, name])
        sd = np.linalg.svd(Jd, compute_uv=False)
        assert sd[-1] < 1e-9 * sd[0], name


def test_boom_lift_offset_is_absorbed_by_the_base(boom):
    """The prismatic column's offset dr1 moves every point along z0: the base
    pose absorbs it, and the report says so."""
    data = simulate_points(boom, poses=20, markers=2, seed=0).data
    report = analyse_point_identifiability(boom, data, ["dr1", "dtheta2", "dr4"])
    assert report.identifiable == ["dtheta2", "dr4"]
    assert "instrument pose and markers" in report.dropped["dr1"]
