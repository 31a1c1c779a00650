"""Kinematic-only robots on the command line (a calibration tool's URDF: no
masses, ``effort="0"``): import-urdf warns once and writes no dynamics and no
effort limits; show, export-urdf and excite take the robot (export then
re-import gives the same MDH table); simulate, identify, identify-gains and
identify-payload refuse it by name with exit 2 and write nothing; identify
fits a robot without dynamics (effort limits known) from its log. The MUKCa
Panda of the shared data the same way."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from rmdrake.cli.commands import main
from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import load_fourier
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.dynamic_parameters import random_standard_parameters
from rmdrake.model.loading import load_robot

MUKCA = SHARED_DATA / "mukca_panda/panda.urdf"
MUKCA_ARGS = ["--base", "panda_link0", "--tip", "ball_link"]
MUKCA_ARGS += ["--exclude", "panda_leftfinger", "--exclude", "panda_rightfinger"]


def _joint(name: str, parent: str, child: str, xyz: str, rpy: str) -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
        f'<child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/>'
        '<axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="1.5" '
        'effort="EFFORT"/><safety_controller k_velocity="40"/></joint>'
    )


ARM = "\n".join(
    [
        '<robot name="karm">',
        *(f'<link name="{k}"/>' for k in ("base", "l1", "l2", "l3", "tip")),
        _joint("j1", "base", "l1", "0 0 0.3", "0 0 0"),
        _joint("j2", "l1", "l2", "0.05 0 0.1", "1.5707963267948966 0 0"),
        _joint("j3", "l2", "l3", "0.4 0 0", "0 0 0.2"),
        '<joint name="t" type="fixed"><parent link="l3"/><child link="tip"/>'
        '<origin xyz="0.3 0 0.02" rpy="0 1.5707963267948966 0"/></joint>',
        "</robot>",
    ]
)
"""A 3R arm as a calibration tool ships it: links without inertials, every
effort EFFORT (to fill in), safety controllers."""


def _import(urdf: Path, out: Path, capsys, *extra: str) -> list[str]:
    """import-urdf ``urdf`` to ``out`` (exit 0); the lines on stderr."""
    assert main(["import-urdf", str(urdf), *extra, "--out", str(out)]) == 0
    return capsys.readouterr().err.strip().splitlines()


@pytest.fixture
def karm(tmp_path, capsys) -> Path:
    """The imported kinematic-only arm (robot YAML)."""
    urdf = tmp_path / "karm.urdf"
    urdf.write_text(ARM.replace("EFFORT", "0"))
    err = _import(urdf, tmp_path / "karm.yaml", capsys)
    assert len(err) == 1, err
    assert err[0].startswith(
        "rmdrake: warning: karm.urdf: kinematic-only model: every link mass is 0 "
        "(no dynamics written) and no joint has an effort limit; "
    )
    return tmp_path / "karm.yaml"


def test_import_writes_neither_dynamics_nor_effort(karm):
    text = karm.read_text()
    assert "dynamics:" not in text and "effort:" not in text
    model = load_robot(karm)
    assert model.kinematic_only and model.n_joints == 3


def test_show_and_export_round_trip(karm, tmp_path, capsys):
    """show (and its Meshcat page) and export-urdf take the robot; the URDF has
    effort 0 and no inertials, and re-imports as the same kinematic-only
    robot: MDH table to 1e-12."""
    html = tmp_path / "karm.html"
    assert main(["show", "--robot", str(karm), "--html", str(html)]) == 0
    out = capsys.readouterr().out
    assert "no dynamic parameters" in out and "no joint effort limits" in out
    assert html.stat().st_size > 10_000
    urdf = tmp_path / "export.urdf"
    assert main(["export-urdf", "--robot", str(karm), "--out", str(urdf)]) == 0
    text = urdf.read_text()
    assert text.count('effort="0.0"') == 3 and "<inertial>" not in text
    err = _import(urdf, tmp_path / "again.yaml", capsys, "--base", "base")
    assert len(err) == 1 and "kinematic-only model" in err[0], err
    model, again = load_robot(karm), load_robot(tmp_path / "again.yaml")
    assert again.kinematic_only and again.dynamics is None
    np.testing.assert_allclose(again.table, model.table, rtol=0, atol=1e-12)


def test_excite_takes_it(karm, tmp_path, capsys):
    """An excitation needs the kinematics and the position, velocity and
    acceleration limits only: excite designs one for a kinematic-only robot."""
    out = tmp_path / "traj.yaml"
    argv = ["excite", "--robot", str(karm), "--out", str(out), "--harmonics", "3"]
    assert main([*argv, "--maxiter", "2", "--seed", "1"]) == 0
    load_fourier(out).check_limits(load_robot(karm))


COMMANDS = {  # command: (extra arguments, what the robot lacks for it)
    "simulate": (["--trajectory", "{traj}"], "no dynamics and no joint effort"),
    "identify": (["--log", "{log}"], "no joint effort limits"),
    "identify-gains": (
        ["--log", "{log}", "--log", "{log}", "--payload-mass", "1"],
        "no joint effort limits",
    ),
    "identify-payload": (["--log", "{log}"], "no dynamics and no joint effort"),
}


@pytest.mark.parametrize("command", COMMANDS)
def test_dynamic_commands_refuse_by_name(command, karm, tmp_path, capsys):
    """Exit 2, one line naming the robot, what it lacks and the command;
    nothing written (the logs are refused before they are read)."""
    traj = tmp_path / "traj.yaml"
    random_fourier_trajectory(load_robot(karm), harmonics=3, seed=2).save(traj)
    log = tmp_path / "log.csv"
    log.write_text("t,q1,q2,q3,tau1,tau2,tau3\n")
    extra, lacks = COMMANDS[command]
    extra = [a.format(traj=traj, log=log) for a in extra]
    out = tmp_path / "out.yaml" if command != "simulate" else tmp_path / "out.csv"
    assert main([command, "--robot", str(karm), *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"rmdrake: error: robot 'karm' has {lacks}"), err
    assert "(a kinematic-only model; expected " in err[0]
    assert f": rmdrake {command} needs them" in err[0]
    assert not out.exists()


def test_identify_fits_a_robot_without_dynamics(tmp_path, capsys):
    """Effort limits known, no masses: identify (no prior) fits the log alone,
    the way such a robot gets its dynamics; the written robot predicts the
    log's torques (noise-free, made from random physical parameters by the
    regressor) to 1e-6 of their range."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM.replace("EFFORT", "200"))
    err = _import(urdf, tmp_path / "arm.yaml", capsys)
    assert len(err) == 1 and "effort" not in err[0].split(";")[0], err
    model = load_robot(tmp_path / "arm.yaml")
    assert model.dynamics is None and model.has_effort_limits
    chi = random_standard_parameters(3, np.random.default_rng(5), mass=(1.0, 3.0))
    t, q, qd, qdd = random_fourier_trajectory(model, fill=0.8, seed=4).sample(150.0)
    tau = torques(model, q, qd, qdd, chi)
    write_joint_log(tmp_path / "log.csv", JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd))
    out = tmp_path / "identified.yaml"
    argv = ["identify", "--robot", str(tmp_path / "arm.yaml"), "--method", "ols"]
    assert main([*argv, "--log", str(tmp_path / "log.csv"), "--out", str(out)]) == 0
    found = load_robot(out)
    assert found.dynamics is not None and found.has_effort_limits
    pred = torques(found, q, qd, qdd, standard_parameters(found))
    assert np.abs(pred - tau).max() < 1e-6 * np.ptp(tau)


