"""What the kinds' simulations share: the largest plausible noise
(:data:`MAX_NOISE_SHARE`), joint positions uniform within the limits
(:func:`random_poses`, rad or m) and poses away from singularities
(:func:`random_point_poses`: in the middle 80 % of every joint range, the 6 x n
tool Jacobian, linear rows divided by the robot's reach so rad and m compare,
with its smallest singular value above ``min_singular`` times its largest,
:func:`well_conditioned`; with a cell, ``clearance`` m from it).

Example::

    q = random_point_poses(model, 20, np.random.default_rng(0))  # (20, n)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rmdrake.kinematics.forward import pose_chunks, robot_reach, tool_jacobian
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.kinematics.clearance import ClearanceChecker

__all__ = [
    "MAX_NOISE_SHARE",
    "random_point_poses",
    "random_poses",
    "well_conditioned",
]

MAX_NOISE_SHARE = 0.1
"""The largest reading noise std (simulated range finder or tracker), as a
share of what it perturbs: the range finder's span, the robot's reach. A
larger one writes readings no instrument gives (a noise of 1 m on a 5-80 mm
range finder gave distances of -2 to 2 m)."""


def random_poses(model: RobotModel, n: int, seed: int) -> np.ndarray:
    """(n, n_joints) joint positions uniform within the limits (rad or m),
    seeded.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import random_poses
    >>> random_poses(load_robot("rv3sb"), 4, seed=0).shape
    (4, 6)
    """
    rng = np.random.default_rng(seed)
    return rng.uniform(model.limits.lower, model.limits.upper, (n, model.n_joints))


def well_conditioned(
    model: RobotModel, q: np.ndarray, reach: float, min_singular: float
) -> np.ndarray:
    """(N,) whether the tool Jacobian at q (N, n), its linear rows divided by
    ``reach`` (m) and prismatic columns times it, has its 6th singular value
    (the last when fewer joints) above ``min_singular`` times its first."""
    J = tool_jacobian(model.table, q, sigma=model.sigma)
    J[:, 3:] /= reach
    J[:, :, model.sigma == 1] *= reach
    sv = np.linalg.svd(J, compute_uv=False)
    return sv[:, min(5, sv.shape[1] - 1)] > min_singular * sv[:, 0]


def random_point_poses(
    model: RobotModel,
    count: int,
    rng: np.random.Generator,
    *,
    min_singular: float = 0.05,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
) -> np.ndarray:
    """(count, n) joint positions in the middle 80 % of the limits whose scaled
    tool Jacobian has singular values above ``min_singular`` times the largest
    and, with a ``checker``, that keep ``clearance``
    (m) from its cell."""
    lo, hi = model.limits.lower, model.limits.upper
    lo, hi = lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo)
    reach = robot_reach(model)
    kept = np.zeros((0, model.n_joints))
    for _ in range(100):
        q = rng.uniform(lo, hi, (2 * count, model.n_joints))
        good = np.concatenate(  # chunk by chunk: the (6, n) Jacobians are large
            [
                well_conditioned(model, q[rows], reach, min_singular)
                for rows in pose_chunks(1, q.shape[0])
            ]
        )
        if checker is not None:
            good[good] = checker.clear(q[good], clearance)
        kept = np.concatenate([kept, q[good]])
        if kept.shape[0] >= count:
            return kept[:count]
    raise ValueError(f"could not draw {count} poses away from singularities")
