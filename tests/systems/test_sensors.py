"""RangeFinder LeafSystem: its readings equal the simulator's (numpy MDH
kinematics and ray-plate intersection) for the same poses and plates, and its
sensor numbers and plate pose live in the Context."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder

from rmdrake.calibration import RangeFinderSpec, simulate_plates
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
