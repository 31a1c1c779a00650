"""Plane-constraint calibration: oracles for the costs, the Jacobian, the
identifiability analysis, the estimators, the range finder and the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rmdrake.calibration import (
    CALIBRATION_METHODS,
    PlaneLM,
    PlaneMeasurements,
    PlaneProblem,
    RangeFinderSpec,
    VolumeCost,
    VolumeDE,
    VolumeDEPlaneLM,
    analyse_identifiability,
    beam_readings,
    fit_planes,
    make_calibrator,
    plate_quadruples,
    simulate_plates,
    tetrahedron_volumes,
    tool_point_errors,
)
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import TOOL_FRAME, MakePlant
from rmdrake.optimize import differential_evolution


@pytest.fixture(scope="module")
def case():
    """Nominal RV-3SB, a true robot with errors on the paper's 17 parameters
    (about 1 mm tool error) and noise-free readings of it: 5 plates x 12."""
    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    rng = np.random.default_rng(7)
    deltas = 4e-4 * rng.standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    sim = simulate_plates(true, noise=0.0, seed=11)
    return nominal, true, names, deltas, sim


def test_tetrahedron_volume_of_unit_corner():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    v = tetrahedron_volumes(pts, np.array([[0, 1, 2, 3], [0, 2, 1, 3]]))
    np.testing.assert_allclose(v, [1 / 6, -1 / 6], rtol=0, atol=1e-15)


def test_plate_quadruples_fixed_set():
    plate = np.repeat([3, 8], [12, 5])
    quads = plate_quadruples(plate)
    assert quads.shape == (math.comb(12, 4) + math.comb(5, 4), 4)
    assert np.all(plate[quads] == plate[quads[:, :1]])  # one plate per quadruple
    assert len({tuple(sorted(q)) for q in quads}) == len(quads)  # distinct
    capped = plate_quadruples(plate, max_per_plate=30)
    assert capped.shape == (30 + 5, 4)
    np.testing.assert_array_equal(capped, plate_quadruples(plate, 30))


def test_volume_cost_zero_at_truth_positive_away(case):
    nominal, _, names, deltas, sim = case
    idx = error_parameter_indices(nominal, names)
    cost = VolumeCost(nominal.table, sim.data, idx)
    at_truth = cost(deltas)
    at_nominal = cost(np.zeros(len(names)))
    # Noise-free points are coplanar to rounding: volumes ~ 1e-19 m^3 each.
    assert at_truth < 1e-15 * cost.quads.shape[0]
    assert at_nominal > 1e6 * at_truth
    rng = np.random.default_rng(0)
    away = deltas + 1e-5 * rng.standard_normal((20, len(names)))
    values = cost(away)
    assert values.shape == (20,) and np.all(values > 100 * at_truth)
    # One vectorised call equals one call per candidate.
    np.testing.assert_allclose(values, [cost(a) for a in away], rtol=1e-12)


def test_plane_jacobian_matches_central_differences(case):
    nominal, _, names, deltas, sim = case
    idx = error_parameter_indices(nominal, error_parameter_names(nominal, "full"))
    pts = tool_points(nominal.table, sim.data.q, sim.data.distance)
    normals, offsets = fit_planes(pts, sim.data.plate_index, 5)
    problem = PlaneProblem(nominal.table, sim.data, idx, normals)
    rng = np.random.default_rng(3)
    x = problem.pack(1e-3 * rng.standard_normal(idx.size), offsets)
    x[idx.size :] += 1e-2 * rng.standard_normal(15) * np.tile([1, 1, 0.1], 5)
    J = problem.jacobian(x)
    h = 1e-7
    fd = np.empty_like(J)
    for c in range(x.size):
        e = np.zeros_like(x)
        e[c] = h
        fd[:, c] = (problem.residuals(x + e) - problem.residuals(x - e)) / (2 * h)
    assert np.abs(fd - J).max() <= 1e-7 * max(1.0, np.abs(J).max())


def test_paper_preset_identifiable_and_full_preset_subset(case):
    nominal, _, names, _, sim = case
    report = analyse_identifiability(nominal, sim.data, names)
    assert report.full_rank and report.rank == 17
    assert report.n_plate_unknowns == 15
    assert 1 < report.condition_number < 1e4
    full = analyse_identifiability(
        nominal, sim.data, error_parameter_names(nominal, "full")
    )
    assert full.rank == len(full.identifiable) < 35
    for base in ("dalpha1", "dd1", "dtheta1", "dr1", "dbeta1"):
        assert "absorbed by the unknown plate poses" in full.dropped[base]
    assert "no effect" in full.dropped["dtheta7"]  # roll about the beam
    # dr6 and dr7 translate along the same axis: one of them is dropped.
    assert ("dr6" in full.dropped) != ("dr7" in full.dropped)
    assert full.combinations  # the unidentifiable directions are reported
    assert set(full.identifiable) | set(full.dropped) == set(full.names)


def test_lm_recovers_truth_noise_free(case):
    nominal, true, names, deltas, sim = case
    lm = PlaneLM(nominal).fit(sim.data)
    assert lm.names_ == names
    assert np.abs(lm.deltas_ - deltas).max() <= 1e-9
    assert lm.residual_rms_ < 1e-12
    err = tool_point_errors(lm.model_, true, np.zeros((1, 6)) + 0.3)
    assert err.max < 1e-9
    # The plates are found too: normals to 1e-9 (up to sign).
    for plate, n in zip(sim.plates, lm.normals_, strict=True):
        assert 1 - abs(plate.normal @ n) < 1e-12


def test_lm_full_preset_recovers_identifiable_truth(case):
    """With the `full` preset, the automatically chosen identifiable set is
    recovered to 1e-9 when the truth has errors only on that set."""
    nominal, _, _, _, sim = case
    report = analyse_identifiability(
        nominal, sim.data, error_parameter_names(nominal, "full")
    )
    names = report.identifiable
    rng = np.random.default_rng(5)
    deltas = 3e-4 * rng.standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    data = simulate_plates(true, noise=0.0, seed=11).data
    lm = PlaneLM(nominal, params="full").fit(data)
    assert lm.names_ == names
    assert np.abs(lm.deltas_ - deltas).max() <= 1e-9
    assert lm.model_.calibration["dropped"] == lm.identifiability_.dropped


def test_lm_std_consistent_with_errors(case):
    nominal, _, names, deltas, sim = case
    rng = np.random.default_rng(1)
    noise = 2e-6
    data = PlaneMeasurements(
        sim.data.plane,
        sim.data.q,
        sim.data.distance + noise * rng.standard_normal(sim.data.n_readings),
    )
    lm = PlaneLM(nominal).fit(data)
    z = (lm.deltas_ - deltas) / lm.std_
    assert np.all(np.isfinite(lm.std_)) and np.all(lm.std_ > 0)
    assert 0.3 < np.sqrt(np.mean(z**2)) < 3.0
    assert np.abs(z).max() < 5.0
    assert 0.5 * noise < lm.residual_rms_ < 1.5 * noise


def test_robust_loss_resists_an_outlier(case):
    nominal, true, names, deltas, sim = case
    rng = np.random.default_rng(2)
    distance = sim.data.distance + 2e-6 * rng.standard_normal(sim.data.n_readings)
    distance[7] += 1e-3  # one bad reading
    data = PlaneMeasurements(sim.data.plane, sim.data.q, distance)
    q = np.random.default_rng(3).uniform(
        nominal.limits.lower, nominal.limits.upper, (300, 6)
    )
    plain = tool_point_errors(PlaneLM(nominal).fit(data).model_, true, q).mean
    robust_lm = PlaneLM(nominal, loss="soft_l1", f_scale=5e-6).fit(data)
    robust = tool_point_errors(robust_lm.model_, true, q).mean
    assert robust < 0.2 * plain
    assert robust < 1e-4
    assert np.argmax(np.abs(robust_lm.residuals_)) == 7  # the outlier stands out


def test_volume_de_seeded_and_improving(case):
    nominal, _, names, _, sim = case
    kw = dict(maxiter=15, popsize=6, max_per_plate=20, seed=4)
    de = VolumeDE(nominal, **kw).fit(sim.data)
    again = VolumeDE(nominal, **kw).fit(sim.data)
    np.testing.assert_array_equal(de.deltas_, again.deltas_)
    assert de.cost_ <= de.cost_nominal_
    assert de.model_.calibration["method"] == "de"
    both = VolumeDEPlaneLM(nominal, **kw).fit(sim.data)
    assert both.model_.calibration["method"] == "de+lm"
    lm = PlaneLM(nominal).fit(sim.data)
    np.testing.assert_allclose(both.deltas_, lm.deltas_, rtol=0, atol=1e-9)


def test_de_lm_is_de_then_lm_from_its_result(case):
    """DE+LM equals a VolumeDE fit followed by a PlaneLM fit started at the DE's
    deltas (same options, same data: the same computation), and leaves the
    inner estimators' own records alone."""
    nominal, _, _, _, sim = case
    kw = dict(maxiter=10, popsize=5, max_per_plate=10, seed=2)
    both = VolumeDEPlaneLM(nominal, loss="huber", f_scale=1e-5, **kw).fit(sim.data)
    de = VolumeDE(nominal, **kw).fit(sim.data)
    lm = PlaneLM(nominal, x0=de.deltas_, loss="huber", f_scale=1e-5).fit(sim.data)
    np.testing.assert_array_equal(both.de_deltas_, de.deltas_)
    np.testing.assert_array_equal(both.deltas_, lm.deltas_)
    np.testing.assert_array_equal(both.std_, lm.std_)
    assert both.cost_ == de.cost_ and both.names_ == lm.names_
    assert both.de_.model_.calibration["method"] == "de"
    assert both.lm_.model_.calibration["method"] == "lm"
    options = both.model_.calibration["options"]
    assert options["loss"] == "huber" and options["seed"] == 2
    assert options["maxiter"] == 10 and options["popsize"] == 5
    assert both.fit_time_ >= both.de_time_ > 0
    assert "time_s" not in both.model_.calibration  # wall time: printed only
    # the smaller default DE budget of de+lm
    budget = {"popsize": 10, "maxiter": 100, "max_per_plate": 30}
    assert VolumeDEPlaneLM(nominal).de_options.items() >= budget.items()


