"""The LM driver every kind shares, and what it reports: scipy's
``least_squares`` on a problem's residuals (m) with its analytic Jacobian
(:func:`solve_lm`), the standard deviations of a least-squares fit's unknowns
(:func:`least_squares_std`) and the table of fitted error parameters
(:func:`delta_lines`, mm and deg).

Example::

    fit = solve_lm(problem, x0, estimator)  # estimator: loss, f_scale, tols
    std = least_squares_std(problem.jacobian(fit.x), fit.fun)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.model.error_parameters import is_compliance_name
from rmdrake.progress import progress_bar

__all__ = [
    "CALIBRATION_LOSSES",
    "MAX_F_SCALE",
    "check_loss",
    "delta_lines",
    "least_squares_std",
    "solve_lm",
]

_RANK_RTOL = 1e-8
"""Singular values of the scaled Jacobian below this fraction of the largest
are a direction the data do not fix (as
:class:`~rmdrake.calibration.sanity.CalibrationBounds`.rtol)."""


CALIBRATION_LOSSES: tuple[str, ...] = ("linear", "huber", "soft_l1", "cauchy", "arctan")
"""Losses of every LM estimator (those of
:func:`scipy.optimize.least_squares`)."""

MAX_F_SCALE = 1.0
"""m: the largest residual scale of a robust loss. Residuals are distances of
points to planes or of tool points, mm to cm; a scale of 1e300 overflowed
scipy's loss (an internal error)."""


def check_loss(loss: str, f_scale: float = 1e-5) -> None:
    """Raises ValueError (one line) unless ``loss`` is one of
    :data:`CALIBRATION_LOSSES` and ``f_scale`` (m) is in (0, :data:`MAX_F_SCALE`]."""
    if loss not in CALIBRATION_LOSSES:
        raise ValueError(
            f"unknown loss '{loss}': expected one of {', '.join(CALIBRATION_LOSSES)}"
        )
    if not 0 < f_scale <= MAX_F_SCALE:
        raise ValueError(
            f"f_scale: expected a residual scale in (0, {MAX_F_SCALE:g}] m, found "
            f"{f_scale:g} (e.g. 3 x the reading noise)"
        )


def solve_lm(problem: Any, x0: np.ndarray, options: Any) -> Any:
    """scipy ``least_squares`` of ``problem.residuals`` with its analytic
    ``problem.jacobian`` from x0: Levenberg-Marquardt for the ``linear`` loss, the
    trust-region reflective method for a robust one; ``options`` has ``loss``,
    ``f_scale`` (m), ``xtol``, ``ftol``, ``gtol``, ``max_nfev`` (an LM
    estimator's attributes). Columns are scaled by the Jacobian.

    A solve that outlasts the progress interval (30 s: many readings) shows
    its iterations (:func:`rmdrake.progress.progress_bar`, lazy: nothing for
    a quick one): ``LM iterations: k, <elapsed> s, cost=..., evaluations=e of
    at most <max_nfev>``, one Jacobian per iteration."""
    import scipy.optimize

    bar = progress_bar(total=None, desc="LM iterations", lazy=True)
    cap = f" of at most {options.max_nfev}" if options.max_nfev else ""
    evaluations = [0]

    def residuals(x: np.ndarray) -> np.ndarray:
        r = problem.residuals(x)
        evaluations[0] += 1
        cost = 0.5 * float(np.dot(r, r)) if np.all(np.isfinite(r)) else np.nan
        bar.set_postfix(cost=f"{cost:.4g}", evaluations=f"{evaluations[0]}{cap}")
        return r

    def jacobian(x: np.ndarray) -> np.ndarray:
        bar.update(1)
        return problem.jacobian(x)

    try:
        return scipy.optimize.least_squares(
            residuals,
            x0,
            jac=jacobian,
            method="trf" if options.loss != "linear" else "lm",
            loss=options.loss,
            f_scale=options.f_scale,
            x_scale="jac",
            xtol=options.xtol,
            ftol=options.ftol,
            gtol=options.gtol,
            max_nfev=options.max_nfev,
        )
    finally:
        bar.close()


def delta_lines(names: Sequence[str], deltas: np.ndarray, std: np.ndarray) -> list[str]:
    """The table of fitted error parameters: a header, then one line per
    parameter with its value and standard deviation in mm (lengths) or deg;
    a compliance ``c<j>`` in rad/(N m) (m/N on a slide) with its stiffness
    1 / c_j and the stiffness's relative std."""
    lines = [f"{'parameter':>10} {'delta':>12} {'std':>10}  unit"]
    for n, d, s in zip(names, deltas, std, strict=True):
        if is_compliance_name(n):
            k = f"{1 / d:.5g}" if d > 0 else "rigid (c <= 0)"
            rel = f" +- {100 * s / d:.3g} %" if d > 0 else ""
            lines.append(f"{n:>10} {d:12.5g} {s:10.3g}  per N m: stiffness {k}{rel}")
        elif n[:2] in ("dd", "dr"):
            lines.append(f"{n:>10} {d * 1e3:12.5f} {s * 1e3:10.5f}  mm")
        else:
            lines.append(f"{n:>10} {np.rad2deg(d):12.6f} {np.rad2deg(s):10.6f}  deg")
    return lines


def least_squares_std(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(u,) standard deviations sqrt(diag(sigma^2 (J^T J)^-1)) of the unknowns
    of a least-squares fit with Jacobian J (m, u) and residuals r (m,) at its
    solution, sigma^2 = |r|^2 / (m - u); NaN without degrees of freedom.

    Computed on the column-scaled J by SVD; a direction whose singular value is
    below ``_RANK_RTOL`` of the largest is not fixed by the data: the unknowns
    in it get an infinite std (the pseudo-inverse would report 0)."""
    dof = r.size - J.shape[1]
    std = np.full(J.shape[1], np.nan)
    if dof <= 0:
        return std
    sigma2 = float(r @ r) / dof
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    _, sv, vt = np.linalg.svd(J / norms, full_matrices=False)
    full = sv > _RANK_RTOL * sv[0]
    cov_s = (vt[full].T / sv[full] ** 2) @ vt[full]
    std = np.sqrt(np.maximum(np.diag(cov_s), 0) * sigma2) / norms
    std[np.abs(vt[~full]).max(axis=0, initial=0) > 1e-3] = np.inf
    return std
