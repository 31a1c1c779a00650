"""rmdrake correct --payload: on an elastic calibrated robot the written joints
are the motor-side targets whose link side, sagging under gravity and the
payload, puts the calibrated tool on the nominal tool poses; on a rigid robot a
payload changes nothing (a note), and a bad payload is a one-line error."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.compensation.correction import rpy_from_rotation
from rmdrake.compensation.programs import (
    JointProgram,
    ToolTargets,
    read_joint_program,
    write_joint_program,
    write_tool_targets,
)
from rmdrake.dynamics.compliance import link_angles
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Compliance

Q = np.array(
    [[0.1, 0.3, 0.6, 0.2, 0.7, 0.1], [-0.4, 0.6, 0.3, -0.5, 1.0, 0.4],
     [0.8, 0.1, 1.0, 0.3, -0.6, -0.2], [0.3, 0.4, 0.8, -0.2, 0.9, 0.0]]
)  # fmt: skip  # demo_rh poses away from its singularities, rad


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("correct_payload")
    nominal = load_robot("demo_rh")
    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(8).standard_normal(len(names))
    rigid = apply_deltas(nominal, names, deltas)  # keeps the name demo_rh
    elastic = dataclasses.replace(
        rigid, compliance=Compliance([3e8, 1e8, 1.5e8, 5e7, 4e7, 2e7])
    )
    rigid.save(tmp / "rigid.yaml")
    elastic.save(tmp / "elastic.yaml")
    write_joint_program(tmp / "q.csv", JointProgram(Q))
    X = tool_poses(nominal.table, Q)
    rpy = rpy_from_rotation(X[:, :3, :3])
    write_tool_targets(tmp / "targets.csv", ToolTargets(X[:, :3, 3], rpy))
    return tmp, elastic, X


def _run(tmp, robot, targets, *extra):
    out = tmp / f"out_{robot}_{targets}_{'_'.join(extra)}.csv"
    argv = ["correct", "--robot", str(tmp / robot), "--targets", str(tmp / targets)]
    code = main([*argv, "--out", str(out), *extra])
    return code, out


@pytest.mark.parametrize("targets", ["q.csv", "targets.csv"])
@pytest.mark.parametrize("payload", [None, 2250.0, 0.0])
def test_elastic_robot_gets_motor_side_targets(case, capsys, targets, payload):
    """Oracle: compliance.link_angles of the written (motor) joints at the
    payload (None: the robot's 4.5 t) puts the calibrated tool on the nominal
    tool poses to 1e-9 m and rad."""
    tmp, elastic, X = case
    extra = () if payload is None else ("--payload", str(payload))
    code, out = _run(tmp, "elastic.yaml", targets, *extra)
    assert code == 0
    mass = 4500.0 if payload is None else payload
    q_m = read_joint_program(out, 6).q
    X_c = tool_poses(elastic.table, link_angles(elastic, q_m, mass))
    assert np.abs(X_c[:, :3, 3] - X[:, :3, 3]).max() < 1e-9
    assert np.abs(X_c[:, :3, :3] - X[:, :3, :3]).max() < 1e-9
    printed = capsys.readouterr().out
    assert f"largest pre-deflection per joint (payload {mass:g} kg): " in printed
    # Without the pre-deflection the tool would sag (> 1 mm on this arm).
    X_sag = tool_poses(elastic.table, link_angles(elastic, link_angles(
        elastic, q_m, mass), mass))  # fmt: skip
    assert np.abs(X_sag[:, :3, 3] - X[:, :3, 3]).max() > 1e-3


def test_rigid_robot_payload_is_a_note_or_an_error(case, capsys):
    tmp, *_ = case
    code, plain = _run(tmp, "rigid.yaml", "q.csv")
    assert code == 0 and "pre-deflection" not in capsys.readouterr().out
    code, zero = _run(tmp, "rigid.yaml", "q.csv", "--payload", "0")
    assert code == 0 and "note" not in capsys.readouterr().out
    code, loaded = _run(tmp, "rigid.yaml", "q.csv", "--payload", "2250")
    printed = capsys.readouterr().out
    assert code == 0
    assert "no compliance (rigid joints): --payload 2250 kg changes nothing" in printed
    for out in (zero, loaded):
        np.testing.assert_array_equal(
            read_joint_program(out, 6).q, read_joint_program(plain, 6).q
        )


@pytest.mark.parametrize(
    "robot, payload, message",
    [
        ("elastic.yaml", "-5", "payload: expected masses >= 0 kg"),
        ("elastic.yaml", "nan", "payload"),
        ("no_payload.yaml", "100", "has no payload entry"),
    ],
)
def test_bad_payload_exits_2_with_one_line(case, capsys, robot, payload, message):
    tmp, elastic, _ = case
    dataclasses.replace(elastic, payload=None).save(tmp / "no_payload.yaml")
    code, out = _run(tmp, robot, "q.csv", "--payload", payload)
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("rmdrake: error:") and "\n" not in err
    assert message in err and not out.exists()
