"""Is a plane-constraint calibration believable? Checks run after every plate fit
(the shared bounds, report and checks: :mod:`rmdrake.calibration.sanity`).

A least-squares fit always returns numbers. These checks say when the numbers
are contradicted by the readings themselves or by physics, so that a wrong
robot is refused instead of being written (:func:`check_calibration`; the
calibrators store its report as ``sanity_``; ``rmdrake calibrate`` refuses a
failed one unless forced). One line per failed check, naming the readings
(1-based, in file order: reading k is line k + 1 of the CSV), plates (by id)
and parameters at fault. The bounds are :class:`CalibrationBounds`.

Why a fit can look perfect and be absurd: the point-to-plane cost has exact,
zero-residual minima far from any real robot. With ``alpha`` corrections of
+-90 deg the model turns every measured point into one single plane (e.g. a
horizontal beam at constant height) and every plate then fits "exactly".
Consistent readings keep the fit in the nominal model's basin; contradictory
ones (wrong plate ids, two plates under one id, distances in mm, random
numbers) push least squares out of it. Hence, in order:

1. **Degrees of freedom**: N readings - k parameters - 3 P plate unknowns
   (normal and offset per plate) must be >= ``min_dof``, and every plate needs
   ``min_per_plate`` readings (3 fix its pose, the rest check it).
2. **Degenerate solution**: the Jacobian of all unknowns at the solution must
   keep full rank (singular values above ``rtol`` of the largest): a collapsed
   model fits planes whatever the readings.
3. **Physical bounds** per parameter kind, see :class:`CalibrationBounds`
   (none on the compliances ``c<j>`` of an elastostatic calibration).
4. **Noise**: the residual RMS s = sqrt(RSS / dof) against the reading noise:
   the declared noise if given, else the robust estimate of 5. s above
   ``noise_ratio`` (3) times it means readings the model does not fully
   explain: up to ``refuse_ratio`` (30) times a *warning* naming the likely
   causes and what to try (error parameters outside the set fitted: robots
   perturbed on every parameter and fitted with the paper's 17 left 6.5x and
   16.9x a declared 2 um, while cutting the nominal residual 8x; a plate that
   moved; a declared noise too small), beyond it a refusal (a rigid model of
   the bending DEMO-class arm leaves 33x, outliers and wrong plate ids
   hundreds of times); s below a tenth of a declared noise (or of
   the nominal model's scatter when the fit failed 2 or 3), an over-fit. A
   robust scatter above ``max_noise`` means the readings are not distances in
   m of this robot.
5. **Outliers**, at the calibrated model if it passed 2 and 3: the
   leverage-corrected residuals e_i = r_i / sqrt(1 - h_ii) (h_ii the diagonal
   of the Jacobian's hat matrix, computed as the squared row norms of the
   economic U of its SVD, N x p: never the N x N matrix) each have the
   noise's variance; their robust scale
   1.4826 median |e_i| estimates the noise; reading i's externally
   studentized residual z_i = e_i / s_(i) (s_(i) the residual scale without
   it, floored at 10 nm) follows Student's t with dof - 1 and is named when
   |z_i| exceeds max(``min_z``, the t quantile of ``outlier_p`` / (2 N))
   (Bonferroni: a clean fit is flagged with probability under ``outlier_p``).
   If that flags a reading, or s exceeds ``noise_ratio`` robust scales, a
   Cauchy-loss refit from the solution replaces the residuals (outliers pull
   a least-squares fit toward them and mask each other) and its robust scale
   becomes the noise estimate.
   When the fit failed 2 or 3, at the nominal model instead: each plate's
   points get a robust plane (least median of squares over point triples,
   then least squares iterated on the points within 3 scales) and z_i is the
   distance to it over the pooled inlier scale; beyond ``min_z`` (or the
   normal quantile) a reading is named. A plate with more than a third of its
   readings flagged, or whose robust scatter (of e, or about its robust plane)
   is over ``plate_ratio`` times the median plate's, "does not fit one plane"
   (two plates under one id, a moved plate).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from rmdrake.calibration.plates.cost import PlaneProblem
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.sanity import (
    CalibrationBounds,
    SanityReport,
    degenerate_reason,
    out_of_bounds_reason,
    residual_over_noise,
    studentized_residuals,
)
from rmdrake.kinematics.forward import chunk_slices, robot_reach, tool_points

__all__ = ["CHUNK_VALUES", "PLATE_CAUSES", "check_calibration"]


CHUNK_VALUES = 1 << 21
"""Most values (16 MB) of one block of the robust plane fits' work arrays:
the random keys that draw the point triples and the distances of all points
to a block of candidate planes are built block by block."""


def _random_triples(m: int, count: int, seed: int = 0) -> np.ndarray:
    """(count, 3) point triples of m points: in each row, the indices of the 3
    smallest of m uniform keys, smallest first (a random 3-subset in random
    order). Drawn in blocks of rows of at most :data:`CHUNK_VALUES` keys, from
    one ``default_rng(seed)`` stream: the triples of one (count, m) draw."""
    rng = np.random.default_rng(seed)
    out = []
    for rows in chunk_slices(count, max(1, CHUNK_VALUES // m)):
        keys = rng.random((rows.stop - rows.start, m))
        low = np.argpartition(keys, 2, axis=1)[:, :3]
        order = np.argsort(np.take_along_axis(keys, low, axis=1), axis=1)
        out.append(np.take_along_axis(low, order, axis=1))
    return np.concatenate(out)


def _lmeds_plane(points: np.ndarray, max_triples: int = 400) -> np.ndarray:
    """Unit normal and offset (4,) of the least-median-of-squares plane among
    the planes through point triples (all, or ``max_triples`` drawn with a
    fixed seed by :func:`_random_triples`: the same points give the same
    plane). NaNs if all triples are collinear. Memory: the (m, planes)
    distances are taken for blocks of planes (:data:`CHUNK_VALUES`)."""
    m = points.shape[0]
    if math.comb(m, 3) <= max_triples:
        tri = np.array(list(itertools.combinations(range(m), 3)), dtype=np.intp)
    else:
        tri = _random_triples(m, max_triples)
    A, B, C = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    n = np.cross(B - A, C - A)
    norm = np.linalg.norm(n, axis=1)
    good = norm > 1e-12 * max(float(np.ptp(points, axis=0).max()) ** 2, 1e-300)
    if not good.any():
        return np.full(4, np.nan)
    n = n[good] / norm[good, None]
    h = np.sum(n * A[good], axis=1)
    med = np.concatenate(
        [
            np.median(np.abs(points @ n[planes].T - h[planes]), axis=0)
            for planes in chunk_slices(n.shape[0], max(1, CHUNK_VALUES // m))
        ]
    )
    best = int(np.argmin(med))
    return np.append(n[best], h[best])


def _robust_planes(
    points: np.ndarray, plate_index: np.ndarray, n_plates: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per plate: robust plane (LMedS, then least squares iterated on the points
    within 3 scales).

    Returns (N,) signed distances of every point to its plate's robust plane
    (m), (N,) inlier mask and (P,) inlier RMS per plate (m, dof m_in - 3)."""
    d = np.zeros(points.shape[0])
    inlier = np.zeros(points.shape[0], dtype=bool)
    scatter = np.zeros(n_plates)
    for p in range(n_plates):
        rows = np.flatnonzero(plate_index == p)
        pts = points[rows]
        plane = _lmeds_plane(pts)
        if not np.all(np.isfinite(plane)):  # collinear: any plane through them
            inlier[rows] = True
            continue
        m = rows.size
        r = pts @ plane[:3] - plane[3]
        scale = 1.4826 * (1 + 5 / max(m - 3, 1)) * float(np.median(np.abs(r)))
        keep = np.ones(m, dtype=bool)
        for _ in range(5):
            new = np.abs(r) <= max(3.0 * scale, 1e-15)
            if new.sum() < 4:
                break
            keep = new
            centre = pts[keep].mean(axis=0)
            normal = np.linalg.svd(pts[keep] - centre, full_matrices=False)[2][-1]
            r = (pts - centre) @ normal
            scale = float(np.sqrt(np.sum(r[keep] ** 2) / max(int(keep.sum()) - 3, 1)))
        d[rows], inlier[rows], scatter[p] = r, keep, scale
    return d, inlier, scatter


