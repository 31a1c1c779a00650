"""The elastic shipped arm from the command line: `simulate` feeds back the
motor side with a rigid-joint controller, which must stay below the arm's
lowest structural mode (refused above it, with the option that fixes it)."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.joint_log import read_joint_log
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def trajectory(tmp_path_factory):
    d = tmp_path_factory.mktemp("elastic")
    random_fourier_trajectory(load_robot("demo_rh"), fill=0.3, seed=2).save(
        d / "t.yaml"
    )
    return d / "t.yaml"


def test_simulate_refuses_a_bandwidth_above_the_mode(trajectory, capsys):
    out = trajectory.parent / "refused.csv"
    argv = ["simulate", "--robot", "demo_rh_elastic", "--trajectory", str(trajectory)]
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lowest structural mode" in err[0]
    assert "--bandwidth" in err[0] and not out.exists()


def test_simulate_elastic_arm_below_the_mode(trajectory, capsys):
    out = trajectory.parent / "log.csv"
    argv = ["simulate", "--robot", "demo_rh_elastic", "--trajectory", str(trajectory)]
    assert main([*argv, "--out", str(out), "--bandwidth", "3", "--rate", "50"]) == 0
    assert "rigid joints" in capsys.readouterr().out
    log = read_joint_log(out, n_joints=6)
    assert np.all(np.isfinite(log.tau)) and log.q.shape == (500, 6)
