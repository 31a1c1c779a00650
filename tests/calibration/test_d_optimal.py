"""The greedy D-optimal step shared by plates and tracker poses, against a
direct oracle: at each step the candidate that most increases log det of the
information matrix, computed from the matrices themselves (no Woodbury
update), among the groups not yet at their quota."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.d_optimal import greedy_d_optimal


def _oracle(B, count, group, quota, regularisation):
    u = B.shape[2]
    M = regularisation * np.eye(u)
    chosen: list[int] = []
    for _ in range(count):
        best, best_gain = -1, -np.inf
        for c in range(B.shape[0]):
            taken = sum(group[k] == group[c] for k in chosen)
            if c in chosen or taken >= quota:
                continue
            gain = np.linalg.slogdet(M + B[c].T @ B[c])[1]
            if gain > best_gain + 1e-9:
                best, best_gain = c, gain
        chosen.append(best)
        M = M + B[best].T @ B[best]
    return sorted(chosen)


@pytest.mark.parametrize("rows", [1, 3])
def test_greedy_choice_is_the_direct_log_det_choice(rows):
    rng = np.random.default_rng(rows)
    B = rng.standard_normal((30, rows, 6))
    group = rng.integers(0, 4, 30)
    ours = greedy_d_optimal(B, 9, group=group, quota=3, regularisation=1e-3)
    assert list(ours) == _oracle(B, 9, group, 3, 1e-3)
    assert np.all(np.bincount(group[ours]) <= 3)


def test_more_candidates_than_the_quotas_allow_is_refused():
    B = np.ones((4, 1, 2))
    with pytest.raises(ValueError, match="at most 2 available"):
        greedy_d_optimal(B, 3, group=np.array([0, 0, 1, 1]), quota=1)