def test_make_calibrator_methods(case):
    nominal = case[0]
    assert CALIBRATION_METHODS == ("de", "lm", "de+lm")
    for method in CALIBRATION_METHODS:
        assert make_calibrator(method, nominal).method == method
    with pytest.raises(ValueError, match="unknown method 'ga': expected one of de,"):
        make_calibrator("ga", nominal)
    with pytest.raises(TypeError, match="popsise"):
        make_calibrator("de+lm", nominal, popsise=5)  # fails before any fit


def test_unknown_loss_fails_before_the_de(case):
    nominal, *_, sim = case
    est = VolumeDEPlaneLM(nominal, loss="l1", maxiter=10**6)
    with pytest.raises(ValueError, match="unknown loss 'l1'"):
        est.fit(sim.data)
    assert not hasattr(est, "de_")


def test_rank_deficient_parameter_set_names_what_to_drop(case):
    nominal, _, names, _, sim = case
    with pytest.raises(ValueError, match=r"not identifiable.*drop .*dtheta1"):
        PlaneLM(nominal, params=[*names, "dtheta1"]).fit(sim.data)
    with pytest.raises(ValueError, match=r"drop (dr6|dr7)"):
        PlaneLM(nominal, params=[*names, "dr7"]).fit(sim.data)


def test_unknown_parameter_name(case):
    nominal, _, _, _, sim = case
    with pytest.raises(ValueError, match="unknown error parameter 'dgamma2'"):
        PlaneLM(nominal, params="dalpha2,dgamma2").fit(sim.data)
    with pytest.raises(ValueError, match="unknown parameter preset 'all'"):
        PlaneLM(nominal, params="all").fit(sim.data)


