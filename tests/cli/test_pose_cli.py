"""The 6-DoF pose kind through the commands: simulate-poses, calibrate (the
file sniffed, --angle-noise), plan --frames, correct and export-urdf on the
result; --angle-noise on another kind's file and a frames plan's option on
another plan are refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from rmdrake.cli.commands import main
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pose_cli")
    assert main(["perturb", "--robot", "rv3sb", "--seed", "1",
                 "--out", str(tmp / "true.yaml")]) == 0  # fmt: skip
    argv = ["simulate-poses", "--robot", str(tmp / "true.yaml"), "--poses", "30",
            "--seed", "2", "--out", str(tmp / "poses.csv")]  # fmt: skip
    assert main(argv) == 0
    return tmp


def test_calibrate_correct_and_export_a_pose_calibration(folder, capsys):
    out = folder / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements",
            str(folder / "poses.csv"), "--noise", "2e-5", "--angle-noise", "5e-5",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "robot 'rv3sb': 30 poses (6-DoF marker readings)" in text
    assert "sanity: plausible" in text
    cal = load_robot(out)
    assert cal.calibration["kind"].startswith("pose kinematic calibration")
    assert not np.array_equal(cal.table, load_robot("rv3sb").table)
    (folder / "targets.csv").write_text("x,y,z\n0.35,0.10,0.45\n0.30,-0.10,0.50\n")
    argv = ["correct", "--robot", str(out), "--targets", str(folder / "targets.csv"),
            "--out", str(folder / "q.csv")]  # fmt: skip
    assert main(argv) == 0
    assert main(["export-urdf", "--robot", str(out), "--out",
                 str(folder / "cal.urdf")]) == 0  # fmt: skip
    assert (folder / "q.csv").stat().st_size and (folder / "cal.urdf").stat().st_size


def test_a_frames_plan(folder, capsys):
    out = folder / "plan"
    argv = ["plan", "--robot", "rv3sb", "--robots", "3", "--frames", "30",
            "--noise", "2e-5", "--length-std", "5e-4", "--angle-std", "5e-4",
            "--target", "1e-4", "--workers", "0", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert "30 frames (6-DoF poses)" in capsys.readouterr().out
    (variant,) = yaml.safe_load((out / "summary.yaml").read_text())["variants"]
    assert variant["frames"] == 30 and variant["angle_noise"] is None
    assert variant["ok"] == 3


def test_options_of_another_kind_are_refused(folder, capsys):
    assert main(["simulate-points", "--robot", "rv3sb", "--poses", "10",
                 "--out", str(folder / "points.csv")]) == 0  # fmt: skip
    capsys.readouterr()
    argv = ["calibrate", "--robot", "rv3sb", "--measurements",
            str(folder / "points.csv"), "--angle-noise", "1e-4",
            "--out", str(folder / "x.yaml")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--angle-noise is for pose measurements" in err[0]
    argv = ["plan", "--robot", "rv3sb", "--robots", "2", "--poses", "10",
            "--angle-noise", "1e-4", "--noise", "2e-5", "--target", "1e-3",
            "--out", str(folder / "p2")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--angle-noise: a 6-DoF plan's option" in err[0]
    assert not (folder / "x.yaml").exists() and not (folder / "p2").exists()
