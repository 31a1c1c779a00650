"""Joint-target correction on a robot with prismatic joints (the boom arm of
tests/conftest.py: a lifting column, joint 1, and a telescopic boom, joint 4,
both in m): the corrected joints checked on the TRUE robot's Drake plant, the
filtered motion's rates, the joint limits in m and the report's units."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.math import RotationMatrix

from rmdrake.compensation.correction import (
    correct_joint_motion,
    correct_path,
    correct_targets,
    filter_program,
)
from rmdrake.kinematics.forward import tool_jacobian, tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.plant import TOOL_FRAME, MakePlant

TOL = 1e-9  # m and rad: what a correction on a perfect model must reach


def poses(model, q):
    return tool_poses(model.table, q, sigma=model.sigma)


def drake_tool_poses(model, q) -> list:
    """Tool poses X_BE of ``model``'s MultibodyPlant (PrismaticJoint where
    sigma is 1) at each row of q: the oracle, independent of the numpy chain."""
    plant, _ = MakePlant(model, visual=False)
    context = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    out = []
    for qk in q:
        plant.SetPositions(context, qk)
        out.append(plant.CalcRelativeTransform(context, plant.world_frame(), tool))
    return out


@pytest.fixture
def case(boom):
    """Nominal boom arm, 12 well-conditioned joint vectors in the middle 80 %
    of the ranges (m for joints 1 and 4), and a "true" robot with 1 mm / 1
    mrad errors on every MDH entry (a few mm at the tool)."""
    rng = np.random.default_rng(4)
    lo, hi = boom.limits.lower, boom.limits.upper
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (200, 6))
    J = tool_jacobian(boom.table, q, sigma=boom.sigma)
    q = q[np.linalg.svd(J, compute_uv=False)[:, -1] >= 0.05][:12]
    assert q.shape[0] == 12
    names = error_parameter_names(boom, "full")
    true = apply_deltas(boom, names, 1e-3 * rng.standard_normal(len(names)))
    return boom, true, q


@pytest.mark.parametrize("pose", [False, True], ids=["position", "pose"])
def test_perfect_calibration_puts_the_true_drake_tool_on_the_targets(case, pose):
    """Calibrated == true: the joints solved on it put the true robot's Drake
    plant tool (prismatic joints as PrismaticJoint) on the nominal tool poses
    to 1e-9 m and rad, within the limits (m for joints 1 and 4), and the
    prismatic joints really move (mm-sized corrections)."""
    nominal, true, q = case
    X = poses(nominal, q)
    R = X[:, :3, :3]
    c = correct_targets(true, X[:, :3, 3], q_seed=q, orientation=R if pose else None)
    assert c.reachable.all() and c.iterations.max() <= 6
    lo, hi = true.limits.lower, true.limits.upper
    assert np.all((c.q >= lo) & (c.q <= hi))
    for k, X_drake in enumerate(drake_tool_poses(true, c.q)):
        assert np.linalg.norm(X_drake.translation() - X[k, :3, 3]) <= TOL
        if pose:
            R_err = RotationMatrix(R[k]).inverse() @ X_drake.rotation()
            assert abs(R_err.ToAngleAxis().angle()) <= TOL
    if pose:  # a full pose fixes all six joints: the slides must move
        assert np.abs(c.q - q)[:, [0, 3]].max() > 1e-4


def test_imperfect_calibration_leaves_its_own_error(case):
    """Calibrated = true + 5 um / 5 urad residual errors on every MDH entry:
    the true plant's tool lands on the target up to the calibrated model's own
    error at the solution, |p_true(q_c) - p_cal(q_c)| (to 1e-9 m), which is
    far below the error of the uncorrected program."""
    nominal, true, q = case
    names = error_parameter_names(true, "full")
    rng = np.random.default_rng(5)
    calibrated = apply_deltas(true, names, 5e-6 * rng.standard_normal(len(names)))
    f = filter_program(nominal, calibrated, q)
    assert f.correction.reachable.all()
    target = poses(nominal, q)[:, :3, 3]
    attained = np.array([X.translation() for X in drake_tool_poses(true, f.q)])
    error = np.linalg.norm(attained - target, axis=1)
    model_error = np.linalg.norm(
        poses(true, f.q)[:, :3, 3] - poses(calibrated, f.q)[:, :3, 3], axis=1
    )
    np.testing.assert_allclose(error, model_error, rtol=0, atol=TOL)
    before = np.linalg.norm(poses(true, q)[:, :3, 3] - target, axis=1)
    assert 1e-6 < error.max() < 0.1 * before.mean()  # a real, small residual


def test_filtered_motion_rates_and_units(case):
    """correct_joint_motion on the boom arm: the calibrated tool pose at q_c ==
    the nominal one at q, equal tool twists (prismatic columns [0; z_j] of the
    geometric Jacobian), qd_c == d q_c / dt by central differences; the summary
    gives the prismatic joints' corrections in mm."""
    nominal, calibrated, q = case
    h, w = 1e-3, np.array([1.0, 1.3, 0.7, 1.1, 0.9, 1.7])
    t = np.arange(0.0, 0.2, h)
    amplitude = np.array([0.05, 0.2, 0.2, 0.05, 0.2, 0.2])  # m or rad
    qt = q[0] + amplitude * np.sin(np.outer(t, w))
    qd = amplitude * w * np.cos(np.outer(t, w))
    filtered, qd_c, _ = correct_joint_motion(nominal, calibrated, qt, qd, 0 * qd)
    X_n, X_c = poses(nominal, qt), poses(calibrated, filtered.q)
    assert np.abs(X_c[:, :3, :] - X_n[:, :3, :]).max() < TOL
    J_n = tool_jacobian(nominal.table, qt, sigma=nominal.sigma)
    J_c = tool_jacobian(calibrated.table, filtered.q, sigma=calibrated.sigma)
    twist_n = np.einsum("mij,mj->mi", J_n, qd)
    twist_c = np.einsum("mij,mj->mi", J_c, qd_c)
    assert np.abs(twist_c - twist_n).max() < TOL
    fd = np.gradient(filtered.q, h, axis=0)[1:-1]
    assert np.abs(fd - qd_c[1:-1]).max() < 1e-6
    units = filtered.summary().splitlines()[0].split(": ")[1].split(", ")
    assert [u.split()[1] for u in units] == ["mm", "mrad", "mrad", "mm", "mrad", "mrad"]


