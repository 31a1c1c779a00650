"""Which error parameters can the plate readings identify? The Jacobian of
the signed point-to-plane residuals (m) at the measured poses, the plate
unknowns projected out (:mod:`rmdrake.calibration.identifiability` explains
the procedure).

Example::

    report = analyse_identifiability(model, data, error_parameter_names(model, "full"))
    report.identifiable  # the kept names, in the preference order
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.identifiability import (
    Candidates,
    IdentifiabilityReport,
    analyse_columns,
)
from rmdrake.calibration.plates.cost import PlaneProblem, fit_planes
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.robot import RobotModel
from rmdrake.progress import progress_bar

__all__ = ["analyse_identifiability"]


def analyse_identifiability(
    model: RobotModel,
    data: PlaneMeasurements,
    names: list[str],
    *,
    deltas: np.ndarray | None = None,
    rtol: float = 1e-6,
) -> IdentifiabilityReport:
    """Identifiability of error parameters from plane readings.

    The Jacobian is evaluated at ``model`` plus ``deltas`` (default: the
    nominal) with each plate's normal and offset from an SVD plane fit of the
    predicted points. The kept set follows the preference order of the module
    docstring: the same for any order of ``names``.

    Args:
      model: the robot.
      data: the readings (their poses and plate ids).
      names: candidate error parameters (e.g. ``error_parameter_names(model,
        "full")``), compliances ``c<j>`` among them (the report lists the MDH
        names first, then the compliances).
      deltas: (k,) values of the candidates at which to evaluate, rad or m
        (compliances in rad/(N m) or m/N; default the nominal's, 0 if rigid),
        in the report's order. With elastic joints the Jacobian is taken at
        the link angles of these values, with the readings' payloads
        (:class:`~rmdrake.calibration.elastostatic.JointLoads`).
      rtol: threshold on a unit column's residual for it to be kept.

    Raises:
      ValueError: unknown parameter names.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import analyse_identifiability, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, seed=0).data
    >>> report = analyse_identifiability(robot, data, ["dtheta1", "dtheta2", "dtheta3"])
    >>> report.identifiable, sorted(report.dropped)
    (['dtheta2', 'dtheta3'], ['dtheta1'])
    """
    # 15 s on 200 000 readings: a lazy bar over its three steps shows them
    # when the process has been silent for the progress interval.
    bar = progress_bar(total=3, desc="identifiability (steps)", lazy=True)
    try:
        at = Candidates(model, data, names, deltas)
        P = int(data.plate_ids.size)
        table = model.table.ravel().copy()
        table[at.idx] += at.deltas[: at.idx.size]
        table = table.reshape(model.table.shape)
        q = at.loads.link_angles(at.deltas, at.torques)
        points = tool_points(table, q, data.distance, sigma=model.sigma)
        normals, offsets = fit_planes(points, data.plate_index, P)
        bar.update(1)
        problem = PlaneProblem(
            model.table, data, at.idx, normals, sigma=model.sigma, **at.options
        )
        J = problem.jacobian(problem.pack(at.deltas, offsets))
        bar.update(1)
        out = analyse_columns(J, at.names, at.order, rtol, "plate", groups=at.groups)
        bar.update(1)
    finally:
        bar.close()
    return out