def test_simulated_readings_are_valid(case):
    _, true, _, _, sim = case
    data = sim.data
    assert data.n_readings == 60 and list(data.plate_ids) == [0, 1, 2, 3, 4]
    assert np.all((data.distance >= 0.005) & (data.distance <= 0.080))
    assert np.all(sim.incidence <= np.deg2rad(35.0))
    assert np.all((data.q >= true.limits.lower) & (data.q <= true.limits.upper))
    p = tool_points(true.table, data.q, data.distance)
    for i, plate in enumerate(sim.plates):
        on = p[data.plane == i]
        np.testing.assert_allclose(on @ plate.normal, plate.offset, atol=1e-12)
        local = (on - plate.X_BP[:3, 3]) @ plate.X_BP[:3, :2]
        assert np.all(np.abs(local) <= 0.15 + 1e-12)
    again = simulate_plates(true, noise=0.0, seed=11)
    np.testing.assert_array_equal(again.data.q, data.q)
    text = sim.summary()
    assert text.startswith("60 readings on 5 plates; readings ")
    assert "noise 0 um" in text and text.count("\n  plate ") == 5


def test_differential_evolution_vectorised_and_seeded():
    shapes = []

    def sphere(x):
        shapes.append(x.shape)
        return np.sum((x - 0.25) ** 2, axis=1)

    kw = dict(seed=3, maxiter=200, tol=1e-10, progress=False)
    a = differential_evolution(sphere, [(-1, 1)] * 3, **kw)
    b = differential_evolution(sphere, [(-1, 1)] * 3, **kw)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_allclose(a.x, 0.25, atol=1e-4)
    assert shapes[0] == (45, 3) and a.time > 0
    with pytest.raises(ValueError, match="bounds"):
        differential_evolution(sphere, [(1, -1)], seed=0)