@pytest.mark.skipif(not MUKCA.is_file(), reason="the MUKCa Panda is not in shared/")
def test_mukca_panda(tmp_path, capsys):
    """The MUKCa Panda (no inertials, effort limits): one warning line naming
    the masses only, no dynamics written; show and export-urdf take it and the
    export re-imports with the same MDH table and kinematics; simulate refuses
    it by name."""
    yaml_path = tmp_path / "panda.yaml"
    err = _import(MUKCA, yaml_path, capsys, *MUKCA_ARGS)
    assert len(err) == 1, err
    assert err[0].startswith(
        "rmdrake: warning: panda.urdf: kinematic-only model: every link mass is 0 "
        "(no dynamics written); show, calibrate, correct, export-urdf and excite "
        "work, simulate"
    )
    assert "dynamics:" not in yaml_path.read_text()
    model = load_robot(yaml_path)
    assert model.dynamics is None and model.has_effort_limits
    assert main(["show", "--robot", str(yaml_path)]) == 0
    assert "no dynamic parameters" in capsys.readouterr().out
    urdf = tmp_path / "panda_export.urdf"
    assert main(["export-urdf", "--robot", str(yaml_path), "--out", str(urdf)]) == 0
    assert urdf.read_text().count('effort="87.0"') == 4
    err = _import(urdf, tmp_path / "again.yaml", capsys, "--base", "base")
    assert len(err) == 1 and "every link mass is 0" in err[0], err
    again = load_robot(tmp_path / "again.yaml")
    np.testing.assert_allclose(again.table, model.table, rtol=0, atol=1e-12)
    q = np.random.default_rng(7).uniform(-2.5, 2.5, (20, 7))
    err_fk = tool_poses(again.table, q) - tool_poses(model.table, q)
    assert np.abs(err_fk).max() < 1e-12
    traj = tmp_path / "traj.yaml"
    random_fourier_trajectory(model, harmonics=3, seed=3).save(traj)
    argv = ["simulate", "--robot", str(yaml_path), "--trajectory", str(traj)]
    assert main([*argv, "--out", str(tmp_path / "log.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "rmdrake: error: robot 'panda' has no dynamics (a kinematic-only model; "
        "expected a 'dynamics' section with 13 standard parameters per link): "
        "rmdrake simulate needs them"
    ]
