"""rmdrake correct's multi-start IK over many targets in chunks: the same
solutions as one batch (the direct oracle), and never more than a chunk of
targets (times the starts) in one IK batch."""

from __future__ import annotations

import numpy as np

import rmdrake.compensation.correction as correction
from rmdrake.compensation.correction import inverse_kinematics
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot


def _targets(count: int):
    model = load_robot("rv3sb")
    q = np.random.default_rng(5).uniform(-1, 1, (count, 6))
    X = tool_poses(model.table, q)
    return model, X[:, :3, 3], X[:, :3, :3]


def test_chunked_targets_equal_one_batch(monkeypatch):
    """30 full-pose targets in chunks of at most 7: the one-batch joints to
    1e-12 rad, residuals to 1e-12 m, and the same reachability."""
    model, p, R = _targets(30)
    one = inverse_kinematics(model, p, orientation=R, starts=4)
    monkeypatch.setattr(correction, "CHUNK_TARGETS", 7)
    chunked = inverse_kinematics(model, p, orientation=R, starts=4)
    np.testing.assert_allclose(chunked.q, one.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        chunked.position_residual, one.position_residual, rtol=0, atol=1e-12
    )
    np.testing.assert_array_equal(chunked.reachable, one.reachable)


def test_no_batch_holds_more_than_a_chunk(monkeypatch):
    """With chunks of 7 targets and 4 starts, no IK batch exceeds 28
    problems (one batch of 30 targets would hold 120)."""
    model, p, R = _targets(30)
    sizes: list[int] = []
    solve = correction.correct_targets

    def spy(model, targets, **kw):
        sizes.append(len(targets))
        return solve(model, targets, **kw)

    monkeypatch.setattr(correction, "CHUNK_TARGETS", 7)
    monkeypatch.setattr(correction, "correct_targets", spy)
    inverse_kinematics(model, p, orientation=R, starts=4)
    assert sum(sizes) == 4 * 30 and max(sizes) <= 4 * 7, sizes
