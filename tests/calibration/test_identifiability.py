"""Identifiability of error parameters from plate readings: the kept set is a
fixed function of the robot and of what the data see, never of round-off, of the
order the names are given in, or of which plates were used."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.plates.cost import PlaneProblem, fit_planes
from rmdrake.calibration.plates.identifiability import analyse_identifiability
from rmdrake.calibration.plates.simulate import simulate_plates
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)

# The RV-3SB `full` preset's identifiable set: the paper's 17 (Table 1) plus
# dtheta2..5 and dbeta7. Where parameters act alike the earlier one in table
# order is kept: dr2 (not dr3) on the parallel axes 2-3, dr6 (not dr7), dtheta5
# (not dbeta5).
RV3SB_FULL = [
    *("dalpha2", "dd2", "dtheta2", "dr2", "dalpha3", "dd3", "dtheta3", "dbeta3"),
    *("dalpha4", "dd4", "dtheta4", "dr4", "dalpha5", "dd5", "dtheta5", "dr5"),
    *("dalpha6", "dd6", "dr6", "dalpha7", "dd7", "dbeta7"),
]

# Ten plate data sets: seeds, plate counts and readings per plate all differ
# (always more readings than the 22 parameters plus 3 unknowns per plate).
DATA_SETS = [(seed, 4 + seed % 3, 10 + seed % 4) for seed in range(10)]


@pytest.fixture(scope="module")
def plate_sets():
    from rmdrake.model.loading import load_robot

    model = load_robot("rv3sb")
    sims = [
        simulate_plates(model, plates=p, per_plate=m, noise=2e-6, seed=s)
        for s, p, m in DATA_SETS
    ]
    return model, sims


def test_full_preset_keeps_the_same_names_on_every_data_set(plate_sets):
    model, sims = plate_sets
    names = error_parameter_names(model, "full")
    for sim, (seed, _, _) in zip(sims, DATA_SETS, strict=True):
        shuffled = [str(n) for n in np.random.default_rng(seed).permutation(names)]
        report = analyse_identifiability(model, sim.data, shuffled)
        assert sorted(report.identifiable) == sorted(RV3SB_FULL), seed
        # Reported in the order the names were given.
        assert report.identifiable == [n for n in shuffled if n in RV3SB_FULL]
        assert set(report.dropped) == set(names) - set(RV3SB_FULL)
        # The decision has a wide margin: structural dependencies, not round-off.
        assert report.weakest_kept > 1e-3, seed
        assert report.strongest_dropped < 1e-10, seed


def _scaled_jacobian(model, data, names):
    """Unit-column Jacobian [parameters | plates] at the nominal (an oracle built
    from the cost's own Jacobian, independent of the selection)."""
    idx = error_parameter_indices(model, names)
    points = tool_points(model.table, data.q, data.distance)
    normals, offsets = fit_planes(points, data.plate_index, data.plate_ids.size)
    problem = PlaneProblem(model.table, data, idx, normals)
    J = problem.jacobian(problem.pack(np.zeros(len(names)), offsets))
    return J / np.linalg.norm(J, axis=0)


def test_kept_set_is_a_basis_of_what_the_plates_see(plate_sets):
    """Kept parameters + plates have full column rank; adding any dropped
    parameter that acts at all makes it rank-deficient (singular values)."""
    model, sims = plate_sets
    data = sims[0].data
    report = analyse_identifiability(model, data, error_parameter_names(model, "full"))
    J = _scaled_jacobian(model, data, report.identifiable)
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] / s[0] > 1e-4
    for name, why in report.dropped.items():
        if "no effect" in why:
            continue
        J_plus = _scaled_jacobian(model, data, [*report.identifiable, name])
        s = np.linalg.svd(J_plus, compute_uv=False)
        assert s[-1] / s[0] < 1e-10, name


def test_alike_parameters_keep_the_earlier_row(plate_sets):
    """dr2 and dr3 move the tool alike (parallel axes 2 and 3): dr2 is kept in
    either order."""
    model, sims = plate_sets
    for names in (["dr3", "dr2", "dd3"], ["dd3", "dr2", "dr3"]):
        report = analyse_identifiability(model, sims[1].data, names)
        assert sorted(report.identifiable) == ["dd3", "dr2"]
        assert "dr2" in report.dropped["dr3"]


def test_paper_preset_is_full_rank(plate_sets):
    model, sims = plate_sets
    names = error_parameter_names(model, "paper")
    report = analyse_identifiability(model, sims[2].data, names)
    assert report.full_rank and report.identifiable == names
    assert report.dropped == {} and report.strongest_dropped == 0.0
    assert np.isfinite(report.condition_number)


def test_demo_rh_keeps_one_named_set_too():
    """Another geometry (the DEMO-class arm, 7.5 m reach, 10 um readings): two
    plate sets of different sizes give one named set, with a wide margin."""
    from rmdrake.model.loading import load_robot

    model = load_robot("demo_rh")
    names = error_parameter_names(model, "full")
    reports = [
        analyse_identifiability(
            model,
            simulate_plates(model, plates=p, per_plate=12, noise=1e-5, seed=s).data,
            names[::-1],
        )
        for s, p in ((1, 6), (4, 5))
    ]
    assert sorted(reports[0].identifiable) == sorted(reports[1].identifiable)
    for report in reports:
        assert report.weakest_kept > 1e-3 and report.strongest_dropped < 1e-10
        # Alike pairs keep the earlier row: dr2 over dr3 (parallel axes 2, 3).
        assert "dr2" in report.identifiable and "dr3" in report.dropped
