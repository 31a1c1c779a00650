"""What a point calibration accepts, before and after its fit.

Before (:func:`check_point_measurements`): the content of a point file (the
reader, :func:`rmdrake.calibration.points.data.read_point_measurements`, checks the
format):
joint count and units, one configuration per pose id, repeated measurements of
one target that agree, coordinates in m, enough poses per marker.

After (:func:`check_point_calibration`): is the fit believable? The checks of
:mod:`rmdrake.calibration.sanity` for plates, for points: degrees of freedom,
full rank of the Jacobian at the solution, corrections within
:class:`~rmdrake.calibration.sanity.CalibrationBounds`, markers within
``max_marker`` of the tool, residual against the noise (declared, or the robust
scale 1.4826 median |e| of the leverage-corrected residuals e) and outlying
rows (externally studentized residuals beyond the Bonferroni bound, as for
plates). Each failed check is one line naming the rows (1-based, in file
order), poses, markers or parameters at fault.
"""

from __future__ import annotations

import math

import numpy as np

from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.problem import PointProblem
from rmdrake.calibration.sanity import (
    MAX_INSTRUMENT_RANGE,
    MAX_MARKER,
    POINT_MAX_NOISE,
    CalibrationBounds,
    SanityReport,
    check_joint_values,
    degenerate_reason,
    out_of_bounds_reason,
    residual_over_noise,
    studentized_residuals,
)
from rmdrake.kinematics.forward import robot_reach

__all__ = [
    "MAX_INSTRUMENT_RANGE",
    "POINT_CAUSES",
    "POINT_MAX_NOISE",
    "check_point_calibration",
    "check_point_measurements",
]


POINT_CAUSES = (
    ": error parameters outside the set fitted (try --params auto or full), "
    "markers that moved on the tool, or a declared noise too small"
)
"""The likely causes of a point fit's residual over the noise."""


def check_point_measurements(
    data: PointMeasurements,
    *,
    n_joints: int | None = None,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    sigma: np.ndarray | None = None,
    reach: float | None = None,
    min_per_marker: int = 3,
    min_poses: int = 3,
    repeat_tol: float = 1e-3,
    source: str = "measurements",
) -> list[str]:
    """Checks point measurements for use in a calibration.

    Errors (ValueError, one line starting with ``source``): a joint count
    other than ``n_joints``; joints in the wrong unit
    (:func:`~rmdrake.calibration.plates.checks.check_joint_values`); rows of one
    pose id with different joint values (one id per configuration); the same
    (pose, marker) twice with points more than ``repeat_tol`` m apart (two
    targets under one id, or the robot moved); coordinates in mm, by the rule:
    a point farther than :data:`MAX_INSTRUMENT_RANGE` (100 m) from the
    instrument, or points spread over more than 2 (``reach`` + 1 m) (the
    largest extent of markers within 1 m of a tool the robot moves; the
    bounding-box diagonal is compared); a marker seen at fewer than
    ``min_per_marker`` poses (naming it and its count); fewer than
    ``min_poses`` poses.

    Returns the warnings (joints outside [lower, upper]).
    """
    if n_joints is not None and data.n_joints != n_joints:
        raise ValueError(
            f"{source}: {data.n_joints} joint columns, but the robot has {n_joints} "
            f"joints (expected columns pose,marker,q1..q{n_joints},x,y,z)"
        )
    if data.n_rows == 0:
        raise ValueError(f"{source}: no measured points")
    messages = check_joint_values(data.q, lower, upper, sigma, source=source)
    order = np.lexsort((np.arange(data.n_rows), data.pose))
    pose, q = data.pose[order], data.q[order]
    first = np.r_[True, pose[1:] != pose[:-1]]
    ref = q[np.maximum.accumulate(np.where(first, np.arange(pose.size), 0))]
    differ = np.flatnonzero(np.abs(q - ref).max(axis=1) > 1e-9)
    if differ.size:
        i = int(differ[0])
        j = int(np.argmax(np.abs(q[i] - ref[i])))
        rows = np.flatnonzero(data.pose == pose[i]) + 1
        raise ValueError(
            f"{source}: pose {pose[i]} has rows with different joint values (rows "
            f"{rows[0]} and {order[i] + 1}: q{j + 1} = {ref[i, j]:g} vs {q[i, j]:g}); "
            f"give each configuration its own pose id"
        )
    key = np.stack([data.pose, data.marker], 1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    if np.any(counts > 1):
        mean = np.zeros((counts.size, 3))
        np.add.at(mean, inverse, data.p_I)
        mean /= counts[:, None]
        spread = np.linalg.norm(data.p_I - mean[inverse], axis=1)
        bad = np.flatnonzero(spread > repeat_tol / 2)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{source}: pose {data.pose[i]}, marker {data.marker[i]} is measured "
                f"{counts[inverse[i]]} times with points more than "
                f"{repeat_tol * 1e3:g} mm apart (row {i + 1}): two targets under "
                f"one id, or the robot moved"
            )
    far = np.linalg.norm(data.p_I, axis=1)
    if far.max() > MAX_INSTRUMENT_RANGE:
        i = int(np.argmax(far))
        raise ValueError(
            f"{source}: point at row {i + 1} is {far[i]:.4g} m from the instrument, "
            f"beyond {MAX_INSTRUMENT_RANGE:g} m: coordinates must be in m, not mm"
        )
    if reach is not None:
        extent = float(np.linalg.norm(np.ptp(data.p_I, axis=0)))
        if extent > 2 * (reach + MAX_MARKER):
            raise ValueError(
                f"{source}: the points spread over {extent:.4g} m, more than "
                f"{2 * (reach + MAX_MARKER):.3g} m (twice the robot's reach plus "
                f"{MAX_MARKER:g} m for the markers): coordinates must be in m, not mm"
            )
    ids = np.unique(key, axis=0)[:, 1]
    marker_ids, per_marker = np.unique(ids, return_counts=True)
    few = np.flatnonzero(per_marker < min_per_marker)
    if few.size:
        bad = ", ".join(f"marker {marker_ids[i]} at {per_marker[i]}" for i in few)
        raise ValueError(
            f"{source}: a marker seen at fewer than {min_per_marker} poses ({bad}): "
            f"its position on the tool cannot be fitted and checked"
        )
    if data.pose_ids.size < min_poses:
        raise ValueError(
            f"{source}: {data.pose_ids.size} pose(s), at least {min_poses} needed"
        )
    return messages


