"""Pose accuracy and repeatability in the manner of ISO 9283.

Test points: a cube in the working space; P1 at its centre and P2..P5 on the
diagonal plane through two opposite edges (the rectangle whose corners are the
cube vertices c +- (L/2) e1 +- (L/2)(e2 + e3)), each 10 % of that rectangle's
diagonal away from a corner along the diagonal, i.e. P = c + 0.8 (corner - c).
The robot approaches each point ``cycles`` times (in the standard, 30), from the
same direction within a cycle.

For one point with commanded position p_c and attained positions p_j
(j = 1..m, m cycles):

* pose accuracy AP = |mean_j p_j - p_c|, the distance from the barycentre of
  the attained positions to the command;
* pose repeatability RP = mean_j l_j + 3 S_l with l_j = |p_j - mean p| and S_l
  the sample standard deviation of the l_j (m - 1 in the denominator).

All positions in m, in the robot's base frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.arrays import as_finite_array

__all__ = ["PoseAccuracy", "cube_test_points", "pose_accuracy"]


def cube_test_points(
    center: object, side: float, R_BC: object | None = None
) -> np.ndarray:
    """The five ISO 9283 test points P1..P5 of a cube, (5, 3) in m.

    Args:
      center: (3,) cube centre in the base frame B, m.
      side: edge length L, m (> 0).
      R_BC: (3, 3) rotation of the cube's edge directions e1, e2, e3 (its
        columns) in B; default the base axes.
    """
    c = as_finite_array(center, "center", (3,))
    if not np.isfinite(side) or side <= 0:
        raise ValueError(f"side: expected a positive length in m, found {side}")
    R = np.eye(3) if R_BC is None else as_finite_array(R_BC, "R_BC", (3, 3))
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-9):
        raise ValueError("R_BC: expected a rotation matrix (orthonormal columns)")
    e1, e2, e3 = R.T
    half = 0.5 * side
    corners = [
        c + s1 * half * e1 + s2 * half * (e2 + e3) for s1, s2 in ((1, 1), (1, -1))
    ]
    corners += [2 * c - corners[0], 2 * c - corners[1]]  # the opposite corners
    return np.vstack([c, *(c + 0.8 * (k - c) for k in corners)])


@dataclasses.dataclass(frozen=True)
class PoseAccuracy:
    """ISO 9283 figures per test point (see the module docstring).

    Attributes:
      AP: (P,) pose accuracy, m.
      RP: (P,) pose repeatability, m.
      barycentre: (P, 3) mean attained position, m.
      errors: (P, m) distance of each attained position to its command, m.
    """

    AP: np.ndarray
    RP: np.ndarray
    barycentre: np.ndarray
    errors: np.ndarray


def pose_accuracy(commanded: object, attained: object) -> PoseAccuracy:
    """AP and RP of attained positions (P, m, 3) against commands (P, 3), m.

    Raises:
      ValueError: shapes that do not match, fewer than 2 cycles, NaN.
    """
    p_c = as_finite_array(commanded, "commanded", (None, 3))
    p = as_finite_array(attained, "attained", (p_c.shape[0], None, 3))
    if p.shape[1] < 2:
        raise ValueError(
            f"attained: expected at least 2 cycles per point, found {p.shape[1]}"
        )
    bary = p.mean(axis=1)
    l = np.linalg.norm(p - bary[:, None, :], axis=2)
    return PoseAccuracy(
        AP=np.linalg.norm(bary - p_c, axis=1),
        RP=l.mean(axis=1) + 3.0 * l.std(axis=1, ddof=1),
        barycentre=bary,
        errors=np.linalg.norm(p - p_c[:, None, :], axis=2),
    )
