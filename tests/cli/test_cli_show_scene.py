"""``show --scene``: the cell is drawn in the saved Meshcat page."""

from __future__ import annotations

import numpy as np

from rmdrake.cli.commands import main
from rmdrake.model.loading import load_robot
from rmdrake.model.scene import load_cell
from rmdrake.systems.visualization import MakeMeshcat, save_robot_poses_html


def test_show_with_scene_writes_html(tmp_path, capsys):
    out = tmp_path / "cell.html"
    argv = ["show", "--robot", "rv3sb", "--scene", "rv3sb_table", "--html", str(out)]
    assert main(argv) == 0
    assert "cell 'rv3sb_table': 5 shapes" in capsys.readouterr().out
    assert out.stat().st_size > 10_000


def test_cell_shapes_are_in_the_meshcat_scene(tmp_path):
    meshcat = MakeMeshcat()
    cell = load_cell("rv3sb_table")
    model = load_robot("rv3sb")
    save_robot_poses_html(
        model, [np.zeros(6)], tmp_path / "s.html", meshcat=meshcat, cell=cell
    )
    for shape in cell.shapes():
        assert meshcat.HasPath(f"/drake/visualizer/cell/{shape.name}")