def test_path_and_limits_in_metres(case):
    """A path that drives the boom (joint 4) 0.05 m past its upper limit: the
    warm-started path solution stays on the limit (m) where the target is out
    of reach, names those targets and solves the others to 1e-9 m."""
    nominal, true, q = case
    hi = true.limits.upper
    q_path = q[0] + np.linspace(0.0, 1.0, 40)[:, None] * (
        np.array([0, 0, 0, hi[3] + 0.05, 0, 0]) - [0, 0, 0, q[0, 3], 0, 0]
    )
    X = poses(true, q_path)
    c = correct_path(true, X[:, :3, 3], q_start=q_path[0], orientation=X[:, :3, :3])
    beyond = q_path[:, 3] > hi[3]
    assert np.all(c.q[:, 3] <= hi[3]) and np.all(c.q[beyond, 3] == hi[3])
    assert set(c.unreachable.tolist()) == set(np.flatnonzero(beyond).tolist())
    assert c.position_residual[~beyond].max() <= TOL
    assert c.at_limit[beyond].all()


def test_different_joint_types_are_refused(case):
    nominal, true, q = case
    revolute = dataclasses.replace(true, sigma=np.zeros(6, dtype=int))
    with pytest.raises(ValueError, match="sigma: joint types") as info:
        filter_program(nominal, revolute, q)
    assert "\n" not in str(info.value)
