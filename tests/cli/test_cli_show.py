"""`rmdrake show`: summary and a non-empty Meshcat HTML for every shipped robot."""

from __future__ import annotations

import subprocess
import sys

from rmdrake.cli import main


def test_show_writes_html(shipped, tmp_path, capsys):
    out = tmp_path / "scene.html"
    assert main(["show", "--robot", shipped.name, "--html", str(out)]) == 0
    text = out.read_text()
    assert len(text) > 10_000 and "<html" in text.lower()
    printed = capsys.readouterr().out
    assert f"robot '{shipped.name}': 6 revolute joints" in printed
    assert "(tool)" in printed


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
