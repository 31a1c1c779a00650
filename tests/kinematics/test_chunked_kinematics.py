"""Forward kinematics, error Jacobians and the tool IK in bounded chunks:
equal to one block (the direct oracle) on small data, and a memory bound
that the unchunked chain (about 1.5 kB per pose) would break."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import rmdrake.kinematics.forward as forward
from rmdrake.kinematics.forward import (
    chunk_slices,
    point_jacobian,
    tool_jacobian,
    tool_points,
    tool_poses,
)
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.model.loading import load_robot

MB = 2**20


def _all(table, q, sigma):
    """Every chunked function's output at (table, q)."""
    rng = np.random.default_rng(1)
    dist = rng.uniform(0.0, 0.1, q.shape[0])
    p_EM = rng.uniform(-0.1, 0.1, (q.shape[0], 3))
    idx = np.arange(0, table.shape[-2] * 5, 3)
    return [
        tool_poses(table, q, sigma=sigma),
        tool_points(table, q, dist, sigma=sigma),
        tool_points(table, q, sigma=sigma, p_EM=p_EM),
        point_jacobian(table, q, idx, dist, sigma=sigma),
        point_jacobian(table, q, idx, sigma=sigma, p_EM=p_EM),
        tool_jacobian(table, q, sigma=sigma),
    ]


@pytest.mark.parametrize("stack", [False, True])
def test_chunks_equal_one_block(stack, monkeypatch):
    """A table (or a stack of 3) and 50 joint vectors, in chunks of 7 pairs
    (2 vectors per chunk with the stack): the one-block values to 1e-15."""
    from conftest import boom_arm  # prismatic joints too

    model = boom_arm()
    rng = np.random.default_rng(0)
    q = rng.uniform(model.limits.lower, model.limits.upper, (50, model.n_joints))
    table = model.table
    if stack:
        table = table + 1e-3 * rng.standard_normal((3, *table.shape))
    one = _all(table, q, model.sigma)
    monkeypatch.setattr(forward, "CHUNK_POSES", 7)
    for a, b in zip(_all(table, q, model.sigma), one, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


def test_point_jacobian_memory_is_the_output_plus_a_chunk():
    """200 000 poses, 5 columns: the output is 24 MB; the chain of one block
    kept about 300 MB of frames; chunked the call stays under 80 MB."""
    model = load_robot("rv3sb")
    q = np.random.default_rng(2).uniform(-1, 1, (200_000, 6))
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        J = point_jacobian(model.table, q, [0, 7, 12, 18, 29], 0.05)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert J.nbytes == 200_000 * 3 * 5 * 8
    assert peak < 80 * MB, peak / MB


def test_ik_chunks_equal_one_block(monkeypatch):
    """solve_tool_ik on 40 full-pose targets in chunks of at most 6
    problems: the one-block joints to 1e-12 rad and the same step counts."""
    model = load_robot("rv3sb")
    rng = np.random.default_rng(3)
    q_true = rng.uniform(-1, 1, (40, 6))
    X = tool_poses(model.table, q_true)
    q0 = q_true + 0.2 * rng.standard_normal(q_true.shape)
    args = (model, q0, X[:, :3, 3], X[:, :3, 2], X[:, :3, 0])
    one = solve_tool_ik(*args)
    monkeypatch.setattr(forward, "CHUNK_POSES", 6)
    chunked = solve_tool_ik(*args)
    np.testing.assert_allclose(chunked.q, one.q, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(chunked.iterations, one.iterations)


@pytest.mark.parametrize("count", [0, 1, 2, 7, 100, 101])
def test_chunk_slices_cover_in_equal_parts(count):
    parts = chunk_slices(count, 10)
    sizes = [s.stop - s.start for s in parts]
    assert sum(sizes) == count and all(s <= 10 for s in sizes)
    assert max(sizes) - min(sizes) <= 1
    assert count < 2 or min(sizes) >= 2  # no single-problem part
    assert [s.start for s in parts[1:]] == [s.stop for s in parts[:-1]]
