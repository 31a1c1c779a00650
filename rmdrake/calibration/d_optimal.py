"""Greedy D-optimal choice of measurements from a pool of candidates: the one
criterion behind the plates' readings
(:func:`~rmdrake.calibration.plates.pose_selection.select_d_optimal`) and the
tracker's poses
(:func:`~rmdrake.calibration.points.pose_selection.select_d_optimal_poses`).

Each candidate is a block of residual rows over the unknowns (one row for a
range reading on a plate, three per marker for a tracker pose). Starting from
``regularisation`` x identity, each step adds the candidate of largest gain
log det(I + B M^-1 B^T) of the information matrix M (log(1 + j^T M^-1 j) for
one row), updating M^-1 by the Woodbury identity.
"""

from __future__ import annotations

import numpy as np

__all__ = ["greedy_d_optimal"]


def greedy_d_optimal(
    blocks: np.ndarray,
    count: int,
    *,
    group: np.ndarray | None = None,
    quota: int | None = None,
    regularisation: float = 1e-6,
) -> np.ndarray:
    """Greedy D-optimal choice of ``count`` candidates (see the module
    docstring). Deterministic: the first candidate on a tie.

    Args:
      blocks: (C, r, u) the rows of each candidate's residuals over the u
        unknowns (already scaled: the caller scales the columns).
      count: candidates to choose (at most C).
      group, quota: (C,) a group per candidate and the most chosen per group
        (the plates: ``per_plate`` readings per plate); None: no groups.
      regularisation: the information matrix's start, times identity.

    Returns:
      (count,) indices of the chosen candidates, ascending.

    Raises:
      ValueError: ``count`` above the candidates the quotas allow.
    """
    B = np.asarray(blocks, dtype=np.float64)
    C, r, u = B.shape
    groups = np.zeros(C, dtype=np.intp) if group is None else np.asarray(group)
    limit = C if quota is None else int(quota)
    _, label, per_group = np.unique(groups, return_inverse=True, return_counts=True)
    if count > int(np.minimum(per_group, limit).sum()):
        raise ValueError(
            f"D-optimal choice: {count} candidates asked, at most "
            f"{int(np.minimum(per_group, limit).sum())} available"
        )
    Minv = np.eye(u) / regularisation
    chosen = np.zeros(C, dtype=bool)
    taken = np.zeros(per_group.size, dtype=np.intp)
    for _ in range(count):
        BM = (B.reshape(C * r, u) @ Minv).reshape(C, r, u)
        G = BM @ B.transpose(0, 2, 1)  # (C, r, r): B_c M^-1 B_c^T
        if r == 1:
            gain = np.log1p(G[:, 0, 0])
        else:
            gain = np.linalg.slogdet(np.eye(r) + G)[1]
        gain[chosen | (taken[label] >= limit)] = -np.inf
        i = int(np.argmax(gain))
        chosen[i] = True
        taken[label[i]] += 1
        S = np.eye(r) + G[i]
        Minv -= BM[i].T @ np.linalg.solve(S, BM[i])
    return np.flatnonzero(chosen)