def _rows(idx: np.ndarray, data: PointMeasurements, limit: int = 6) -> str:
    """'rows 3 (pose 1, marker 2), ...' (1-based), at most ``limit``."""
    text = ", ".join(
        f"{int(i) + 1} (pose {data.pose[i]}, marker {data.marker[i]})"
        for i in idx[:limit]
    )
    more = f" and {idx.size - limit} more" if idx.size > limit else ""
    return f"row{'s' if idx.size > 1 else ''} {text}{more}"


def check_point_calibration(
    data: PointMeasurements,
    problem: PointProblem,
    x: np.ndarray,
    names: list[str],
    *,
    noise: float | None = None,
    bounds: CalibrationBounds | None = None,
    max_noise: float = POINT_MAX_NOISE,
) -> SanityReport:
    """Runs the checks of the module docstring on one point fit.

    Args:
      data: the points fitted.
      problem: the problem of the fit; x: its solution.
      names: the error parameters (the first k entries of x).
      noise: declared standard deviation of each coordinate, m; None:
        estimated (robust).
      bounds: the bounds (default :class:`CalibrationBounds`()).
      max_noise: m, the largest believable robust scatter.
    """
    import scipy.special

    b = bounds or CalibrationBounds()
    r = problem.residuals(x)
    J = problem.jacobian(x)
    reasons: list[str] = []
    k, u = len(names), problem.n_unknowns
    dof = r.size - u
    s = math.sqrt(float(r @ r) / dof) if dof > 0 else 0.0
    if dof < b.min_dof:
        reasons.append(
            f"only {dof} degrees of freedom ({r.size} coordinates - {k} parameters "
            f"- {u - k} instrument and marker unknowns), at least {b.min_dof} "
            "needed to check the fit: measure more poses or calibrate fewer "
            "parameters"
        )
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    U, sv, vt = np.linalg.svd(J / norms, full_matrices=False)
    collapsed = degenerate_reason(sv, vt, names, b.rtol)
    if collapsed:
        collapsed = collapsed.replace("planes fit", "points fit")
    length = b.length + b.length_fraction * robot_reach(problem.table)
    beyond = out_of_bounds_reason(names, x[:k], length, b.angle)
    markers = problem.unpack(x)[3]
    far = np.flatnonzero(np.linalg.norm(markers, axis=1) > MAX_MARKER)
    full = sv > b.rtol * sv[0]
    e, z = studentized_residuals(r, U, full, dof, b.noise_floor)
    scale = 1.4826 * float(np.median(np.abs(e)))
    if scale > max_noise:
        reasons.append(
            f"the points scatter {scale * 1e3:.4g} mm about the fitted model "
            f"(robust), beyond {max_noise * 1e3:g} mm: coordinates not in m, "
            "markers mixed up, or points not of this robot"
        )
    else:
        # scipy.stats.t.isf(p, dof - 1), the same bits, without scipy.stats (1 s)
        z_crit = float(
            -scipy.special.stdtrit(max(dof - 1, 1), b.outlier_p / (2 * r.size))
        )
        z_crit = max(b.min_z, z_crit)
        rows = np.flatnonzero((np.abs(z) > z_crit).reshape(-1, 3).any(axis=1))
        if rows.size:
            off = np.linalg.norm(r.reshape(-1, 3)[rows], axis=1)
            mm = ", ".join(f"{v * 1e3:.3g}" for v in off[:6])
            reasons.append(
                f"outlying {_rows(rows, data)}: {mm} mm off the fitted model, "
                f"standardized residual over {z_crit:.3g}: a swapped marker id or "
                "a bad reading"
            )
    ref, source = (
        (float(noise), "declared")
        if noise is not None
        else (scale, "estimated: robust scale of the leverage-corrected residuals")
    )
    warnings: list[str] = []
    what = f"RMS per coordinate over {dof} dof"
    above = residual_over_noise(s, ref, source, dof, b, what)
    if above is not None:
        (reasons if above[0] else warnings).append(above[1] + POINT_CAUSES)
    elif dof > 0 and noise is not None and s < ref / 10:
        reasons.append(
            f"residual {s * 1e6:.4g} um is far below the declared noise "
            f"({ref * 1e6:.4g} um): an exact fit of noisy points is degenerate"
        )
    if far.size:
        ids = data.marker_ids[far]
        reasons.append(
            f"marker(s) {', '.join(map(str, ids))} fitted more than {MAX_MARKER:g} m "
            "from the tool frame: a wrong tool or marker id"
        )
    reasons += [c for c in (collapsed, beyond) if c is not None]
    return SanityReport(
        reasons=tuple(reasons),
        noise=float(ref),
        noise_source=source,
        residual_rms=s,
        dof=dof,
        z=z,
        outliers=np.flatnonzero((np.abs(z) > b.min_z).reshape(-1, 3).any(axis=1)),
        reference="calibrated",
        warnings=tuple(warnings),
    )
