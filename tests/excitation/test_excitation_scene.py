"""``excite --scene``: the designed trajectory keeps clear of the cell."""

from __future__ import annotations

import numpy as np
from conftest import cell_distances

from rmdrake.cli.commands import main
from rmdrake.excitation.trajectory import load_fourier
from rmdrake.kinematics.clearance import default_collision_radius
from rmdrake.model.loading import load_robot
from rmdrake.model.scene import load_cell


def test_excite_with_scene_keeps_the_clearance_at_the_log_rate(tmp_path, capsys):
    out = tmp_path / "traj.yaml"
    argv = ["excite", "--robot", "rv3sb", "--out", str(out), "--maxiter", "6"]
    argv += ["--scene", "rv3sb_table", "--clearance", "0.05"]
    assert main(argv) == 0
    assert "clearance to the cell >=" in capsys.readouterr().out
    model = load_robot("rv3sb")
    _, q, _, _ = load_fourier(out).sample(150.0)
    assert q.shape == (1500, 6)
    d = cell_distances(
        model, load_cell("rv3sb_table"), default_collision_radius(model), q
    )
    assert d.min() >= 0.05
    # and the motion is a real excitation, not a standstill
    assert np.ptp(q, axis=0).min() > 0.05
