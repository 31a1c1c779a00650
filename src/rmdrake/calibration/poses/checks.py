"""What a pose calibration accepts, before and after its fit.

Before (:func:`check_pose_measurements`): the content of a pose file (the
reader checks the format): the joint count, joint values in rad (m on a
slide) within the robot's limits' reach, positions within
:data:`~rmdrake.calibration.points.checks.MAX_INSTRUMENT_RANGE` of the
instrument.

After (:func:`check_pose_calibration`): is the fit believable? Degrees of
freedom, full rank of the Jacobian at the solution, corrections within
:class:`~rmdrake.calibration.sanity.CalibrationBounds`, the marker within
:data:`~rmdrake.calibration.points.checks.MAX_MARKER` of the flange, and the
residual against the declared noises: the RMS of the weighted residuals
(position / sigma_p, angle / sigma_r) over the degrees of freedom is about 1
when the noises are right; above ``noise_ratio`` it is a warning, above
``refuse_ratio`` a refusal, far below 1 (a tenth) a refusal too (an exact fit
of noisy readings). With estimated noises the ratio is 1 by construction and
only the position scatter is bounded (by
:data:`~rmdrake.calibration.points.checks.POINT_MAX_NOISE`). Outlying rows:
externally studentized residuals beyond ``min_z`` (one line naming them).

Example::

    from rmdrake.calibration.poses.checks import check_pose_measurements
    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    check_pose_measurements(simulate_poses(model, poses=10).data, model)
"""

from __future__ import annotations

import math

import numpy as np

from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.problem import PoseProblem
from rmdrake.calibration.sanity import (
    MAX_INSTRUMENT_RANGE,
    MAX_MARKER,
    POINT_MAX_NOISE,
    CalibrationBounds,
    SanityReport,
    check_joint_values,
    degenerate_reason,
    out_of_bounds_reason,
    studentized_residuals,
)
from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.robot import RobotModel

__all__ = ["check_pose_calibration", "check_pose_measurements"]


def check_pose_measurements(data: PoseMeasurements, model: RobotModel) -> list[str]:
    """Checks the content of pose readings against ``model``; returns the
    warnings (joint values outside the limits).

    Raises:
      ValueError: one line: another joint count, joint values in another
        unit, a position farther than ``MAX_INSTRUMENT_RANGE`` from I.
    """
    if data.n_joints != model.n_joints:
        raise ValueError(
            f"pose measurements: {data.n_joints} joint columns, but robot "
            f"'{model.name}' has {model.n_joints} joints"
        )
    warnings = check_joint_values(
        data.q, model.limits.lower, model.limits.upper, model.sigma
    )
    far = np.flatnonzero(np.linalg.norm(data.p_IM, axis=1) > MAX_INSTRUMENT_RANGE)
    if far.size:
        raise ValueError(
            f"pose measurements: row {far[0] + 1}: position "
            f"{np.linalg.norm(data.p_IM[far[0]]):.4g} from the instrument, beyond "
            f"{MAX_INSTRUMENT_RANGE:g} m: positions are in m"
        )
    return warnings


def check_pose_calibration(
    problem: PoseProblem,
    x: np.ndarray,
    names: list[str],
    *,
    declared: bool,
    source: str | None = None,
    bounds: CalibrationBounds | None = None,
) -> SanityReport:
    """Runs the checks of the module docstring on one pose fit (``problem``
    weighted by the noises, declared or estimated; ``x`` its solution; the
    first ``len(names)`` entries the error parameters; ``declared``: a noise
    was declared, ``source`` says which, default ``declared`` or
    ``estimated``). The report's noise and residual are the position ones
    (m): sigma_p and sigma_p times the weighted RMS."""
    b = bounds or CalibrationBounds()
    r = problem.residuals(x)
    J = problem.jacobian(x)
    reasons: list[str] = []
    warnings: list[str] = []
    k, u = len(names), problem.n_unknowns
    dof = r.size - u
    s = math.sqrt(float(r @ r) / dof) if dof > 0 else 0.0
    if dof < b.min_dof:
        reasons.append(
            f"only {dof} degrees of freedom ({r.size} residuals - {k} parameters - "
            f"12 instrument and marker unknowns), at least {b.min_dof} needed to "
            "check the fit: measure more poses or calibrate fewer parameters"
        )
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    U, sv, vt = np.linalg.svd(J / norms, full_matrices=False)
    collapsed = degenerate_reason(sv, vt, names, b.rtol)
    if collapsed:
        collapsed = collapsed.replace("planes fit", "poses fit")
    length = b.length + b.length_fraction * robot_reach(problem.table)
    beyond = out_of_bounds_reason(names, x[:k], length, b.angle)
    p_FM = problem.unpack(x)[2][:3, 3]
    e_p, e_r = problem.errors(x)
    rms_p = float(np.sqrt(np.mean(e_p**2)))
    rms_r = float(np.sqrt(np.mean(e_r**2)))
    full = sv > b.rtol * sv[0]
    _, z = studentized_residuals(r, U, full, dof, 1e-12)
    rows = np.flatnonzero((np.abs(z) > b.min_z).reshape(-1, 6).any(axis=1))
    if rms_p > POINT_MAX_NOISE:
        reasons.append(
            f"the positions scatter {rms_p * 1e3:.4g} mm about the fitted model, "
            f"beyond {POINT_MAX_NOISE * 1e3:g} mm: coordinates not in m, rotation "
            "vectors not in rad, or readings not of this robot"
        )
    elif rows.size:
        listed = ", ".join(str(int(i) + 1) for i in rows[:6])
        more = f" and {rows.size - 6} more" if rows.size > 6 else ""
        reasons.append(
            f"outlying row(s) {listed}{more}: standardized residual over "
            f"{b.min_z:g}: a bad reading or a marker seen wrong"
        )
    what = (
        f"residual {s:.3g} x the noises (position RMS {rms_p * 1e6:.4g} um vs "
        f"{problem.sigma_p * 1e6:.4g} um, angle RMS {rms_r * 1e6:.4g} urad vs "
        f"{problem.sigma_r * 1e6:.4g} urad, over {dof} dof)"
    )
    if declared and dof > 0:
        if s > b.refuse_ratio:
            reasons.append(f"{what}: readings the model cannot explain")
        elif s > b.noise_ratio:
            warnings.append(f"{what}: the model misses something the readings see")
        elif s < 0.1:
            reasons.append(
                f"{what}: far below the declared noises, an exact fit of noisy "
                "readings is degenerate (or the noises are overstated)"
            )
    if np.linalg.norm(p_FM) > MAX_MARKER:
        reasons.append(
            f"marker fitted {np.linalg.norm(p_FM):.3g} m from the flange, beyond "
            f"{MAX_MARKER:g} m: a wrong tool or positions of another marker"
        )
    reasons += [c for c in (collapsed, beyond) if c is not None]
    return SanityReport(
        reasons=tuple(reasons),
        noise=problem.sigma_p,
        noise_source=source or ("declared" if declared else "estimated"),
        residual_rms=s * problem.sigma_p,
        dof=dof,
        z=z,
        outliers=rows,
        reference="calibrated",
        warnings=tuple(warnings),
    )
