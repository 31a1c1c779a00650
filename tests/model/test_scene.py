"""Robot cells: the YAML, the collision geometry, the batched clearance."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import cell_distances

from rmdrake.kinematics.clearance import ClearanceChecker, default_collision_radius
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant, collision_filtered_pairs
from rmdrake.model.scene import load_cell, shipped_cells


def test_shipped_cell_loads():
    assert "rv3sb_table" in shipped_cells()
    cell = load_cell("rv3sb_table")
    names = [s.name for s in cell.shapes()]
    assert names[:2] == ["table_top", "wall"] and len(names) == 5
    X = cell.boxes[2].X_BG.transform()
    assert np.allclose(X.translation(), [0.5, 0.3, 0.08])


@pytest.mark.parametrize(
    "body, message",
    [
        ("boxes: [{name: a, size: [1, -1, 1]}]", "boxes[0] 'a': size"),
        ("boxes: [{name: a, size: [1, 1]}]", "size: expected 3 lengths"),
        ("spheres: [{name: a, radius: 0.1}, {name: a, radius: 0.2}]", "twice"),
        ("spheres: [{radius: 0.1}]", "expected a name"),
        (
            "cylinders: [{name: c, radius: 0.1, length: 1, X_BG: {rpy: [0, 1]}}]",
            "X_BG.rpy",
        ),
        ("sphere: [{name: a, radius: 0.1}]", "sphere"),
        ("spheres: [{name: a, radius: .nan}]", "radius"),
    ],
)
def test_bad_cells_are_one_line_errors(tmp_path, body, message):
    path = tmp_path / "cell.yaml"
    path.write_text(f"name: bad\n{body}\n")
    with pytest.raises(ValueError) as e:
        load_cell(path)
    text = str(e.value)
    assert message in text and "\n" not in text and str(path) in text


def test_plant_collision_geometry_and_filters():
    model = load_robot("rv3sb")
    plant, _ = MakePlant(model)  # the default plant: no collision geometry
    assert not any(
        plant.GetCollisionGeometriesForBody(plant.GetBodyByName(f"link{j}"))
        for j in range(1, 7)
    )
    radius = default_collision_radius(model)
    assert radius == pytest.approx(0.04 * 1.18)
    pairs = collision_filtered_pairs(model.table, radius)
    # adjacent links, the 95 mm shoulder offset, and the wrist's zero links
    assert {(0, 1), (0, 2), (1, 2), (3, 6), (4, 6), (5, 6)} <= set(pairs)
    assert (0, 3) not in pairs and (2, 6) not in pairs and (1, 3) not in pairs
    plant, _ = MakePlant(model, collision_radius=radius, cell=load_cell("rv3sb_table"))
    assert len(plant.GetCollisionGeometriesForBody(plant.GetBodyByName("link3"))) == 2


def test_clear_equals_the_signed_distances():
    model = load_robot("rv3sb")
    cell = load_cell("rv3sb_table")
    rng = np.random.default_rng(1)
    q = rng.uniform(model.limits.lower, model.limits.upper, (150, 6))
    for self_collision in (False, True):
        checker = ClearanceChecker(
            model=model, cell=cell, self_collision=self_collision
        )
        for c in (0.0, 0.05):
            expected = checker.clearance(q) >= c
            assert np.array_equal(checker.clear(q, c), expected)
            assert 0 < expected.sum() < len(q)
    d_cell, _ = checker.distances(q)
    assert np.allclose(d_cell, cell_distances(model, cell, checker.radius, q))
