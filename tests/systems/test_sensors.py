"""RangeFinder LeafSystem: its readings equal the simulator's (numpy MDH
kinematics and ray-plate intersection) for the same poses and plates."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder

from rmdrake.calibration import simulate_plates
from rmdrake.plant import MakePlant
from rmdrake.robot import apply_deltas, error_parameter_names
from rmdrake.systems.sensors import RangeFinder


@pytest.fixture(scope="module")
def station():
    from rmdrake.robot import load_robot

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
    finder = builder.AddSystem(RangeFinder(plant=plant))
    builder.Connect(
        plant.get_body_poses_output_port(), finder.get_body_poses_input_port()
    )
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


def test_span_is_a_context_parameter(station):
    _, sim, plant, finder, diagram = station
    context = diagram.CreateDefaultContext()
    finder_context = finder.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), sim.data.q[0])
    finder.SetPlatePose(finder_context, RigidTransform(sim.plates[0].X_BP))
    assert finder.GetOutputPort("valid").Eval(finder_context)[0] == 1.0
    numbers = finder_context.get_mutable_numeric_parameter(0)
    numbers.SetAtIndex(1, 0.5 * sim.true_distance[0])  # span max below the reading
    assert finder.GetOutputPort("valid").Eval(finder_context)[0] == 0.0
