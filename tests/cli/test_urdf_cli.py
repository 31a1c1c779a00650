"""`rmdrake import-urdf`, `export-urdf`, and a URDF given to `show`: the files
written are the robot (FK checked against the YAML), bad inputs exit 2 with
one line and write nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from rmdrake.cli.commands import main
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot

TIAGO = SHARED_DATA / "tiago_figaroh/tiago.urdf"

ARM = """<robot name="two">
<link name="base"/>
<link name="l1"><inertial><mass value="2"/><origin xyz="0.1 0 0" rpy="0 0 0"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
<link name="l2"><inertial><mass value="1"/><origin xyz="0 0.1 0" rpy="0 0 0"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="hand"/>
<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
<origin xyz="0.2 0.3 0.1" rpy="0.3 0.2 0.1"/><axis xyz="0 1 1"/>
<limit lower="-2" upper="2" velocity="1" effort="50"/></joint>
<joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
<origin xyz="0.4 0 0" rpy="0 0.5 0"/><axis xyz="1 0 0"/>
<limit lower="0" upper="0.5" velocity="0.2" effort="300"/></joint>
<joint name="h" type="fixed"><parent link="l2"/><child link="hand"/>
<origin xyz="0 0 0.1" rpy="0 0 0.7"/></joint>
</robot>
"""


@pytest.fixture
def arm(tmp_path) -> Path:
    path = tmp_path / "two.urdf"
    path.write_text(ARM)
    return path


def _fk(model, q):
    X_LB = np.eye(4)
    if model.base_frame is not None:
        from pydrake.math import RigidTransform, RollPitchYaw

        bf = model.base_frame
        X_LB = RigidTransform(RollPitchYaw(bf.rpy), bf.xyz).GetAsMatrix4()
    return X_LB @ tool_poses(model.table, q, sigma=model.sigma)


def test_import_export_show(arm, tmp_path, capsys):
    """import -> YAML (base frame recorded, warned), show of the URDF prints
    it, export -> URDF whose re-import has the same kinematics."""
    yaml_path, urdf_path = tmp_path / "two.yaml", tmp_path / "again.urdf"
    argv = ["import-urdf", str(arm), "--base", "base", "--tip", "hand"]
    assert main([*argv, "--out", str(yaml_path)]) == 0
    out, err = capsys.readouterr()
    assert "robot 'two': 2 joints (R, P;" in out and "base frame B" in out
    assert "rmdrake: warning:" in err and "targets are in B" in err
    model = load_robot(yaml_path)
    assert model.base_frame is not None and model.base_frame.link == "base"
    assert main(["show", "--robot", str(arm), "--base", "base", "--tip", "hand"]) == 0
    assert "base frame B in link 'base'" in capsys.readouterr().out
    assert (
        main(["export-urdf", "--robot", str(yaml_path), "--out", str(urdf_path)]) == 0
    )
    assert f"wrote {urdf_path}" in capsys.readouterr().out
    with pytest.warns(UserWarning, match="base frame B"):  # X_LB is in joint1
        again = load_robot(urdf_path, base="base", tip="tool")
    q = np.random.default_rng(0).uniform(0, 0.5, (5, 2))
    np.testing.assert_allclose(_fk(again, q), _fk(model, q), atol=1e-12)


@pytest.mark.skipif(not TIAGO.is_file(), reason="the TIAGo URDF is not in shared/")
def test_tiago_import_export(tmp_path, capsys):
    yaml_path, urdf_path = tmp_path / "tiago.yaml", tmp_path / "tiago.urdf"
    argv = ["import-urdf", str(TIAGO), "--base", "base_footprint"]
    argv += ["--tip", "wrist_ft_tool_link", "--out", str(yaml_path)]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert "robot 'tiago': 8 joints (P, R, R, R, R, R, R, R;" in out
    assert "head_1_joint" in err  # the lumped head is named
    model = load_robot(yaml_path)
    assert model.base_frame is None and model.n_joints == 8
    assert (
        main(["export-urdf", "--robot", str(yaml_path), "--out", str(urdf_path)]) == 0
    )
    again = load_robot(urdf_path, base="base", tip="tool")
    q = np.random.default_rng(1).uniform(0, 0.3, (5, 8))
    np.testing.assert_allclose(_fk(again, q), _fk(model, q), atol=1e-12)


BAD = {
    "parse": (["--base", "base", "--tip", "hand"], "cannot parse URDF"),
    "no link": (["--base", "nowhere", "--tip", "hand"], "no link 'nowhere'"),
    "above": (["--base", "l2", "--tip", "l1"], "is above base link"),
    "exclude": (["--exclude", "hand", "--exclude", "nope"], "no link 'nope'"),
    "excluded tip": (["--tip", "hand", "--exclude", "l2"], "'hand' is excluded"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_input_exits_2(case, arm, tmp_path, capsys):
    if case == "parse":
        arm.write_text(ARM[:200])
    out = tmp_path / "robot.yaml"
    assert main(["import-urdf", str(arm), *BAD[case][0], "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and BAD[case][1] in err[0], err
    assert not out.exists()


def test_import_excluding(arm, tmp_path, capsys):
    """--exclude l2 (repeatable) leaves l2 and hand out: one joint, 2 kg."""
    argv = ["import-urdf", str(arm), "--exclude", "l2", "--exclude", "hand"]
    assert main([*argv, "--out", str(tmp_path / "one.yaml")]) == 0
    out = capsys.readouterr().out
    assert "1 joints (R;" in out and "link masses (kg): 2\n" in out
    assert load_robot(tmp_path / "one.yaml").dynamics[0, 9] == 2.0


def test_output_naming_the_urdf_refused(arm, capsys):
    before = arm.read_text()
    argv = ["import-urdf", str(arm), "--base", "base", "--tip", "hand"]
    assert main([*argv, "--out", str(arm)]) == 2
    assert "is also the input --urdf" in capsys.readouterr().err
    assert arm.read_text() == before


def test_identify_takes_a_urdf(arm, tmp_path, capsys):
    """identify loads the URDF's chain (the missing log is what stops it)."""
    argv = ["identify", "--robot", str(arm), "--base", "base", "--tip", "hand"]
    out = tmp_path / "id.yaml"
    argv += ["--log", str(tmp_path / "missing.csv"), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "missing.csv" in err and not out.exists()
