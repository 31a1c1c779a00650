"""Which parameters of one arm drift over time: its identified base parameters
at several dates against its own earlier fits, with their trend.

Numbers in, flags out (numpy and scipy: no plant, no file): ``days`` (n,) the
date of each fit in days (any origin), ``values`` and ``std`` (n, p) the base
parameters and their stds of each fit (SI units of each parameter, as in
:mod:`rmdrake.dynamics.fleet`).

The rule. Per parameter a straight line x(t) = a + b t is fitted by weighted
least squares (weights 1 / std^2): the trend b, in the parameter's unit per
year (365.25 days), with its standard deviation sb = 1 / sqrt(sum w (t -
t_w)^2). Where the fits scatter about the line more than their stds say
(the reduced chi-square c = chi^2 / (n - 2) > 1: a real arm's day-to-day
changes, temperature, a least-squares std that assumes white residuals), sb
is scaled by sqrt(c) and the ratio b / sb read through Student's t with n - 2
degrees of freedom (:func:`~rmdrake.dynamics.fleet.sigma_equivalent`);
otherwise it is a normal deviate. A parameter is flagged when that sigma
exceeds the family-wise threshold of p tests
(:func:`~rmdrake.dynamics.fleet.family_threshold`: a constant arm raises any
flag with probability at most ``false_alarm``, 1 %; 52 parameters: 3.73
sigma). The change is the line's from the first date to the last, b (t_n -
t_1), relative to the line's value at the first date where that is clear of
zero by the threshold. Example: fv3 1.20, 1.21, 1.25, 1.27, 1.31, 1.32 N m
s/rad monthly with stds 0.01: b = 0.32 +- 0.03 N m s/rad a year, 11.0 sigma
(the threshold of one parameter at 1 %: 2.58), flagged ``joint 3 viscous
friction +11 % since the first fit (+26.4 %/year, 11.0 sigma)``.

``bench/fleet.py`` prints this rule's false alarms on simulated constant arms
and how soon it flags a joint friction growing 10 % a year. A least-squares std
is that of white torque noise: a real arm's fits scatter more from day to day
(temperature moves friction), which the reduced chi-square scaling absorbs at
the cost of detection.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from rmdrake.dynamics.fleet import (
    DEFAULT_FALSE_ALARM,
    RESOLUTION,
    check_threshold,
    family_threshold,
    parameter_unit,
    parameter_words,
    sigma_equivalent,
)

__all__ = ["DAYS_PER_YEAR", "MIN_FITS", "Drift", "HistoryTrend", "compare_history"]

DAYS_PER_YEAR = 365.25
"""Days in a year: trends are per year."""
MIN_FITS = 3
"""The fewest fits of one arm a trend is told from (a line through two has
no scatter to check)."""


@dataclasses.dataclass(frozen=True)
class Drift:
    """One parameter of the arm that drifts.

    Attributes:
      name: the base parameter (``fv3``).
      trend, trend_std: its change per year and that change's standard
        deviation, SI unit per year.
      z: the trend in sigma, signed.
      first, last: the line's values at the first and last dates, SI.
      relative: (last - first) / |first|, or None where first is not clear of
        zero.
      unit: the parameter's SI unit.
    """

    name: str
    trend: float
    trend_std: float
    z: float
    first: float
    last: float
    relative: float | None
    unit: str

    @property
    def words(self) -> str:
        """The parameter in words (``joint 3 viscous friction``)."""
        return parameter_words(self.name)

    def text(self) -> str:
        """``joint 3 viscous friction +10 % since the first fit (+25 %/year,
        15.0 sigma)``, or the changes in SI units where no percentage means
        anything."""
        if self.relative is not None:
            pct = 100.0 * self.relative
            year = 100.0 * self.trend / abs(self.first)
            return (
                f"{self.words} {pct:+.0f} % since the first fit "
                f"({year:+.1f} %/year, {abs(self.z):.1f} sigma)"
            )
        return (
            f"{self.words} {self.last - self.first:+.3g} {self.unit} since the "
            f"first fit ({self.trend:+.3g} {self.unit}/year, {abs(self.z):.1f} "
            "sigma)"
        )


@dataclasses.dataclass(frozen=True)
class HistoryTrend:
    """What :func:`compare_history` found.

    Attributes:
      names: (p,) base parameter names.
      days: (n,) each fit's date, days (the caller's origin).
      values, std: (n, p) the fits' parameters and stds, SI.
      trend, trend_std: (p,) change per year and its std, SI per year (the std
        scaled by the scatter where it exceeds the stds).
      scatter: (p,) sqrt of the reduced chi-square about the line.
      dof: (p,) degrees of freedom of trend_std (inf: the stds alone).
      z: (p,) the trend in sigma, signed.
      first, last: (p,) the line at the first and last dates, SI.
      threshold: sigma over which a trend is flagged.
      false_alarm: the family-wise rate that set it, or None (given).
    """

    names: tuple[str, ...]
    days: np.ndarray
    values: np.ndarray
    std: np.ndarray
    trend: np.ndarray
    trend_std: np.ndarray
    scatter: np.ndarray
    dof: np.ndarray
    z: np.ndarray
    first: np.ndarray
    last: np.ndarray
    threshold: float
    false_alarm: float | None = None

    @property
    def flagged(self) -> list[Drift]:
        """The parameters whose trend exceeds the threshold, joint terms
        (friction, rotor inertia, offsets) first, each group in base order."""
        from rmdrake.dynamics.fleet import is_joint_term

        joint = [k for k, n in enumerate(self.names) if is_joint_term(n)]
        other = [k for k, n in enumerate(self.names) if not is_joint_term(n)]
        out = []
        for k in joint + other:
            if not abs(self.z[k]) > self.threshold:
                continue
            first, last = float(self.first[k]), float(self.last[k])
            clear = abs(first) > self.threshold * float(np.max(self.std[:, k]))
            out.append(
                Drift(
                    name=self.names[k],
                    trend=float(self.trend[k]),
                    trend_std=float(self.trend_std[k]),
                    z=float(self.z[k]),
                    first=first,
                    last=last,
                    relative=(last - first) / abs(first) if clear else None,
                    unit=parameter_unit(self.names[k]),
                )
            )
        return out

    def describe(self) -> str:
        """One line: how many fits over how long, and the threshold."""
        span = (self.days[-1] - self.days[0]) / DAYS_PER_YEAR * 12.0
        text = (
            f"fitted a trend to {len(self.names)} base parameters over "
            f"{len(self.days)} fits ({span:.1f} months); flagged beyond "
            f"{self.threshold:.3g} sigma"
        )
        if self.false_alarm is not None:
            text += f" (false alarms {100 * self.false_alarm:g} % over "
            text += f"{len(self.names)} tests)"
        return text


def compare_history(
    names: Sequence[str],
    days: object,
    values: object,
    std: object,
    *,
    threshold: float | None = None,
    false_alarm: float = DEFAULT_FALSE_ALARM,
) -> HistoryTrend:
    """Fits each parameter's trend over one arm's fits (module docstring).

    Args:
      names: (p,) base parameter names (:mod:`rmdrake.dynamics.base`).
      days: (n,) each fit's date in days (any origin), n >= :data:`MIN_FITS`,
        not all the same; sorted here with the fits.
      values, std: (n, p) identified base parameters and stds, SI (a std of 0
        or NaN: the resolution floor, 1e-9 of the largest |value|).
      threshold: sigma over which a trend is flagged; None: the family-wise
        one of p tests at ``false_alarm``.
      false_alarm: the chance that a constant arm raises any flag.

    Raises:
      ValueError: shapes that disagree, fewer than :data:`MIN_FITS` fits, one
        date for all, values or dates that are not finite, a threshold not > 0.
    """
    names = tuple(str(n) for n in names)
    t = np.asarray(days, dtype=np.float64)
    x = np.asarray(values, dtype=np.float64)
    s = np.abs(np.asarray(std, dtype=np.float64))
    n, p = t.size, len(names)
    if t.ndim != 1 or x.shape != (n, p) or s.shape != (n, p):
        raise ValueError(
            f"days {t.shape}, values {x.shape}, std {s.shape}: expected (n,), "
            f"(n, {p}), (n, {p})"
        )
    if n < MIN_FITS:
        raise ValueError(f"history: {n} fit(s); a trend needs at least {MIN_FITS}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x))):
        raise ValueError("history: dates and values must be finite")
    if np.ptp(t) == 0:
        raise ValueError("history: every fit has the same date; no trend to tell")
    if threshold is None:
        threshold, alarm = family_threshold(p, false_alarm), float(false_alarm)
    else:
        threshold, alarm = check_threshold(threshold), None
    order = np.argsort(t, kind="stable")
    t, x, s = t[order], x[order], s[order]
    floor = RESOLUTION * np.maximum(np.max(np.abs(x), axis=0), 1e-300)
    s = np.maximum(np.where(np.isfinite(s), s, 0.0), floor)
    w = 1.0 / s**2  # (n, p)
    years = (t - t[0]) / DAYS_PER_YEAR
    tw = (w * years[:, None]).sum(0) / w.sum(0)  # weighted mean time, (p,)
    xw = (w * x).sum(0) / w.sum(0)
    dt = years[:, None] - tw
    sxx = (w * dt**2).sum(0)
    trend = (w * dt * (x - xw)).sum(0) / sxx
    trend_std = 1.0 / np.sqrt(sxx)
    resid = x - (xw + trend * dt)
    nu = n - 2
    scatter = np.sqrt((w * resid**2).sum(0) / nu) if nu > 0 else np.ones(p)
    over = scatter > 1.0
    trend_std = np.where(over, trend_std * scatter, trend_std)
    dof = np.where(over, float(nu), np.inf)
    z = sigma_equivalent(trend / trend_std, dof)
    return HistoryTrend(
        names=names,
        days=t,
        values=x,
        std=s,
        trend=trend,
        trend_std=trend_std,
        scatter=scatter,
        dof=dof,
        z=z,
        first=xw + trend * (years[0] - tw),
        last=xw + trend * (years[-1] - tw),
        threshold=float(threshold),
        false_alarm=alarm,
    )
