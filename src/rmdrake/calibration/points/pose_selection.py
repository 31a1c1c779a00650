"""Greedy D-optimal choice of tracker poses from a pool: the point twin of
:func:`rmdrake.calibration.plates.pose_selection.select_d_optimal`.

The criterion is the plates' one, with a pose's block of rows in place of a
reading's row: the information matrix of the residuals over every MDH error
parameter (the ``full`` preset) and the nuisance unknowns (here the instrument
pose and the markers), columns scaled to unit norm over the pool, starts from
``regularisation`` x identity, and each step adds the candidate of largest gain
log det(I + B M^-1 B^T) (B the candidate's rows; one row on a plate, where the
gain is log(1 + j^T M^-1 j), three rows per marker at a tracker pose), updating
M^-1 by the Woodbury identity
(:func:`~rmdrake.calibration.d_optimal.greedy_d_optimal`).
:func:`select_d_optimal_poses` builds the blocks of tracker poses from
:class:`~rmdrake.calibration.points.problem.PointProblem`.
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.d_optimal import greedy_d_optimal
from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.problem import PointProblem, predict_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.robot import RobotModel

__all__ = ["select_d_optimal_poses"]


def select_d_optimal_poses(
    model: RobotModel,
    q_pool: np.ndarray,
    markers: np.ndarray,
    count: int,
    *,
    regularisation: float = 1e-6,
) -> np.ndarray:
    """Greedy D-optimal choice of ``count`` tracker poses from a pool.

    The blocks are the rows of every marker at a pose in the point residuals
    (:class:`~rmdrake.calibration.points.problem.PointProblem`) over every MDH
    error parameter (the ``full`` preset), the instrument pose and the
    markers, at ``model`` with the instrument at the base frame (R_IB = I,
    p_IB = 0: the criterion does not depend on the instrument's pose but
    through the column scaling) and the markers where they are mounted, in E
    (an experimenter knows them to a few mm, enough to plan); columns scaled
    to unit norm over the pool
    (:func:`~rmdrake.calibration.d_optimal.greedy_d_optimal`).

    Args:
      model: the planning robot (the nominal, as on a real robot).
      q_pool: (C, n) candidate joint positions (encoder side), rad or m.
      markers: (M, 3) markers in E, m.
      count: poses to keep, at most C.

    Returns:
      (count,) indices into ``q_pool``, ascending.
    """
    q_pool = np.asarray(q_pool, dtype=np.float64)
    p_EM = np.asarray(markers, dtype=np.float64).reshape(-1, 3)
    C, M = q_pool.shape[0], p_EM.shape[0]
    pose = np.repeat(np.arange(C), M)
    marker = np.tile(np.arange(M), C)
    p_I = predict_points(
        model.table,
        q_pool[pose],
        p_EM[marker],
        np.eye(3),
        np.zeros(3),
        sigma=model.sigma,
    )
    data = PointMeasurements(pose, marker + 1, q_pool[pose], p_I)
    idx = error_parameter_indices(model, error_parameter_names(model, "full"))
    problem = PointProblem(model.table, data, idx, np.eye(3), sigma=model.sigma)
    J = problem.jacobian(problem.pack(np.zeros(idx.size), np.zeros(3), p_EM))
    norms = np.linalg.norm(J, axis=0)
    J /= np.where(norms > 0, norms, 1.0)  # in place: J is the pool's size
    blocks = J.reshape(C, 3 * M, J.shape[1])  # rows: pose-major, then marker, xyz
    return greedy_d_optimal(blocks, count, regularisation=regularisation)
