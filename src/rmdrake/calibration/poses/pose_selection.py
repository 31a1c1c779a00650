"""Greedy D-optimal choice of robot poses for 6-DoF measurements: the pose
twin of :func:`rmdrake.calibration.points.pose_selection.select_d_optimal_poses`.

The blocks are the six weighted rows (position / sigma_p, orientation /
sigma_r) of each candidate pose in the pose residuals
(:class:`~rmdrake.calibration.poses.problem.PoseProblem`) over every MDH error
parameter (the ``full`` preset) and the nuisance unknowns X_IB and X_FM,
columns scaled to unit norm over the pool; each step adds the candidate of
largest gain log det(I + B M^-1 B^T)
(:func:`~rmdrake.calibration.d_optimal.greedy_d_optimal`).

Example::

    import numpy as np
    from rmdrake.calibration.poses.pose_selection import select_d_optimal_poses
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    q = np.random.default_rng(0).uniform(-1, 1, (40, 6))
    kept = select_d_optimal_poses(model, q, np.eye(4), 10)
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.d_optimal import greedy_d_optimal
from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.problem import PoseProblem, predict_poses
from rmdrake.calibration.poses.so3 import so3_log_many
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.robot import RobotModel

__all__ = ["select_d_optimal_poses"]


def select_d_optimal_poses(
    model: RobotModel,
    q_pool: np.ndarray,
    X_FM: np.ndarray,
    count: int,
    *,
    sigma_p: float = 1e-5,
    sigma_r: float = 1e-5,
    regularisation: float = 1e-6,
) -> np.ndarray:
    """Greedy D-optimal choice of ``count`` poses from a pool (see the module
    docstring), at ``model`` with the instrument at the base frame (X_IB = I:
    the criterion does not depend on it but through the column scaling) and
    the marker at ``X_FM`` (4, 4) in F (known to a few mm, enough to plan).

    Args:
      model: the planning robot (the nominal, as on a real robot).
      q_pool: (C, n) candidate joint positions, rad or m.
      X_FM: (4, 4) marker pose in the flange F, m.
      count: poses to keep, at most C.
      sigma_p, sigma_r: the noises (m, rad) weighting the rows.

    Returns:
      (count,) indices into ``q_pool``, ascending.
    """
    q_pool = np.asarray(q_pool, dtype=np.float64)
    X_FM = np.asarray(X_FM, dtype=np.float64)
    C = q_pool.shape[0]
    X = predict_poses(model.table, q_pool, np.eye(4), X_FM, sigma=model.sigma)
    data = PoseMeasurements(q_pool, X[:, :3, 3], so3_log_many(X[:, :3, :3]))
    idx = error_parameter_indices(model, error_parameter_names(model, "full"))
    problem = PoseProblem(
        model.table,
        data,
        idx,
        np.eye(3),
        X_FM[:3, :3],
        sigma_p=sigma_p,
        sigma_r=sigma_r,
        sigma=model.sigma,
    )
    J = problem.jacobian(problem.pack(np.zeros(idx.size), np.zeros(3), X_FM[:3, 3]))
    norms = np.linalg.norm(J, axis=0)
    J /= np.where(norms > 0, norms, 1.0)  # in place: J is the pool's size
    return greedy_d_optimal(
        J.reshape(C, 6, J.shape[1]), count, regularisation=regularisation
    )
