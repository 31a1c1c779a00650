"""Which error parameters can 6-DoF pose readings identify?

The procedure of :mod:`rmdrake.calibration.identifiability` (columns scaled
to unit norm, the nuisance columns projected out, a greedy twice-orthogonalised
pass in the MDH preference order, the SVD for the unidentifiable
combinations) on the weighted pose residuals
(:class:`~rmdrake.calibration.poses.problem.PoseProblem`), whose nuisance
unknowns are the instrument pose X_IB and the marker pose X_FM (12). What a
fixed change of the base frame does is absorbed by X_IB: every entry of the
first row (``dalpha1 dd1 dtheta1 dr1 dbeta1``: the first joint's offset
turns about z_1 before q_1, which commutes with it); what a fixed change of
the flange frame does is absorbed by X_FM: every entry of the tool row n+1,
and the last joint's ``dtheta<n>``, ``dr<n>`` (they commute with its turn),
and where the geometry allows more of row n (``dbeta6`` on the RV-3SB).
Parameters that act alike elsewhere (parallel axes) keep the earlier one in
the preference order. A 6-DoF pose sees 4 R + 2 P + 6 parameters of a chain
with R revolute and P prismatic joints; less the 12 of X_IB and X_FM that
leaves 4 R + 2 P - 6 error parameters (18 on a 6R arm).

Example::

    from rmdrake.calibration.poses.identifiability import (
        analyse_pose_identifiability)
    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.error_parameters import error_parameter_names
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    data = simulate_poses(model, poses=30, noise_p=0, noise_r=0).data
    report = analyse_pose_identifiability(
        model, data, error_parameter_names(model, "full"))
    print(report.summary())
"""

from __future__ import annotations

import numpy as np

from rmdrake.calibration.identifiability import IdentifiabilityReport, analyse_columns
from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.problem import PoseProblem, initial_alignment
from rmdrake.model.error_parameters import error_parameter_indices
from rmdrake.model.robot import RobotModel

__all__ = ["analyse_pose_identifiability"]


def analyse_pose_identifiability(
    model: RobotModel,
    data: PoseMeasurements,
    names: list[str],
    *,
    rtol: float = 1e-6,
    start: tuple[np.ndarray, np.ndarray] | None = None,
    deltas: np.ndarray | None = None,
    sigma_p: float = 1e-5,
    sigma_r: float = 1e-5,
) -> IdentifiabilityReport:
    """Identifiability of MDH error parameters from 6-DoF readings (see the
    module docstring), at ``model`` plus ``deltas`` (default the nominal) with
    ``start`` = (X_IB, X_FM) (default: the hand-eye
    :func:`~rmdrake.calibration.poses.problem.initial_alignment`); rows
    weighted by ``sigma_p`` (m) and ``sigma_r`` (rad).

    Raises:
      ValueError: an unknown name, a compliance ``c<j>`` (rigid joints only).

    >>> from rmdrake.model.loading import load_robot
    >>> from rmdrake.calibration.poses.simulate import simulate_poses
    >>> model = load_robot("rv3sb")
    >>> sim = simulate_poses(model, poses=20, seed=1)
    >>> report = analyse_pose_identifiability(model, sim.data, ["dtheta1", "dtheta2"])
    >>> report.identifiable  # the base pose X_IB absorbs joint 1's offset
    ['dtheta2']
    """
    idx = error_parameter_indices(model, names)
    X_IB, X_FM = start or initial_alignment(model.table, data, sigma=model.sigma)
    problem = PoseProblem(
        model.table,
        data,
        idx,
        X_IB[:3, :3],
        X_FM[:3, :3],
        sigma_p=sigma_p,
        sigma_r=sigma_r,
        sigma=model.sigma,
    )
    d = np.zeros(idx.size) if deltas is None else np.asarray(deltas, float)
    J = problem.jacobian(problem.pack(d, X_IB[:3, 3], X_FM[:3, 3]))
    return analyse_columns(J, list(names), idx, rtol, "instrument")
