"""`rmdrake show`: summary and a non-empty Meshcat HTML for every shipped robot."""

from __future__ import annotations

import subprocess
import sys

from rmdrake.cli.commands import main


def test_show_writes_html(shipped, tmp_path, capsys):
    out = tmp_path / "scene.html"
    assert main(["show", "--robot", shipped.name, "--html", str(out)]) == 0
    text = out.read_text()
    assert len(text) > 10_000 and "<html" in text.lower()
    printed = capsys.readouterr().out
    assert f"robot '{shipped.name}': 6 revolute joints" in printed
    assert "(tool)" in printed


def test_show_prismatic_robot(boom, tmp_path, capsys):
    """A robot YAML with prismatic joints 1 and 4: the summary names the joint
    types, gives the slides' ranges and speeds in m and m/s and their efforts
    in N (the revolute joints' in deg, deg/s, N m); the scene (Meshcat with
    PrismaticJoint) is written."""
    robot, out = tmp_path / "boom.yaml", tmp_path / "scene.html"
    boom.save(robot)
    assert main(["show", "--robot", str(robot), "--html", str(out)]) == 0
    assert len(out.read_text()) > 10_000
    lines = capsys.readouterr().out.splitlines()
    head = "robot 'boom_arm': 4 revolute and 2 prismatic joints (prismatic: 1, 4)"
    assert head in lines[0]
    rows = {line.split()[0]: line.split() for line in lines if line[:4].strip()}
    assert rows["1"][1] == "P" and rows["4"][1] == "P"
    assert rows["4"][-6:] == ["0..0.6", "m", "0.4", "m/s", "800", "N"]
    assert rows["1"][-6:] == ["0..0.8", "m", "0.3", "m/s", "2000", "N"]
    assert rows["2"][1] == "R" and rows["2"][-7:] == [
        "-166.2..166.2", "deg", "114.6", "deg/s", "400", "N", "m"
    ]  # fmt: skip
    assert rows["7"][-1] == "(tool)"


def test_show_bad_robot_exits_2(tmp_path):
    """Console entry point: one-line reason on stderr, exit code 2, no file."""
    out = tmp_path / "x.html"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "rmdrake.cli",
            "show",
            "--robot",
            "nope",
            "--html",
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2
    assert result.stderr.strip().startswith("rmdrake: error: unknown robot 'nope'")
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_demo_smoke_writes_every_artefact(tmp_path, capsys):
    """`rmdrake demo --smoke`: the main job's whole path (robot, calibration
    study, identification study) with token budgets."""
    assert main(["demo", "--smoke", "--out", str(tmp_path)]) == 0
    for name in (
        "rv3sb.html",
        "kinematics/kinematic_calibration_fig3.png",
        "kinematics/kinematic_calibration.html",
        "dynamics/excitation.yaml",
        "dynamics/identified_physical.yaml",
        "dynamics/fig4_joint_trajectories.png",
        "dynamics/fig6_cartesian_path.png",
        "dynamics/fig7_torques.png",
        "dynamics/excitation.html",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    out = capsys.readouterr().out
    assert "DE + LM" in out and "noise-free data" in out