def test_too_few_readings_for_the_unknowns(case):
    nominal, _, _, _, sim = case
    few = sim.data.subset(
        np.concatenate([np.arange(p * 12, p * 12 + 5) for p in range(5)])
    )
    with pytest.raises(ValueError, match=r"25 readings cannot identify 17 parameters"):
        PlaneLM(nominal).fit(few)


# -- the range finder -------------------------------------------------------------


def _beams(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N, 4, 4) tool poses with the given origins and unit beam directions."""
    X = np.tile(np.eye(4), (len(origins), 1, 1))
    for i, z in enumerate(directions):
        x = np.cross(z, [0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0])
        x /= np.linalg.norm(x)
        X[i, :3, 0], X[i, :3, 1], X[i, :3, 2] = x, np.cross(z, x), z
    X[:, :3, 3] = origins
    return X


def test_beam_readings_on_a_known_plate():
    """Plate z = 0.1 m (normal +z, centre (0.5, 0, 0.1)), beams pointing down
    from height 0.1 + h tilted by a about x: reading h / cos a, incidence a."""
    X_BP = np.eye(4)
    X_BP[:3, 3] = [0.5, 0.0, 0.1]
    spec = RangeFinderSpec()  # 5..80 mm, 35 deg, 0.3 m x 0.3 m
    h = np.array([0.03, 0.03, 0.03, 0.003, 0.09, 0.03, 0.03, 0.03])
    a = np.deg2rad([0.0, 20.0, 34.0, 0.0, 0.0, 36.0, 0.0, 0.0])
    x = np.array([0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.64, 0.66])  # hit x on the plate
    directions = np.stack([np.zeros_like(a), np.sin(a), -np.cos(a)], axis=1)
    origins = np.stack([x, -h * np.tan(a), 0.1 + h], axis=1)
    t, incidence, valid = beam_readings(_beams(origins, directions), X_BP, spec)
    np.testing.assert_allclose(t, h / np.cos(a), rtol=1e-12)
    np.testing.assert_allclose(incidence, a, atol=1e-7)
    # in span and cone; too near; too far; beyond the cone; on, off the edge
    expected = [True, True, True, False, False, False, True, False]
    np.testing.assert_array_equal(valid, expected)
    # Plane behind the sensor, and beam parallel to it: NaN, invalid.
    up = _beams(origins[:2], np.array([[0.0, 0, 1], [1.0, 0, 0]]))
    t, _, valid = beam_readings(up, X_BP, spec)
    assert np.all(np.isnan(t)) and not valid.any()


def test_beam_readings_batched_equal_one_by_one():
    rng = np.random.default_rng(8)
    X_BP = np.eye(4)
    X_BP[:3, 3] = [0.4, 0.1, 0.2]
    directions = rng.normal([0, 0, -1], 0.3, (50, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = X_BP[:3, 3] + rng.uniform(-0.2, 0.2, (50, 3)) * [1, 1, 0.3] + [0, 0, 0.05]
    X_BE = _beams(origins, directions)
    spec = RangeFinderSpec(span=(0.0, 0.2), plate_size=(0.2, 0.4))
    batch = beam_readings(X_BE, X_BP, spec)
    assert 0 < batch.valid.sum() < 50  # some of each
    for i in range(50):
        one = beam_readings(X_BE[i : i + 1], X_BP, spec)
        np.testing.assert_allclose(one.distance, batch.distance[i], rtol=1e-14)
        assert one.valid[0] == batch.valid[i]


def test_range_finder_spec_checks_and_vector_layout():
    spec = RangeFinderSpec(span=(0.01, 0.1), max_incidence=0.5, plate_size=(0.2, 0.1))
    np.testing.assert_array_equal(spec.as_vector(), [0.01, 0.1, 0.5, 0.2, 0.1])
    assert RangeFinderSpec.from_vector(spec.as_vector()) == spec
    assert RangeFinderSpec().span == (0.005, 0.080)
    assert RangeFinderSpec().max_incidence == pytest.approx(np.deg2rad(35.0))
    with pytest.raises(ValueError, match="span"):
        RangeFinderSpec(span=(0.08, 0.005))
    with pytest.raises(ValueError, match="max_incidence"):
        RangeFinderSpec(max_incidence=2.0)
    with pytest.raises(ValueError, match="plate_size"):
        RangeFinderSpec(plate_size=(0.3, 0.0))
    with pytest.raises(ValueError, match="span"):
        RangeFinderSpec(span=(0.0, np.nan))


def test_simulator_keeps_to_the_spec(case):
    """A smaller plate, a narrower cone and a shorter span: every simulated
    reading satisfies them, and the plates carry the spec's size."""
    true = case[1]
    spec = RangeFinderSpec(span=(0.01, 0.05), max_incidence=0.4, plate_size=(0.2, 0.1))
    sim = simulate_plates(
        true, plates=4, per_plate=6, noise=0.0, seed=2, spec=spec, selection="first"
    )
    data = sim.data
    assert np.all((sim.true_distance >= 0.01) & (sim.true_distance <= 0.05))
    assert np.all(sim.incidence <= 0.4)
    for i, plate in enumerate(sim.plates):
        assert plate.size == (0.2, 0.1)
        local = (sim.p_BM[data.plane == i] - plate.X_BP[:3, 3]) @ plate.X_BP[:3, :2]
        assert np.all(np.abs(local) <= np.array([0.1, 0.05]) + 1e-12)


