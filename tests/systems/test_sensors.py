"""RangeFinder LeafSystem: its readings equal the simulator's (numpy MDH
kinematics and ray-plate intersection) for the same poses and plates, and its
sensor numbers and plate pose live in the Context."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder

from rmdrake.calibration import RangeFinderSpec, random_poses, simulate_plates
from rmdrake.kinematics.forward import tool_points, tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.plant import MakePlant
from rmdrake.systems.sensors import RangeFinder, ToolTracker


@pytest.fixture(scope="module")
def station():
    from rmdrake.model.loading import load_robot

    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    true = apply_deltas(
        nominal, names, 5e-4 * np.random.default_rng(4).standard_normal(17)
    )
    sim = simulate_plates(
        true, plates=4, per_plate=6, noise=0.0, seed=5, selection="first"
    )
    builder = DiagramBuilder()
    plant, _ = MakePlant(true, builder=builder, visual=False)
    finder = RangeFinder.AddToBuilder(builder, plant)
    diagram = builder.Build()
    return true, sim, plant, finder, diagram


def test_readings_equal_simulator(station):
    true, sim, plant, finder, diagram = station
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    finder_context = finder.GetMyMutableContextFromRoot(context)
    distance = finder.GetOutputPort("distance")
    valid = finder.GetOutputPort("valid")
    for i in range(sim.data.n_readings):
        X_BP = RigidTransform(sim.plates[sim.data.plane[i]].X_BP)
        finder.SetPlatePose(finder_context, X_BP)
        plant.SetPositions(plant_context, sim.data.q[i])
        assert valid.Eval(finder_context)[0] == 1.0
        assert abs(distance.Eval(finder_context)[0] - sim.true_distance[i]) < 1e-12


def test_plate_pose_is_a_context_parameter(station):
    _, sim, plant, finder, diagram = station
    a, b = diagram.CreateDefaultContext(), diagram.CreateDefaultContext()
    for ctx, shift in ((a, 0.0), (b, 0.01)):
        X = sim.plates[0].X_BP.copy()
        X[:3, 3] -= shift * X[:3, 2]  # move the plate 10 mm away along -normal
        finder.SetPlatePose(finder.GetMyMutableContextFromRoot(ctx), RigidTransform(X))
        plant.SetPositions(plant.GetMyMutableContextFromRoot(ctx), sim.data.q[0])
    da = finder.GetOutputPort("distance").Eval(finder.GetMyContextFromRoot(a))[0]
    db = finder.GetOutputPort("distance").Eval(finder.GetMyContextFromRoot(b))[0]
    cos = sim.incidence[0]
    assert abs((db - da) - 0.01 / np.cos(cos)) < 1e-12


def test_invalid_reading_is_nan(station):
    _, sim, plant, finder, diagram = station
    context = diagram.CreateDefaultContext()
    finder_context = finder.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), sim.data.q[0])
    X = sim.plates[0].X_BP.copy()
    X[:3, 3] -= 0.5 * X[:3, 2]  # 0.5 m further: beyond the 80 mm span
    finder.SetPlatePose(finder_context, RigidTransform(X))
    assert np.isnan(finder.GetOutputPort("distance").Eval(finder_context)[0])
    assert finder.GetOutputPort("valid").Eval(finder_context)[0] == 0.0


def test_calibration_scene_has_plates_and_points(station, tmp_path):
    from rmdrake.systems.visualization import MakeMeshcat, save_calibration_html

    true, sim, *_ = station
    meshcat = MakeMeshcat()
    path = save_calibration_html(
        true,
        sim.data.q[:3],
        [(p.X_BP, p.size) for p in sim.plates],
        {"points": (sim.p_BM, (0.1, 0.3, 0.9, 1.0))},
        tmp_path / "scene.html",
        meshcat=meshcat,
    )
    for i in range(len(sim.plates)):
        assert meshcat.HasPath(f"/calibration/plates/{i}")
    assert meshcat.HasPath(f"/calibration/points/{sim.data.n_readings - 1}")
    assert "<html" in path.read_text()[:2000].lower()


def _at_first_reading(station):
    """Context of the station at the first simulated reading (valid)."""
    _, sim, plant, finder, diagram = station
    context = diagram.CreateDefaultContext()
    finder_context = finder.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), sim.data.q[0])
    finder.SetPlatePose(finder_context, RigidTransform(sim.plates[0].X_BP))
    return finder_context


def test_span_is_a_context_parameter(station):
    _, sim, _, finder, _ = station
    finder_context = _at_first_reading(station)
    valid = finder.GetOutputPort("valid")
    assert valid.Eval(finder_context)[0] == 1.0
    assert finder.GetSpec(finder_context) == RangeFinderSpec()
    numbers = finder_context.get_mutable_numeric_parameter(0)
    numbers.SetAtIndex(1, 0.5 * sim.true_distance[0])  # span max below the reading
    assert valid.Eval(finder_context)[0] == 0.0
    assert finder.GetSpec(finder_context).span[1] == 0.5 * sim.true_distance[0]


def test_plate_size_and_incidence_are_context_parameters(station):
    _, sim, _, finder, _ = station
    finder_context = _at_first_reading(station)
    valid = finder.GetOutputPort("valid")
    X = sim.plates[0].X_BP.copy()
    X[:3, 3] += 0.2 * X[:3, 0]  # centre 0.2 m along x_P: the hit is off a 0.3 m plate
    finder.SetPlatePose(finder_context, RigidTransform(X))
    assert valid.Eval(finder_context)[0] == 0.0
    wide = RangeFinderSpec(plate_size=(1.0, 1.0))
    finder.SetSpec(finder_context, wide)
    assert valid.Eval(finder_context)[0] == 1.0
    for factor, expected in ((1.01, 1.0), (0.99, 0.0)):  # cone just wider, narrower
        cone = dataclasses.replace(wide, max_incidence=factor * sim.incidence[0])
        finder.SetSpec(finder_context, cone)
        assert valid.Eval(finder_context)[0] == expected


def test_add_to_builder_names_wires_and_sets_defaults(station):
    true, sim, *_ = station
    builder = DiagramBuilder()
    plant, _ = MakePlant(true, builder=builder, visual=False)
    spec = RangeFinderSpec(span=(0.001, 0.2), max_incidence=0.7, plate_size=(2, 1))
    X_WP = RigidTransform(sim.plates[1].X_BP)
    finder = RangeFinder.AddToBuilder(builder, plant, spec=spec, X_WP=X_WP, name="rf")
    diagram = builder.Build()
    assert finder.get_name() == "rf"
    assert diagram.GetSubsystemByName("rf") is finder
    context = diagram.CreateDefaultContext()
    finder_context = finder.GetMyContextFromRoot(context)
    assert finder.GetSpec(finder_context) == spec
    np.testing.assert_array_equal(
        finder.GetPlatePose(finder_context).GetAsMatrix4(), sim.plates[1].X_BP
    )
    i = int(np.flatnonzero(sim.data.plane == 1)[0])
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), sim.data.q[i])
    distance = finder.GetOutputPort("distance").Eval(finder_context)[0]
    assert abs(distance - sim.true_distance[i]) < 1e-12  # wired to the plant


def test_constructor_is_keyword_only(station):
    _, _, plant, *_ = station
    with pytest.raises(TypeError):
        RangeFinder(plant)


# ---- ToolTracker ------------------------------------------------------------------
@pytest.fixture(scope="module")
def tracked():
    """The shipped RV-3SB's plant with a ToolTracker (marker offset p_EM) and a
    noisy one (std 1 mm), and 20 random joint configurations within limits."""
    from rmdrake.model.loading import load_robot

    model = load_robot("rv3sb")
    builder = DiagramBuilder()
    plant, _ = MakePlant(model, builder=builder, visual=False)
    exact = ToolTracker.AddToBuilder(builder, plant)
    noisy = ToolTracker.AddToBuilder(
        builder, plant, p_EM=(0.01, -0.02, 0.03), noise=1e-3, name="noisy"
    )
    diagram = builder.Build()
    q = random_poses(model, 20, seed=3)
    return model, plant, exact, noisy, diagram, q


def test_tool_tracker_equals_numpy_kinematics(tracked):
    model, plant, exact, noisy, diagram, q = tracked
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    exact_context = exact.GetMyMutableContextFromRoot(context)
    p_EM = np.array([0.05, -0.03, 0.12])
    X_BE = tool_poses(model.table, q)
    worst = 0.0
    for i in range(q.shape[0]):
        plant.SetPositions(plant_context, q[i])
        exact.SetMarkerOffset(exact_context, np.zeros(3))
        p_WM = exact.GetOutputPort("p_WM").Eval(exact_context)
        worst = max(worst, np.abs(p_WM - tool_points(model.table, q[i])[0]).max())
        exact.SetMarkerOffset(exact_context, p_EM)
        p_WM = exact.GetOutputPort("p_WM").Eval(exact_context)
        want = X_BE[i, :3, :3] @ p_EM + X_BE[i, :3, 3]
        worst = max(worst, np.abs(p_WM - want).max())
    assert worst < 1e-12  # m (measured about 2e-16)
    np.testing.assert_array_equal(exact.GetMarkerOffset(exact_context), p_EM)


def test_tool_tracker_noise_is_seeded_and_scaled_by_a_parameter(tracked):
    model, plant, _, noisy, diagram, q = tracked
    port = noisy.GetOutputPort("p_WM")

    def read(seed: int, std: float | None = None) -> np.ndarray:
        context = diagram.CreateDefaultContext()
        diagram.SetRandomContext(context, RandomGenerator(seed))
        plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q[0])
        tracker_context = noisy.GetMyMutableContextFromRoot(context)
        if std is not None:
            noisy.SetNoiseStd(tracker_context, std)
        assert noisy.GetNoiseStd(tracker_context) == (1e-3 if std is None else std)
        return port.Eval(tracker_context)

    X_point = tool_poses(model.table, q[0])[0]
    exact = X_point[:3, :3] @ [0.01, -0.02, 0.03] + X_point[:3, 3]
    a, b, c = read(1), read(1), read(2)
    np.testing.assert_array_equal(a, b)  # the same seed, the same noise
    assert not np.array_equal(a, c)
    assert 1e-6 < np.abs(a - exact).max() < 5e-3  # std 1 mm
    np.testing.assert_allclose(read(1, std=0.0), exact, rtol=0, atol=1e-12)
    np.testing.assert_allclose(read(1, std=2e-3) - exact, 2 * (a - exact), atol=1e-12)
    assert diagram.GetSubsystemByName("noisy_noise") is not None
    with pytest.raises(ValueError, match="noise: expected a std >= 0 m"):
        ToolTracker(plant=plant, noise=-1.0)
    with pytest.raises(ValueError, match="p_EM"):
        ToolTracker(plant=plant, p_EM=(0.0, 1.0))
    with pytest.raises(TypeError):
        ToolTracker(plant)


# ---- the boom arm (prismatic joints 1 and 4) --------------------------------------
@pytest.fixture(scope="module")
def boom_station():
    """A "true" boom arm (1 mm / 1 mrad errors on every MDH entry) whose plant
    (PrismaticJoint for joints 1 and 4) carries a RangeFinder and a ToolTracker,
    and its simulated plate readings (numpy kinematics with sigma)."""
    from conftest import boom_arm

    nominal = boom_arm()
    names = error_parameter_names(nominal, "full")
    deltas = 1e-3 * np.random.default_rng(4).standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    sim = simulate_plates(
        true, plates=3, per_plate=5, noise=0.0, seed=5, selection="first"
    )
    builder = DiagramBuilder()
    plant, _ = MakePlant(true, builder=builder, visual=False)
    finder = RangeFinder.AddToBuilder(builder, plant)
    tracker = ToolTracker.AddToBuilder(builder, plant)
    return true, sim, plant, finder, tracker, builder.Build()


def test_boom_range_finder_equals_simulator(boom_station):
    """Readings of the Drake plant with prismatic joints == the simulator's
    (numpy chain, q_j added to r_j for the slides) to 1e-12 m, at readings
    that move the slides (joints 1 and 4) across their ranges."""
    true, sim, plant, finder, _, diagram = boom_station
    assert np.ptp(sim.data.q[:, [0, 3]], axis=0).min() > 0.05  # m: slides move
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    finder_context = finder.GetMyMutableContextFromRoot(context)
    for i in range(sim.data.n_readings):
        finder.SetPlatePose(
            finder_context, RigidTransform(sim.plates[sim.data.plane[i]].X_BP)
        )
        plant.SetPositions(plant_context, sim.data.q[i])
        assert finder.GetOutputPort("valid").Eval(finder_context)[0] == 1.0
        d = finder.GetOutputPort("distance").Eval(finder_context)[0]
        assert abs(d - sim.true_distance[i]) < 1e-12


def test_boom_tool_tracker_equals_kinematics(boom_station):
    """p_WM of the tracker on the boom arm's plant == tool_points(..., sigma)
    and X_BE p_EM of tool_poses(..., sigma), to 1e-12 m; the same values
    without sigma (all revolute) are off by decimetres, so sigma matters."""
    true, _, plant, _, tracker, diagram = boom_station
    rng = np.random.default_rng(8)
    q = rng.uniform(true.limits.lower, true.limits.upper, (10, 6))
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    tracker_context = tracker.GetMyMutableContextFromRoot(context)
    p_EM = np.array([0.05, -0.03, 0.12])
    tracker.SetMarkerOffset(tracker_context, p_EM)
    X_BE = tool_poses(true.table, q, sigma=true.sigma)
    p_want = np.einsum("nij,j->ni", X_BE[:, :3, :3], p_EM) + X_BE[:, :3, 3]
    p_got = np.empty_like(p_want)
    for i in range(q.shape[0]):
        plant.SetPositions(plant_context, q[i])
        p_got[i] = tracker.GetOutputPort("p_WM").Eval(tracker_context)
    np.testing.assert_allclose(p_got, p_want, rtol=0, atol=1e-12)
    tracker.SetMarkerOffset(tracker_context, np.zeros(3))
    plant.SetPositions(plant_context, q[0])
    p_tool = tool_points(true.table, q[:1], sigma=true.sigma)[0]
    got = tracker.GetOutputPort("p_WM").Eval(tracker_context)
    np.testing.assert_allclose(got, p_tool, rtol=0, atol=1e-12)
    revolute = tool_points(true.table, q, sigma=None)
    assert np.linalg.norm(revolute - X_BE[:, :3, 3], axis=1).max() > 0.1
