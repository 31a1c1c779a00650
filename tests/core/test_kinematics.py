"""Oracle tests: numpy MDH kinematics against Drake's MultibodyPlant and against
finite differences of itself."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform

from rmdrake.kinematics import point_jacobian, tool_points, tool_poses
from rmdrake.plant import TOOL_FRAME, MakePlant
from rmdrake.robot import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)


def random_errors(model, rng, scale_m=2e-3, scale_rad=5e-3):
    """Random deltas on every table entry (the `full` preset)."""
    names = error_parameter_names(model, "full")
    scales = np.array([scale_rad if n[1] in "abt" else scale_m for n in names])
    return names, scales * rng.standard_normal(len(names))


def test_forward_kinematics_equals_drake_plant(shipped, rng):
    """Tool pose X_BE from numpy == CalcRelativeTransform(world, tool) to 1e-12,
    for random error parameters (every table entry) and random joint vectors."""
    for _ in range(3):
        names, values = random_errors(shipped, rng)
        model = apply_deltas(shipped, names, values)
        plant, _ = MakePlant(model, visual=False)
        context = plant.CreateDefaultContext()
        tool = plant.GetFrameByName(TOOL_FRAME)
        q = rng.uniform(model.limits.lower, model.limits.upper, size=(20, 6))
        X_numpy = tool_poses(model.table, q)
        for k in range(q.shape[0]):
            plant.SetPositions(context, q[k])
            X = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
            assert np.abs(X.translation() - X_numpy[k, :3, 3]).max() < 1e-12
            R_err = X.rotation().inverse() @ RigidTransform(X_numpy[k]).rotation()
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
    np.testing.assert_allclose(batch, expected, rtol=0, atol=1e-15)


def test_point_jacobian_equals_central_differences(shipped, rng):
    """Analytic d p_BM / d param == central difference to 1e-7 relative."""
    names, values = random_errors(shipped, rng)
    model = apply_deltas(shipped, names, values)
    idx = error_parameter_indices(model, names)
    q = rng.uniform(model.limits.lower, model.limits.upper, size=(15, 6))
    length = float(np.abs(model.table[:, [1, 3]]).max())
    dist = rng.uniform(0.01, 0.1, size=15) * length
    J = point_jacobian(model.table, q, idx, dist)
    assert J.shape == (15, 3, len(idx))
    h = 1e-6
    flat = model.table.ravel()
    for c, i in enumerate(idx):
        tp, tm = flat.copy(), flat.copy()
        tp[i] += h
        tm[i] -= h
        fd = (
            tool_points(tp.reshape(-1, 5), q, dist)
            - tool_points(tm.reshape(-1, 5), q, dist)
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
