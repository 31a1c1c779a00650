"""Greedy D-optimal choice of calibration poses from a pool of valid readings.

Of many valid readings a careful experimenter keeps those that spread the
information on the error parameters: here, greedily, the reading that most
increases log det of the information matrix of the point-to-plane residuals.
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.d_optimal import greedy_d_optimal
from rmdrake.calibration.plates.cost import PlaneProblem
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.robot import RobotModel

__all__ = ["select_d_optimal"]


def select_d_optimal(
    model: RobotModel,
    pool: PlaneMeasurements,
    normals: list[np.ndarray],
    per_plate: int,
    *,
    regularisation: float = 1e-6,
) -> np.ndarray:
    """Greedy D-optimal choice of ``per_plate`` readings per plate from a pool.

    The information matrix is that of the signed point-to-plane residuals
    (:class:`~rmdrake.calibration.plates.cost.PlaneProblem`) over every MDH error
    parameter (the ``full`` preset) and the plate unknowns, at ``model`` with
    the given plate normals, columns scaled to unit norm over the pool. Starting
    from ``regularisation`` x identity, each step adds the reading with the
    largest gain log(1 + j^T M^-1 j) among plates not yet full
    (:func:`~rmdrake.calibration.d_optimal.greedy_d_optimal`). Deterministic.

    Returns:
      Indices into the pool, grouped by plate in increasing order, each group in
      the pool's order.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import select_d_optimal, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> sim = simulate_plates(robot, plates=3, per_plate=10, seed=0)
    >>> normals = [p.X_BP[:3, 2] for p in sim.plates]
    >>> select_d_optimal(robot, sim.data, normals, per_plate=4).shape
    (12,)
    """
    idx = error_parameter_indices(model, error_parameter_names(model, "full"))
    problem = PlaneProblem(model.table, pool, idx, np.array(normals), sigma=model.sigma)
    pts = tool_points(model.table, pool.q, pool.distance, sigma=model.sigma)
    n = np.array(normals)
    offsets = np.array(
        [np.mean(pts[pool.plate_index == p] @ n[p]) for p in range(len(n))]
    )
    J = problem.jacobian(problem.pack(np.zeros(idx.size), offsets))
    norms = np.linalg.norm(J, axis=0)
    J /= np.where(norms > 0, norms, 1.0)  # in place: J is the pool's size
    plate = pool.plate_index
    chosen = greedy_d_optimal(
        J[:, None, :],
        per_plate * len(normals),
        group=plate,
        quota=per_plate,
        regularisation=regularisation,
    )
    return np.concatenate([chosen[plate[chosen] == p] for p in range(len(normals))])
