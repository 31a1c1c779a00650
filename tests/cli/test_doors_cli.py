"""The doors of the ``rmdrake`` command: what comes in wrong (a robot in mm,
targets in mm, too few poses, a single payload, a motion into the cell) is
refused or flagged with one line naming the unit, option or bound, and
nothing is written."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from rmdrake.cli.commands import main
from rmdrake.model.loading import load_robot
from rmdrake.model.urdf.importer import robot_to_urdf


def _refused(argv: list[str], capsys, code: int = 2) -> str:
    """The one stderr line of a command that must exit with ``code``."""
    assert main(argv) == code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.fixture
def mm_urdf(tmp_path) -> Path:
    """rv3sb's URDF with every length in mm."""

    def scale(m: re.Match) -> str:
        xyz = " ".join(repr(float(v) * 1000) for v in m.group(2).split())
        return f"{m.group(1)}{xyz}{m.group(3)}"

    path = tmp_path / "mm.urdf"
    text = robot_to_urdf(load_robot("rv3sb"))
    path.write_text(re.sub(r'(<origin xyz=")([^"]*)(")', scale, text))
    return path


@pytest.mark.parametrize(
    "argv",
    [
        ["import-urdf", "{urdf}", "--out", "{out}/robot.yaml"],
        ["show", "--robot", "{urdf}", "--html", "{out}/robot.html"],
        ["export-urdf", "--robot", "{urdf}", "--out", "{out}/again.urdf"],
        ["perturb", "--robot", "{urdf}", "--out", "{out}/true.yaml"],
        ["simulate-plates", "--robot", "{urdf}", "--out", "{out}/plates.csv"],
        [
            "correct",
            "--robot",
            "{urdf}",
            "--targets",
            "0.3,0,0.5",
            "--out",
            "{out}/q.csv",
        ],
    ],
)
def test_a_urdf_in_mm_is_refused_at_every_door(mm_urdf, tmp_path, capsys, argv):
    out = tmp_path / "out"
    out.mkdir()
    argv = [a.format(urdf=mm_urdf, out=out) for a in argv]
    line = _refused(argv, capsys)
    assert line.startswith(f"rmdrake: error: {mm_urdf}: mdh row")
    assert "looks like mm? convert the lengths to m" in line
    assert not list(out.iterdir())


def test_a_robot_yaml_in_mm_is_refused(tmp_path, capsys):
    data = load_robot("rv3sb").to_dict()
    for row in [*data["mdh"], data["tool"]]:
        row["d"], row["r"] = row["d"] * 1000, row["r"] * 1000
    robot = tmp_path / "mm.yaml"
    robot.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    out.mkdir()
    line = _refused(
        ["perturb", "--robot", str(robot), "--out", f"{out}/t.yaml"], capsys
    )
    assert line.startswith(f"rmdrake: error: {robot}: mdh row 3: d = 245 is beyond")
    assert "looks like mm? convert the lengths to m" in line
    assert not list(out.iterdir())


def test_gravity_beyond_physics_is_refused_before_a_simulation(tmp_path, capsys):
    text = load_robot("rv3sb").to_yaml()
    robot = tmp_path / "g.yaml"
    robot.write_text(re.sub(r"gravity:.*", "gravity: [0.0, 0.0, -1000000.0]", text))
    out = tmp_path / "out"
    out.mkdir()
    line = _refused(
        ["perturb", "--robot", str(robot), "--out", f"{out}/t.yaml"], capsys
    )
    assert "gravity: |g| = 1e+06 m/s^2 is beyond 30 m/s^2" in line
    assert not list(out.iterdir())


def test_an_empty_urdf_is_refused_with_one_line(tmp_path, capsys):
    urdf = tmp_path / "empty.urdf"
    urdf.write_text('<robot name="empty"></robot>')
    line = _refused(["show", "--robot", str(urdf)], capsys)
    assert "robot has no actuated joints between base and tip" in line


def test_a_negative_velocity_limit_is_refused_not_aborted(tmp_path, capsys):
    text = robot_to_urdf(load_robot("rv3sb"))
    urdf = tmp_path / "v.urdf"
    urdf.write_text(re.sub(r'velocity="[^"]*"', 'velocity="-1"', text, count=1))
    line = _refused(["import-urdf", str(urdf), "--out", f"{tmp_path}/r.yaml"], capsys)
    assert """joint 'joint1': <limit velocity="-1"> is negative""" in line
    assert not (tmp_path / "r.yaml").exists()


@pytest.mark.parametrize("allow", [[], ["--allow-unreachable"]])
def test_targets_in_mm_are_refused_before_any_ik(tmp_path, capsys, allow):
    """A target 583 m away is in mm, not merely out of reach: refused naming the
    row and the unit, with --allow-unreachable too; nothing written."""
    targets = tmp_path / "t.csv"
    targets.write_text("x,y,z\n0.3,0,0.5\n300,0,500\n")
    out = tmp_path / "q.csv"
    line = _refused(
        [
            "correct",
            "--robot",
            "rv3sb",
            "--targets",
            str(targets),
            "--out",
            str(out),
            *allow,
        ],
        capsys,
    )
    assert "target row 2 is 583.1 m from the base, beyond 10 x the reach 1.18 m" in line
    assert line.endswith("not mm?")
    assert not out.exists()


