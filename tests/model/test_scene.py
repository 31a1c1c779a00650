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


# ---- meshes and model files: one box, four ways --------------------------------
BOX = (0.3, 0.2, 0.4)  # m
X_BOX = {"xyz": [0.45, 0.15, 0.3], "rpy": [0.1, -0.2, 0.5]}
CUBE_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    + ["f 1 2 4 3", "f 5 7 8 6", "f 1 5 6 2", "f 3 4 8 7", "f 1 3 7 5", "f 2 6 8 4"]
)
SDF = """<?xml version="1.0"?>
<sdf version="1.7"><model name="jig"><static>{static}</static>
  <link name="block"><pose>{xyz} {rpy}</pose>
    <collision name="body"><geometry><box><size>{size}</size></box></geometry>
    </collision></link></model></sdf>
"""


def _four_cells(tmp_path):
    """The same box as a box, a scaled unit-cube mesh (only one scale can be
    given: the mesh is the box's x edge cubed, so the box is a cube here), an
    SDFormat model and Drake model directives naming that SDFormat file."""
    side = BOX[0]
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    xyz, rpy = (" ".join(map(str, X_BOX[k])) for k in ("xyz", "rpy"))
    (tmp_path / "jig.sdf").write_text(
        SDF.format(static="true", xyz=xyz, rpy=rpy, size=f"{side} {side} {side}")
    )
    (tmp_path / "cell.dmd.yaml").write_text(
        f"directives:\n- add_model: {{name: jig, file: 'file://{tmp_path}/jig.sdf'}}\n"
    )
    pose = f"X_BG: {{xyz: {X_BOX['xyz']}, rpy: {X_BOX['rpy']}}}"
    texts = {
        "box": f"boxes: [{{name: b, size: [{side}, {side}, {side}], {pose}}}]",
        "mesh": f"meshes: [{{name: b, file: cube.obj, scale: {side}, {pose}}}]",
        "sdf": "models: [jig.sdf]",
        "directives": "models: [cell.dmd.yaml]",
    }
    cells = {}
    for kind, text in texts.items():
        (tmp_path / f"{kind}.yaml").write_text(f"name: {kind}\n{text}\n")
        cells[kind] = load_cell(tmp_path / f"{kind}.yaml")
    return cells


def test_mesh_sdformat_and_directives_cells_measure_the_same_box(tmp_path):
    """Oracle: Drake's signed distance to the same cube given as a Box; the
    mesh (its convex hull), the SDFormat model and the directives must agree
    within 20 um over configurations near and far from it. Not closer: Drake
    finds a capsule-box distance iteratively (GJK), and the SDFormat box, posed
    equal to the YAML box to 1e-16, measured 5.2 um apart at 8 mm."""
    model = load_robot("rv3sb")
    cells = _four_cells(tmp_path)
    assert [s.name for s in cells["sdf"].shapes()] == ["jig/body"]
    rng = np.random.default_rng(3)
    lo, hi = model.limits.lower, model.limits.upper
    q = lo + (hi - lo) * rng.uniform(0.1, 0.9, size=(40, model.n_joints))
    radius = default_collision_radius(model)
    reference = cell_distances(model, cells["box"], radius, q)
    assert reference.min() < 0 < reference.max()  # some touch, some clear it
    for kind in ("mesh", "sdf", "directives"):
        d_cell, _ = ClearanceChecker(model=model, cell=cells[kind]).distances(q)
        assert np.abs(d_cell - reference).max() < 2e-5, kind


def test_cell_models_that_move_or_do_not_parse_are_refused(tmp_path):
    (tmp_path / "free.sdf").write_text(
        SDF.format(static="false", xyz="0 0 1", rpy="0 0 0", size="1 1 1")
    )
    (tmp_path / "free.yaml").write_text("name: c\nmodels: [free.sdf]\n")
    with pytest.raises(ValueError, match=r"free.sdf: bodies block are not welded"):
        load_cell(tmp_path / "free.yaml")
    (tmp_path / "bad.sdf").write_text("<sdf version='1.7'><model>")
    (tmp_path / "bad.yaml").write_text("name: c\nmodels: [bad.sdf]\n")
    with pytest.raises(ValueError, match=r"cell file \S+bad.yaml: model \S+bad.sdf"):
        load_cell(tmp_path / "bad.yaml")
    (tmp_path / "nomesh.yaml").write_text(
        "name: c\nmeshes: [{name: m, file: none.obj}]\n"
    )
    with pytest.raises(ValueError, match=r"meshes\[0\] 'm': file: no such file"):
        load_cell(tmp_path / "nomesh.yaml")


def test_the_page_draws_the_mesh_and_the_models(tmp_path):
    from rmdrake.systems.visualization import MakeMeshcat, save_robot_poses_html

    cells = _four_cells(tmp_path)
    for kind, name in (("mesh", "b"), ("sdf", "jig/body")):
        meshcat = MakeMeshcat()
        save_robot_poses_html(
            load_robot("rv3sb"), [np.zeros(6)], tmp_path / "r.html",
            meshcat=meshcat, cell=cells[kind],
        )  # fmt: skip
        assert meshcat.HasPath(f"/drake/visualizer/cell/{name}"), kind