def _rows(idx: np.ndarray, limit: int = 6) -> str:
    """'readings 3, 17, 40' (1-based), at most ``limit`` listed."""
    text = ", ".join(str(int(i) + 1) for i in idx[:limit])
    more = f" and {idx.size - limit} more" if idx.size > limit else ""
    return f"reading{'s' if idx.size > 1 else ''} {text}{more}"


def _robust_refit(
    problem: PlaneProblem, x: np.ndarray, scale: float, floor: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Residuals (N,), leverage-corrected residuals (N,) and their robust scale
    (m) after a
    Cauchy-loss refit from ``x`` (three rounds, the loss's scale 3 robust
    scales of the previous round): outliers that pulled the least-squares fit
    toward them (and hid each other) stand out again."""
    import scipy.optimize

    r = e = np.zeros(problem.q.shape[0])
    for _ in range(3):
        fit = scipy.optimize.least_squares(
            problem.residuals,
            x,
            jac=problem.jacobian,
            method="trf",
            loss="cauchy",
            f_scale=max(3.0 * scale, floor),
            x_scale="jac",
            max_nfev=50,
        )
        x, r = fit.x, fit.fun
        U, sv, _ = np.linalg.svd(problem.jacobian(x), full_matrices=False)
        h = np.sum(U[:, sv > 1e-12 * sv[0]] ** 2, axis=1)
        e = r / np.sqrt(np.clip(1.0 - h, 1e-9, 1.0))
        scale = 1.4826 * float(np.median(np.abs(e)))
    return r, e, scale


PLATE_CAUSES = (
    ": error parameters outside the set fitted (try --params auto or full), "
    "a plate that moved during the readings, or a declared noise too small"
)
"""The likely causes of a plate fit's residual over the noise."""


def check_calibration(
    data: PlaneMeasurements,
    problem: PlaneProblem,
    x: np.ndarray,
    names: list[str],
    *,
    noise: float | None = None,
    bounds: CalibrationBounds | None = None,
) -> SanityReport:
    """Runs the checks of the module docstring on one fit.

    The reasons come in this order: too few dof or readings on a plate; plates
    that do not fit one plane; reading scatter beyond ``max_noise``; outlying
    readings; residual against the noise; degenerate solution; corrections
    beyond bounds (the data's faults first, their consequences after).

    Args:
      data: the readings fitted.
      problem: the point-to-plane problem of the fit (nominal table, error
        parameter indices, plates:
        :class:`~rmdrake.calibration.plates.cost.PlaneProblem`).
      x: its solution (deltas in rad or m, then the plate unknowns).
      names: the error parameters (the first k entries of x).
      noise: declared standard deviation of the readings, m; None: estimated.
      bounds: the bounds (default :class:`CalibrationBounds`()).
    """
    import scipy.special

    nominal_table = problem.table
    deltas = x[: len(names)]
    residuals = problem.residuals(x)
    jacobian = problem.jacobian(x)
    b = bounds or CalibrationBounds()
    reasons: list[str] = []
    N, k = data.n_readings, len(names)
    P = int(data.plate_ids.size)
    ids, pi = data.plate_ids, data.plate_index
    dof = N - k - 3 * P
    s = math.sqrt(float(np.sum(np.asarray(residuals) ** 2)) / dof) if dof > 0 else 0.0
    if dof < b.min_dof:
        reasons.append(
            f"only {dof} degrees of freedom ({N} readings - {k} parameters - "
            f"{3 * P} plate unknowns), at least {b.min_dof} needed to check the "
            "fit: take more readings or calibrate fewer parameters"
        )
    counts = np.bincount(pi, minlength=P)
    for p in np.flatnonzero(counts < b.min_per_plate):
        reasons.append(
            f"plate {ids[p]} has {counts[p]} readings, at least {b.min_per_plate} "
            "needed (3 fix its pose, the others check it)"
        )
    J = np.asarray(jacobian, dtype=np.float64)
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    U, sv, vt = np.linalg.svd(J / norms, full_matrices=False)
    collapsed = degenerate_reason(sv, vt, names, b.rtol)
    length = b.length + b.length_fraction * robot_reach(nominal_table)
    beyond = out_of_bounds_reason(names, deltas, length, b.angle)
    calibrated_ok = collapsed is None and beyond is None
    if calibrated_ok:
        reference = "calibrated"
        full = sv > b.rtol * sv[0]
        dist, z = studentized_residuals(residuals, U, full, dof, b.noise_floor)
        off = residuals
        sigma = 1.4826 * float(np.median(np.abs(dist)))
        how = "robust scale of the fit's leverage-corrected residuals"
        # scipy.stats.t.isf(p, dof - 1), the same bits, without scipy.stats (1 s)
        z_crit = float(-scipy.special.stdtrit(max(dof - 1, 1), b.outlier_p / (2 * N)))
        z_crit = max(b.min_z, z_crit)
        if dof >= 2 and (
            np.any(np.abs(z) > z_crit) or s > b.noise_ratio * max(sigma, b.noise_floor)
        ):
            off, dist, sigma = _robust_refit(problem, x, sigma, b.noise_floor)
            z = dist / max(sigma, b.noise_floor)
            how = "robust scale of a Cauchy-loss refit's residuals"
        scatter = np.array(
            [1.4826 * np.median(np.abs(dist[pi == p])) for p in range(P)]
        )
    else:
        reference = "nominal"
        pts = tool_points(
            np.asarray(nominal_table), data.q, data.distance, sigma=problem.sigma
        )
        dist, inlier, scatter = _robust_planes(pts, pi, P)
        off = dist
        keep = inlier & (scatter <= b.plate_ratio * np.median(scatter))[pi]
        used = len(np.unique(pi[keep]))
        sigma = math.sqrt(
            float(np.sum(dist[keep] ** 2)) / max(int(keep.sum()) - 3 * used, 1)
        )
        z = dist / max(sigma, b.noise_floor)
        how = "robust plane fits at the nominal model"
        # scipy.stats.norm.isf(p), the same bits
        z_crit = float(-scipy.special.ndtri(b.outlier_p / (2 * N)))
    z_crit = max(b.min_z, z_crit)
    median_scatter = float(np.median(scatter))
    bad_plate = scatter > b.plate_ratio * max(median_scatter, b.noise_floor)
    flagged = np.abs(z) > z_crit
    for p in range(P):
        rows = np.flatnonzero(pi == p)
        share = int(flagged[rows].sum())
        if bad_plate[p] or share > rows.size / 3:
            why = (
                f"scatter {scatter[p] * 1e6:.4g} um vs {median_scatter * 1e6:.4g} "
                "um on the median plate"
                if bad_plate[p]
                else f"{share} of its {rows.size} readings lie off its plane"
            )
            reasons.append(
                f"plate {ids[p]}: its readings do not fit one plane ({why}, at the "
                f"{reference} model): two plates under one id, or the plate moved"
            )
            flagged[rows] = False
    if sigma > b.max_noise:
        reasons.append(
            f"the readings scatter {sigma * 1e3:.4g} mm about their plates (robust, "
            f"at the {reference} model), beyond {b.max_noise * 1e3:g} mm: "
            "distances not in m, or readings not of this robot"
        )
        flagged[:] = False  # everything is off: naming readings says nothing
    outliers = np.flatnonzero(flagged)
    if outliers.size:
        mm = ", ".join(f"{abs(off[i]) * 1e3:.3g}" for i in outliers[:6])
        on = ", ".join(str(ids[pi[i]]) for i in outliers[:6])
        reasons.append(
            f"outlying {_rows(outliers)} (plate{'s' if outliers.size > 1 else ''} "
            f"{on}): {mm} mm off the "
            f"plate's plane, standardized residual over {z_crit:.3g} at the "
            f"{reference} model: a wrong plate id or a bad reading"
        )
    if noise is not None:
        ref, source = float(noise), "declared"
    else:
        ref, source = sigma, f"estimated: {how}"
    warnings: list[str] = []
    above = residual_over_noise(s, ref, source, dof, b, f"RMS over {dof} dof")
    if above is not None:
        (reasons if above[0] else warnings).append(above[1] + PLATE_CAUSES)
    elif dof > 0 and s < ref / 10 and (noise is not None or not calibrated_ok):
        reasons.append(
            f"residual {s * 1e6:.4g} um (RMS over {dof} dof) is far below the noise "
            f"({ref * 1e6:.4g} um, {source}): an exact fit of noisy readings is a "
            "degenerate model, not a success"
        )
    reasons += [r for r in (collapsed, beyond) if r is not None]
    return SanityReport(
        reasons=tuple(reasons),
        noise=float(ref),
        noise_source=source,
        residual_rms=s,
        dof=dof,
        z=z,
        outliers=np.flatnonzero(flagged),
        reference=reference,
        warnings=tuple(warnings),
    )
