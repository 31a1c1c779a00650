"""Oracle tests: numpy MDH kinematics against Drake's MultibodyPlant and against
finite differences of itself."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform

from rmdrake.kinematics.forward import (
    point_jacobian,
    tool_jacobian,
    tool_points,
    tool_poses,
)
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.plant import TOOL_FRAME, MakePlant


def random_errors(model, rng, scale_m=2e-3, scale_rad=5e-3):
    """Random deltas on every table entry (the `full` preset)."""
    names = error_parameter_names(model, "full")
    scales = np.array([scale_rad if n[1] in "abt" else scale_m for n in names])
    return names, scales * rng.standard_normal(len(names))


def test_forward_kinematics_equals_drake_plant(any_robot, rng):
    """Tool pose X_BE from numpy == CalcRelativeTransform(world, tool) to 1e-12,
    for random error parameters (every table entry) and random joint vectors,
    revolute and prismatic joints."""
    for _ in range(3):
        names, values = random_errors(any_robot, rng)
        model = apply_deltas(any_robot, names, values)
        plant, _ = MakePlant(model, visual=False)
        context = plant.CreateDefaultContext()
        tool = plant.GetFrameByName(TOOL_FRAME)
        q = rng.uniform(model.limits.lower, model.limits.upper, size=(20, 6))
        X_numpy = tool_poses(model.table, q, sigma=model.sigma)
        for k in range(q.shape[0]):
            plant.SetPositions(context, q[k])
            X = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
            # The batch, and one pose alone (the plain-float chain).
            for X_k in (
                X_numpy[k],
                tool_poses(model.table, q[k], sigma=model.sigma)[0],
            ):
                assert np.abs(X.translation() - X_k[:3, 3]).max() < 1e-12
                R_err = X.rotation().inverse() @ RigidTransform(X_k).rotation()
                assert abs(R_err.ToAngleAxis().angle()) < 1e-12


def test_batched_over_parameter_sets_equals_one_by_one(rv3sb, rng):
    """(P, N) evaluation equals P separate (N,) evaluations exactly."""
    tables = np.stack(
        [apply_deltas(rv3sb, *random_errors(rv3sb, rng)).table for _ in range(7)]
    )
    q = rng.uniform(rv3sb.limits.lower, rv3sb.limits.upper, size=(11, 6))
    dist = rng.uniform(0.005, 0.08, size=11)
    batch = tool_points(tables, q, dist)
    assert batch.shape == (7, 11, 3)
    for p in range(7):
        np.testing.assert_array_equal(batch[p], tool_points(tables[p], q, dist))
    poses = tool_poses(tables, q)
    assert poses.shape == (7, 11, 4, 4)
    expected = poses[..., :3, 3] + dist[None, :, None] * poses[..., :3, 2]
    # Two evaluation orders of p + d z: a few ulp of the 1 m scale on any CPU.
    np.testing.assert_allclose(batch, expected, rtol=0, atol=1e-14)


def test_point_jacobian_equals_central_differences(any_robot, rng):
    """Analytic d p_BM / d param == central difference to 1e-7 relative."""
    names, values = random_errors(any_robot, rng)
    model = apply_deltas(any_robot, names, values)
    idx = error_parameter_indices(model, names)
    q = rng.uniform(model.limits.lower, model.limits.upper, size=(15, 6))
    length = float(np.abs(model.table[:, [1, 3]]).max())
    dist = rng.uniform(0.01, 0.1, size=15) * length
    sigma = model.sigma
    J = point_jacobian(model.table, q, idx, dist, sigma=sigma)
    assert J.shape == (15, 3, len(idx))
    h = 1e-6
    flat = model.table.ravel()
    for c, i in enumerate(idx):
        tp, tm = flat.copy(), flat.copy()
        tp[i] += h
        tm[i] -= h
        fd = (
            tool_points(tp.reshape(-1, 5), q, dist, sigma=sigma)
            - tool_points(tm.reshape(-1, 5), q, dist, sigma=sigma)
        ) / (2 * h)
        scale = max(np.abs(J[..., c]).max(), length)
        assert np.abs(fd - J[..., c]).max() <= 1e-7 * scale, names[c]


def test_jacobian_batched_matches_single(rv3sb, rng):
    tables = np.stack([rv3sb.table, apply_deltas(rv3sb, ["dd3"], [1e-3]).table])
    q = rng.uniform(rv3sb.limits.lower, rv3sb.limits.upper, size=(4, 6))
    idx = error_parameter_indices(rv3sb, error_parameter_names(rv3sb, "paper"))
    J = point_jacobian(tables, q, idx)
    np.testing.assert_array_equal(J[1], point_jacobian(tables[1], q, idx))


@pytest.mark.parametrize(
    "q, message",
    [
        (np.zeros((3, 5)), r"q: expected shape \(N, 6\)"),
        (np.full((2, 6), np.nan), "q: expected finite numbers"),
    ],
)
def test_bad_joint_input(rv3sb, q, message):
    with pytest.raises(ValueError, match=message):
        tool_points(rv3sb.table, q)


def test_bad_table_and_distance(rv3sb):
    with pytest.raises(ValueError, match="MDH table: expected shape"):
        tool_points(np.zeros((7, 4)), np.zeros((1, 6)))
    with pytest.raises(ValueError, match=r"distance: expected shape \(2,\)"):
        tool_points(rv3sb.table, np.zeros((2, 6)), np.zeros(3))


# ---- inverse kinematics of the tool frame -----------------------------------------
LM = {"damping": 1e-12, "residual_damping": 1.0}  # the damping compensation uses


@pytest.mark.parametrize("dof", [3, 5, 6])
def test_tool_ik_meets_every_target_of_a_batch(any_robot, rng, dof):
    """Targets of the model itself, seeds 0.05 (rad or m) off: every residual
    (the stacked points) <= tol = 1e-10 m within 10 steps, q within the limits
    (m for the prismatic joints of the boom arm); X_BE is the forward
    kinematics at the returned q; one problem alone (the plain-float path)
    agrees with the batch (the numpy path)."""
    model = any_robot
    lo, hi = model.limits.lower, model.limits.upper
    q_true = rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo), (30, 6))
    X = tool_poses(model.table, q_true, sigma=model.sigma)
    axes = [X[:, :3, 2], X[:, :3, 0]][: (dof - 1) // 2]
    q0 = q_true + 0.05 * rng.standard_normal(q_true.shape)
    ik = solve_tool_ik(model, q0, X[:, :3, 3], *axes, **LM)
    assert ik.residual.max() <= 1e-10 and ik.iterations.max() <= 10
    assert np.all((ik.q >= lo) & (ik.q <= hi))
    X_q = tool_poses(model.table, ik.q, sigma=model.sigma)
    np.testing.assert_allclose(ik.X_BE, X_q, atol=1e-14)
    assert np.linalg.norm(ik.X_BE[:, :3, 3] - X[:, :3, 3], axis=1).max() <= 1e-10
    if dof == 6:
        np.testing.assert_allclose(ik.X_BE[:, :3, :3], X[:, :3, :3], atol=1e-9)
    for k in range(3):
        one = solve_tool_ik(
            model,
            q0[k : k + 1],
            X[k : k + 1, :3, 3],
            *(a[k : k + 1] for a in axes),
            **LM,
        )
        assert one.residual[0] <= 1e-10
        np.testing.assert_allclose(one.q[0], ik.q[k], rtol=0, atol=1e-10)
        np.testing.assert_allclose(one.X_BE[0], ik.X_BE[k], rtol=0, atol=1e-10)


@pytest.mark.parametrize("single", [False, True])
def test_tool_ik_jacobian_equals_point_jacobian(boom, rng, single):
    """The IK's q-Jacobian of its three points (tool origin, lever along z_E,
    lever along x_E), numpy and plain-float paths, == the theta (revolute) or
    r (prismatic) columns of :func:`point_jacobian` of the same points, to
    1e-12: z_j x (p - o_j) for the revolute joints, z_j for joints 1 and 4."""
    from rmdrake.kinematics.ik import _BatchedPoints, _SinglePoints

    lever, N = 0.1, 1 if single else 5
    q = rng.uniform(boom.limits.lower, boom.limits.upper, (N, 6))
    slide = boom.sigma == 1
    kind = _SinglePoints if single else _BatchedPoints
    points = kind(boom.table, 6, 3, lever, slide)
    _, state = points(q)
    J = points.jacobian(state, np.ones(N, dtype=bool))
    idx = 5 * np.arange(6) + np.where(slide, 3, 2)
    x_row = np.vstack([boom.table, [0.0, 0.0, 0.0, 0.0, np.pi / 2]])
    expected = [
        point_jacobian(boom.table, q, idx, sigma=boom.sigma),
        point_jacobian(boom.table, q, idx, lever, sigma=boom.sigma),
        point_jacobian(
            x_row,
            np.hstack([q, np.zeros((N, 1))]),
            idx,
            lever,
            sigma=np.append(boom.sigma, 0),
        ),  # fmt: skip
    ]
    np.testing.assert_allclose(J, np.concatenate(expected, axis=1), atol=1e-12)


def test_residual_damping_keeps_newton_fast_near_the_wrist_singularity(rv3sb):
    """q5 = 0.02 rad: the constant damping 1e-6 m^2 is of the order of the
    smallest squared singular value and slows convergence down to linear; the
    damping |r|^2 vanishes with the residual and keeps it quadratic."""
    q = np.array([[0.3, 0.2, 1.2, 0.4, 0.02, 0.1]])
    X = tool_poses(rv3sb.table, q)
    args = (rv3sb, q + 0.01, X[:, :3, 3], X[:, :3, 2], X[:, :3, 0])
    constant = solve_tool_ik(*args, give_up=np.inf)
    shrinking = solve_tool_ik(*args, give_up=np.inf, **LM)
    assert shrinking.residual[0] <= 1e-10 and constant.residual[0] <= 1e-10
    assert shrinking.iterations[0] <= 4 < 10 <= constant.iterations[0]


def test_tool_ik_stays_within_the_joint_limits(rv3sb, rng):
    """A target that needs joint 2 0.2 rad past its upper limit: q is clipped
    after every step, the joint ends on its limit, the residual stays large."""
    lo, hi = rv3sb.limits.lower, rv3sb.limits.upper
    q = np.array(
        [[0.3, hi[1] + 0.2, 1.2, 0.4, 0.9, 0.1], [0.3, 0.2, 1.2, 0.4, 0.9, 0.1]]
    )
    X = tool_poses(rv3sb.table, q)
    ik = solve_tool_ik(rv3sb, np.clip(q, lo, hi), X[:, :3, 3], X[:, :3, 2], X[:, :3, 0])
    assert np.all((ik.q >= lo) & (ik.q <= hi))
    assert ik.q[0, 1] == hi[1] and ik.residual[0] > 1e-3 and ik.residual[1] <= 1e-10


def test_tool_ik_bad_input(rv3sb):
    q, p = np.zeros((2, 6)), np.zeros((2, 3))
    with pytest.raises(ValueError, match="x_BE: needs z_BE"):
        solve_tool_ik(rv3sb, q, p, None, p)
    with pytest.raises(ValueError, match=r"p_BE: expected shape \(2, 3\)"):
        solve_tool_ik(rv3sb, q, p[:1])
    with pytest.raises(ValueError, match="q0: expected finite"):
        solve_tool_ik(rv3sb, np.full((2, 6), np.nan), p)


def test_tool_jacobian_equals_drake(any_robot, rng):
    """[w_BE; v_BE] per joint rate == Drake's CalcJacobianSpatialVelocity of the
    tool frame, every robot (prismatic joints too), random q and random table
    errors, to 1e-12."""
    from pydrake.multibody.tree import JacobianWrtVariable

    from rmdrake.model.plant import TOOL_FRAME, MakePlant

    table = any_robot.table + 1e-3 * rng.standard_normal(any_robot.table.shape)
    model = any_robot.with_table(table)
    plant, _ = MakePlant(model, visual=False)
    context = plant.CreateDefaultContext()
    q = rng.uniform(model.limits.lower, model.limits.upper, (5, model.n_joints))
    J = tool_jacobian(model.table, q, sigma=model.sigma)
    world, tool = plant.world_frame(), plant.GetFrameByName(TOOL_FRAME)
    for k in range(q.shape[0]):
        plant.SetPositions(context, q[k])
        J_drake = plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kV, tool, np.zeros(3), world, world
        )
        scale = max(1.0, np.abs(J_drake).max())
        np.testing.assert_allclose(J[k], J_drake, rtol=0, atol=1e-12 * scale)
        alone = tool_jacobian(model.table, q[k], sigma=model.sigma)[0]  # plain floats
        np.testing.assert_allclose(alone, J_drake, rtol=0, atol=1e-12 * scale)