def test_a_target_just_out_of_reach_is_reported_by_its_residual(tmp_path, capsys):
    targets = tmp_path / "t.csv"
    targets.write_text("x,y,z\n0.3,0,0.5\n2.0,0,0.5\n")
    out = tmp_path / "q.csv"
    argv = ["correct", "--robot", "rv3sb", "--targets", str(targets), "--out"]
    assert main([*argv, str(out)]) == 2
    printed = capsys.readouterr()
    assert "1 target(s) out of reach, first row 2 (position residual" in printed.err
    assert not out.exists()


def test_a_motion_into_the_cell_is_a_warning(tmp_path, capsys):
    """A log whose arm dips into rv3sb_table: the figure is labelled as a
    penetration and one warning names the link and the time it enters; the
    torques are right, so the exit code stays 0 (a warning, documented)."""
    from rmdrake.dynamics import standard_parameters
    from rmdrake.dynamics.joint_log import JointLog, write_joint_log
    from rmdrake.dynamics.regressor import torques

    model = load_robot("rv3sb")
    t = np.linspace(0.0, 4.0, 201)
    s = 0.5 - 0.5 * np.cos(np.pi * t / 4.0)  # 0 -> 1, at rest at both ends
    q = np.zeros((t.size, 6))
    q[:, 1], q[:, 2] = 2.3 * s, 0.3 * s  # shoulder down to the table
    qd, qdd = (
        np.gradient(q, t, axis=0),
        np.gradient(np.gradient(q, t, axis=0), t, axis=0),
    )
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    log = write_joint_log(tmp_path / "log.csv", JointLog(t=t, q=q, tau=tau))
    argv = [
        "validate",
        "--robot",
        "rv3sb",
        "--log",
        str(log),
        "--scene",
        "rv3sb_table",
        "--cutoff",
        "0",
        "--force",
    ]
    assert main(argv) == 0
    out = capsys.readouterr().out
    figure = re.search(
        r"cell 'rv3sb_table': the logged motion enters it: "
        r"penetration ([\d.]+) mm at t = ([\d.]+) s",
        out,
    )
    assert figure and float(figure.group(1)) > 10
    warning = re.search(
        r"warning: link '(link\d)' enters the cell 'rv3sb_table' at t = ([\d.]+) s "
        r"\(penetration up to ([\d.]+) mm",
        out,
    )
    assert warning, out
    assert float(warning.group(2)) < float(figure.group(2))  # enters, then deeper
    assert warning.group(3) == figure.group(1)
    assert "comes within -" not in out


@pytest.mark.parametrize("poses", ["1", "2"])
def test_an_alignment_from_fewer_than_three_poses_is_refused(capsys, poses):
    argv = ["compare", "--robot", "rv3sb", "--robot", "rv3sb", "--aligned"]
    line = _refused([*argv, "--poses", poses], capsys)
    assert f"--poses {poses}: an aligned comparison needs at least 3 poses" in line
    assert main([*argv, "--poses", "3"]) == 0  # the minimum is enough
    assert main(argv[:-1] + ["--poses", poses]) == 0  # unaligned: any count


def test_collinear_tool_points_are_refused_by_the_library():
    import dataclasses

    from rmdrake.kinematics.compare import tool_error_stats

    robot = load_robot("rv3sb")
    limits = robot.limits
    # Every joint fixed at 0: the tool points are one point (rotation undefined).
    fixed = dataclasses.replace(limits, lower=limits.lower * 0, upper=limits.upper * 0)
    still = dataclasses.replace(robot, limits=fixed)
    with pytest.raises(ValueError, match="lie on one line"):
        tool_error_stats(still, still, n_poses=5, aligned=True)
    with pytest.raises(ValueError, match="n_poses 2: an aligned comparison needs"):
        tool_error_stats(robot, robot, n_poses=2, aligned=True)


@pytest.mark.parametrize("payload", [None, "0", "2"])
def test_compliance_from_one_payload_is_refused_before_the_fit(
    tmp_path, capsys, payload
):
    """Plates read at one payload (no column: 0 kg) cannot show the wrist's
    stiffness: refused up front naming --compliance and the payload."""
    plates = tmp_path / "plates.csv"
    argv = ["simulate-plates", "--robot", "demo_rh", "--out", str(plates)]
    assert main(argv + (["--payload", payload] if payload else [])) == 0
    capsys.readouterr()
    out = tmp_path / "cal.yaml"
    argv = [
        "calibrate",
        "--robot",
        "demo_rh",
        "--measurements",
        str(plates),
        "--out",
        str(out),
        "--method",
        "lm",
        "--compliance",
    ]
    line = _refused(argv, capsys)
    at = f"{float(payload or 0):g} kg"
    assert (
        f"--compliance needs readings at two or more payloads; these were all at {at}"
        in line
    )
    assert not out.exists()