def test_prismatic_arm_plane_calibration_recovers_identifiable_truth(boom):
    """A robot with prismatic joints (the boom arm, joints 1 and 4): the plate
    readings are simulated through Drake-checked kinematics with the joint
    types, and LM on the `full` preset recovers the identifiable set to 1e-9.
    The offsets of a prismatic joint are its r0 (dr), so dr1 and dr4 must be
    handled like any length, and the kept set must be structurally the same
    for two plate sets."""
    sim0 = simulate_plates(boom, plates=5, per_plate=14, noise=0.0, seed=3)
    report = analyse_identifiability(
        boom, sim0.data, error_parameter_names(boom, "full")
    )
    again = analyse_identifiability(
        boom,
        simulate_plates(boom, plates=5, per_plate=14, noise=0.0, seed=4).data,
        error_parameter_names(boom, "full"),
    )
    assert report.identifiable == again.identifiable
    names = report.identifiable
    rng = np.random.default_rng(6)
    deltas = 3e-4 * rng.standard_normal(len(names))
    true = apply_deltas(boom, names, deltas)
    data = simulate_plates(true, plates=5, per_plate=14, noise=0.0, seed=11).data
    lm = PlaneLM(boom, params="full").fit(data)
    assert lm.names_ == names
    assert np.abs(lm.deltas_ - deltas).max() <= 1e-9
    # The simulated measurement points are the plant's: tool point + reading
    # along the tool z axis, prismatic joints sliding in Drake.
    plant, _ = MakePlant(boom, visual=False)
    ctx = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    for i in range(0, sim0.data.n_readings, 9):
        plant.SetPositions(ctx, sim0.data.q[i])
        X = plant.CalcRelativeTransform(ctx, plant.world_frame(), tool)
        p = X.translation() + sim0.true_distance[i] * X.rotation().col(2)
        assert np.abs(p - sim0.p_BM[i]).max() < 1e-12


def test_a_loss_scale_beyond_any_residual_is_refused():
    """--f-scale 1e300 overflowed scipy's loss into an internal error."""
    from rmdrake.calibration.plates.estimators import check_loss

    check_loss("cauchy", 1e-5)
    for bad in (1e300, 0.0, -1e-5):
        with pytest.raises(ValueError, match=r"f_scale: expected a residual scale"):
            check_loss("cauchy", bad)
