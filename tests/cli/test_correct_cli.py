"""rmdrake correct: tool targets or a nominal joint program in, the corrected
joint program out; the calibrated model's tool lands on the targets."""

from __future__ import annotations

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
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("correct")
    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(2).standard_normal(len(names))
    calibrated = apply_deltas(nominal, names, deltas)  # keeps the name rv3sb
    calibrated.save(tmp / "calibrated.yaml")
    rng = np.random.default_rng(5)
    q = rng.uniform(-0.8, 0.8, (12, 6))
    q[:, 2] = rng.uniform(0.2, 1.2, 12)  # joint 3 is limited to [-20, 171] deg
    q[:, 4] = rng.uniform(0.5, 1.2, 12)  # away from the wrist singularity
    X = tool_poses(nominal.table, q)
    return tmp, nominal, calibrated, q, X


def test_tool_targets_round_trip(case, capsys):
    tmp, nominal, calibrated, q, X = case
    targets = ToolTargets(
        X[:, :3, 3], rpy_from_rotation(X[:, :3, :3]), 0.1 * np.arange(12)
    )
    write_tool_targets(tmp / "targets.csv", targets)
    out = tmp / "q.csv"
    argv = ["correct", "--robot", str(tmp / "calibrated.yaml")]
    assert main([*argv, "--targets", str(tmp / "targets.csv"), "--out", str(out)]) == 0
    program = read_joint_program(out, 6)
    np.testing.assert_array_equal(program.t, targets.t)
    X_c = tool_poses(calibrated.table, program.q)
    assert np.abs(X_c[:, :3, 3] - X[:, :3, 3]).max() < 1e-9
    assert np.abs(X_c[:, :3, :3] - X[:, :3, :3]).max() < 1e-9
    printed = capsys.readouterr().out
    assert "12 targets, 0 unreachable" in printed and "largest correction" in printed


def test_joint_program_is_filtered(case):
    tmp, nominal, calibrated, q, X = case
    write_joint_program(tmp / "nominal_q.csv", JointProgram(q))
    out = tmp / "filtered.csv"
    argv = ["correct", "--robot", str(tmp / "calibrated.yaml"), "--nominal", "rv3sb"]
    assert (
        main([*argv, "--targets", str(tmp / "nominal_q.csv"), "--out", str(out)]) == 0
    )
    q_c = read_joint_program(out, 6).q
    X_c = tool_poses(calibrated.table, q_c)
    assert np.abs(X_c[:, :3, 3] - X[:, :3, 3]).max() < 1e-9
    assert 1e-5 < np.abs(q_c - q).max() < 1e-2  # a real, small correction


def test_unreachable_target_is_named_and_nothing_is_written(case, capsys):
    tmp, nominal, calibrated, q, X = case
    p = X[:, :3, 3].copy()
    p[3] = [3.0, 0.0, 0.5]  # far outside the 0.7 m reach
    write_tool_targets(tmp / "far.csv", ToolTargets(p))
    out = tmp / "far_q.csv"
    argv = ["correct", "--robot", str(tmp / "calibrated.yaml"), "--targets"]
    assert main([*argv, str(tmp / "far.csv"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "out of reach, first row 4" in err
    assert not out.exists()
    assert (
        main([*argv, str(tmp / "far.csv"), "--out", str(out), "--allow-unreachable"])
        == 0
    )
    assert read_joint_program(out, 6).q.shape == (11, 6)


def test_bad_input_exits_2_with_one_line(case, capsys):
    tmp, *_ = case
    (tmp / "nan.csv").write_text("x,y,z\n0.3,0.1,nan\n")
    write_joint_program(tmp / "q3.csv", JointProgram(np.zeros((2, 3))))
    cases = [
        (["--targets", str(tmp / "nan.csv")], "nan.csv"),
        (["--targets", str(tmp / "q3.csv")], "3 joint columns, expected 6"),
        (["--targets", str(tmp / "q3.csv"), "--nominal", "demo_rh"], None),
    ]
    for extra, message in cases:
        out = tmp / "never.csv"
        argv = ["correct", "--robot", str(tmp / "calibrated.yaml"), *extra]
        assert main([*argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("rmdrake: error:") and err.count("\n") == 0
        if message:
            assert message in err
        assert not out.exists()


def test_boom_arm_yaml_end_to_end(boom, tmp_path, capsys):
    """`rmdrake correct` on robot YAMLs with prismatic joints 1 and 4: tool
    targets (position and RPY) solved on the calibrated boom arm, and a
    nominal joint program filtered; the written joints are within the limits
    (m for the slides) and put the calibrated robot's Drake plant tool (with
    PrismaticJoint) on the targets to 1e-9 m and rad. Poses away from the arm's
    singularities (smallest singular value of the tool Jacobian >= 0.05)."""
    from pydrake.math import RotationMatrix

    from rmdrake.kinematics.forward import tool_jacobian
    from rmdrake.model.plant import TOOL_FRAME, MakePlant

    names = error_parameter_names(boom, "full")
    deltas = 1e-3 * np.random.default_rng(6).standard_normal(len(names))
    calibrated = apply_deltas(boom, names, deltas)
    boom.save(tmp_path / "boom.yaml")
    calibrated.save(tmp_path / "calibrated.yaml")
    lo, hi = boom.limits.lower, boom.limits.upper
    rng = np.random.default_rng(9)
    q = rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo), (100, 6))
    J = tool_jacobian(boom.table, q, sigma=boom.sigma)
    q = q[np.linalg.svd(J, compute_uv=False)[:, -1] >= 0.05][:8]  # not singular
    X = tool_poses(boom.table, q, sigma=boom.sigma)
    write_tool_targets(
        tmp_path / "targets.csv",
        ToolTargets(X[:, :3, 3], rpy_from_rotation(X[:, :3, :3])),
    )
    write_joint_program(tmp_path / "nominal_q.csv", JointProgram(q))
    plant, _ = MakePlant(calibrated, visual=False)
    context = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    argv = ["correct", "--robot", str(tmp_path / "calibrated.yaml")]
    argv += ["--nominal", str(tmp_path / "boom.yaml")]
    for given in ("targets.csv", "nominal_q.csv"):
        out = tmp_path / f"out_{given}"
        assert main([*argv, "--targets", str(tmp_path / given), "--out", str(out)]) == 0
        assert "8 targets, 0 unreachable" in capsys.readouterr().out
        q_c = read_joint_program(out, 6).q
        assert np.all((q_c >= lo) & (q_c <= hi))
        for k in range(8):
            plant.SetPositions(context, q_c[k])
            X_c = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
            assert np.linalg.norm(X_c.translation() - X[k, :3, 3]) < 1e-9
            R_err = RotationMatrix(X[k, :3, :3]).inverse() @ X_c.rotation()
            assert abs(R_err.ToAngleAxis().angle()) < 1e-9
        if given == "nominal_q.csv":  # filtering: the slides correct too (mm)
            assert 1e-4 < np.abs(q_c - q)[:, [0, 3]].max() < 0.05
