"""Points fixed in the tool frame (markers, tracker targets): p_BM = p_BE +
R_BE p_EM, against Drake's plant and against finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.kinematics.forward import point_jacobian, tool_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.plant import TOOL_FRAME, MakePlant


def test_marker_points_equal_drake(any_robot, rng):
    """tool_points(..., p_EM=) == the plant's tool frame applied to p_EM, 1e-12."""
    plant, _ = MakePlant(any_robot, visual=False)
    ctx = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    lim = any_robot.limits
    q = rng.uniform(lim.lower, lim.upper, (8, any_robot.n_joints))
    p_EM = rng.uniform(-0.1, 0.1, (8, 3))
    p = tool_points(any_robot.table, q, sigma=any_robot.sigma, p_EM=p_EM)
    for i in range(8):
        plant.SetPositions(ctx, q[i])
        X = plant.CalcRelativeTransform(ctx, plant.world_frame(), tool)
        assert np.abs(X.multiply(p_EM[i]) - p[i]).max() < 1e-12
    # One (3,) offset is the same offset at every pose.
    one = tool_points(any_robot.table, q, sigma=any_robot.sigma, p_EM=p_EM[0])
    tiled = np.tile(p_EM[0], (8, 1))
    every = tool_points(any_robot.table, q, sigma=any_robot.sigma, p_EM=tiled)
    # Broadcast against tiled operands may take other BLAS kernels: a few ulp.
    np.testing.assert_allclose(one, every, rtol=0, atol=1e-14)


def test_marker_point_jacobian_equals_central_differences(any_robot, rng):
    names = error_parameter_names(any_robot, "full")
    idx = error_parameter_indices(any_robot, names)
    lim = any_robot.limits
    q = rng.uniform(lim.lower, lim.upper, (6, any_robot.n_joints))
    p_EM = rng.uniform(-0.2, 0.2, (6, 3))
    s = any_robot.sigma
    J = point_jacobian(any_robot.table, q, idx, sigma=s, p_EM=p_EM)
    flat, h = any_robot.table.ravel(), 1e-6
    for c, i in enumerate(idx):
        tp, tm = flat.copy(), flat.copy()
        tp[i] += h
        tm[i] -= h
        fd = (
            tool_points(tp.reshape(-1, 5), q, sigma=s, p_EM=p_EM)
            - tool_points(tm.reshape(-1, 5), q, sigma=s, p_EM=p_EM)
        ) / (2 * h)
        assert np.abs(fd - J[..., c]).max() <= 1e-7, names[c]


def test_marker_offset_bad_input(rv3sb):
    q = np.zeros((2, 6))
    with pytest.raises(ValueError, match="either distance or p_EM"):
        tool_points(rv3sb.table, q, 0.1, p_EM=[0, 0, 0.1])
    with pytest.raises(ValueError, match=r"p_EM: expected shape \(3,\) or \(2, 3\)"):
        tool_points(rv3sb.table, q, p_EM=np.zeros((3, 3)))
