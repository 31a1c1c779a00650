"""Which error parameters can measured tool points identify? The Jacobian of
the 3-D point residuals (m), the instrument pose and the markers projected
out (:mod:`rmdrake.calibration.identifiability` explains the procedure).

Example::

    report = analyse_point_identifiability(model, data, ["dr1", "dtheta2"])
    report.identifiable
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.identifiability import (
    Candidates,
    IdentifiabilityReport,
    analyse_columns,
)
from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.problem import PointProblem, initial_alignment
from rmdrake.model.robot import RobotModel

__all__ = ["analyse_point_identifiability"]


def analyse_point_identifiability(
    model: RobotModel,
    data: PointMeasurements,
    names: list[str],
    *,
    rtol: float = 1e-6,
    start: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    deltas: np.ndarray | None = None,
) -> IdentifiabilityReport:
    """Identifiability of error parameters from measured tool points.

    The nuisance unknowns are the instrument pose X_IB (6) and the markers
    p_EM (3 per marker): they are projected out first, so what a base-frame
    change (the first joint's offset against the base yaw, for instance) or a
    tool-frame change (the last joint's offset against the markers) does is
    absorbed and dropped; then the greedy pass in the MDH preference order.
    Evaluated at ``model`` plus ``deltas`` (default the nominal; compliances
    ``c<j>`` among the names as in :func:`~rmdrake.calibration.plates.
    identifiability.analyse_identifiability`: listed last, the Jacobian at
    the link angles under the points' payloads) with
    ``start`` = (R_IB, p_IB, markers) (default: those of
    :func:`~rmdrake.calibration.points.problem.initial_alignment`).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import analyse_point_identifiability, simulate_points
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=12, seed=0).data
    >>> names = ["dtheta1", "dtheta2", "dtheta3"]
    >>> analyse_point_identifiability(robot, data, names).identifiable
    ['dtheta2', 'dtheta3']
    """
    at = Candidates(model, data, names, deltas)
    R, p, markers = start or initial_alignment(model.table, data, sigma=model.sigma)
    problem = PointProblem(
        model.table, data, at.idx, R, sigma=model.sigma, **at.options
    )
    J = problem.jacobian(problem.pack(at.deltas, p, markers))
    return analyse_columns(J, at.names, at.order, rtol, "instrument", groups=at.groups)
