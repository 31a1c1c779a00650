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

Lazy evaluation (Minoux's accelerated greedy): M only grows, so M^-1 only
shrinks and every candidate's gain only falls from step to step (log det is
submodular). A gain computed at an earlier step is therefore an upper bound
of the current one: the candidates wait in a heap by their last gain, and a
step re-evaluates (in blocks of :data:`CHUNK_CANDIDATES`) only those whose
bound is on top, until the top one is current. It is then the largest gain of
all, the same choice as evaluating every candidate (ties to the first
candidate), at a cost of about C log C + the steps times a few blocks instead
of C times the steps, so a pool of millions of candidates stays tractable.
"""

from __future__ import annotations

import heapq

import numpy as np

from rmdrake.kinematics.forward import chunk_slices

__all__ = ["CHUNK_CANDIDATES", "greedy_d_optimal"]

CHUNK_CANDIDATES = 4_096
"""Most candidates whose gains are evaluated in one batch (the first gains
of all the candidates are computed chunk by chunk; a lazy re-evaluation takes
at most this many from the top of the heap)."""


def _heap_keys(gain: np.ndarray, index: np.ndarray) -> list[int]:
    """Heap keys of candidates ``index`` (K,) with gains (K,): ints that sort
    by decreasing gain, then increasing index (the float's bits mapped to an
    order-preserving unsigned int, complemented, with the index below: one int
    compares faster than a (gain, index) tuple)."""
    bits = np.ascontiguousarray(gain, dtype=np.float64).view(np.uint64)
    negative = (bits >> np.uint64(63)).astype(bool)
    ordered = np.where(negative, ~bits, bits | np.uint64(1 << 63))
    return [
        (k << 32) | i
        for k, i in zip((~ordered).tolist(), np.asarray(index).tolist(), strict=True)
    ]


def _gains(B: np.ndarray, Minv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(gains (K,), B M^-1 (K, r, u)) of the candidate blocks B (K, r, u)."""
    K, r, u = B.shape
    BM = (B.reshape(K * r, u) @ Minv).reshape(K, r, u)
    G = BM @ B.transpose(0, 2, 1)  # (K, r, r): B_c M^-1 B_c^T
    if r == 1:
        return np.log1p(G[:, 0, 0]), BM
    return np.linalg.slogdet(np.eye(r) + G)[1], BM


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
    full = [False] * per_group.size  # a group at its quota
    taken = [0] * per_group.size
    group_of = label.tolist()
    at = [0] * C  # the step of each candidate's gain
    heap: list[int] = []  # _heap_keys: the largest gain, then the first index
    for rows in chunk_slices(C, CHUNK_CANDIDATES):
        heap += _heap_keys(_gains(B[rows], Minv)[0], np.arange(C)[rows])
    heapq.heapify(heap)
    low = (1 << 32) - 1
    for step in range(count):
        block = 1  # stale candidates re-evaluated at once, doubling
        while True:
            while full[group_of[heap[0] & low]]:  # never again
                heapq.heappop(heap)
            i = heap[0] & low
            if at[i] == step:  # current, and above every other bound
                break
            stale: list[int] = []
            while heap and len(stale) < block:
                j = heap[0] & low
                if full[group_of[j]]:
                    heapq.heappop(heap)
                    continue
                if at[j] == step:
                    break
                stale.append(j)
                heapq.heappop(heap)
            idx = np.array(stale, dtype=np.intp)
            for key in _heap_keys(_gains(B[idx], Minv)[0], idx):
                heapq.heappush(heap, key)
            for j in stale:
                at[j] = step
            block = min(2 * block, CHUNK_CANDIDATES)
        heapq.heappop(heap)
        chosen[i] = True
        g = group_of[i]
        taken[g] += 1
        full[g] = taken[g] >= limit
        BM = _gains(B[i : i + 1], Minv)[1]
        S = np.eye(r) + BM[0] @ B[i].T
        Minv -= BM[0].T @ np.linalg.solve(S, BM[0])
    return np.flatnonzero(chosen)
