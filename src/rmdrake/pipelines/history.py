"""``rmdrake fleet --history``: one arm's joint logs over months in, one
identified robot YAML per log, ``history.csv``, ``history_fits.csv`` and
``history.png`` out, and which parameters drift from the arm's own earlier
fits, with their trend.

Each log's date is in its file name, as ``YYYY-MM-DD`` anywhere in the stem
(``logs/arm3_2026-01-15.csv``: 15 January 2026); the stem names the fit
(``OUT/arm3_2026-01-15.yaml``). Each log is identified as
:func:`~rmdrake.pipelines.fleet.identify_arms` identifies a fleet's arms (one
task each on the execution layer, ``wls`` or ``ols`` with their stds); a log
that fails is a failed row and the trend is told from the others (at least
:data:`~rmdrake.dynamics.history.MIN_FITS` on two dates or more). The trend
and the flags are :func:`~rmdrake.dynamics.history.compare_history`'s.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as dt
import io
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.dynamics.fleet import DEFAULT_FALSE_ALARM
from rmdrake.dynamics.history import (
    DAYS_PER_YEAR,
    MIN_FITS,
    HistoryTrend,
    compare_history,
)
from rmdrake.execution import Execution
from rmdrake.io.atomic import atomic_write_text, check_writable
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.checked import Echo
from rmdrake.pipelines.fleet import (
    ArmResult,
    arm_names,
    check_fleet_options,
    identify_arms,
)

__all__ = [
    "HISTORY_CSV",
    "HISTORY_FITS_CSV",
    "HISTORY_PNG",
    "HistoryRun",
    "history_summary",
    "log_dates",
    "run_history",
    "write_history_csv",
    "write_history_fits_csv",
]

HISTORY_CSV = "history.csv"
"""The per-parameter trend table's file name in the output folder."""
HISTORY_FITS_CSV = "history_fits.csv"
"""The per-fit table's file name in the output folder."""
HISTORY_PNG = "history.png"
"""The figure's file name in the output folder."""
_DATE = re.compile(r"(?<!\d)(\d{4})-(\d{2})-(\d{2})(?!\d)")


def log_dates(logs: Sequence[str | os.PathLike]) -> list[dt.date]:
    """Each log's date: the one ``YYYY-MM-DD`` in its file name's stem
    (``arm3_2026-01-15.csv`` -> 2026-01-15).

    Raises:
      ValueError: one line: a stem with no date, two dates, or a date that
        is not one (2026-02-30).
    """
    out = []
    for log in map(Path, logs):
        found = _DATE.findall(log.stem)
        if len(found) != 1:
            raise ValueError(
                f"--history: log {log.name}: expected one date YYYY-MM-DD in its "
                f"name (arm3_2026-01-15.csv), found {len(found)}"
            )
        try:
            out.append(dt.date(*map(int, found[0])))
        except ValueError as e:
            raise ValueError(f"--history: log {log.name}: {e}") from None
    return out


@dataclasses.dataclass(frozen=True)
class HistoryRun:
    """What :func:`run_history` did.

    Attributes:
      fits: one result per log, in date order.
      dates: (n,) their dates.
      trend: the trend of the fits identified (None: fewer than MIN_FITS or
        one date).
      csv, fits_csv, figure: the files written (figure None without a trend).
    """

    fits: tuple[ArmResult, ...]
    dates: tuple[dt.date, ...]
    trend: HistoryTrend | None
    csv: Path
    fits_csv: Path
    figure: Path | None

    @property
    def failed(self) -> list[ArmResult]:
        """The logs not identified (failed or refused)."""
        return [a for a in self.fits if not a.ok]


def history_summary(run: HistoryRun) -> str:
    """The final line: ``history: 6 fits over 5.0 months, 1 flagged: joint 3
    viscous friction +11 % since the first fit (+26.4 %/year, 11.0 sigma)``,
    then the failed fits."""
    ok = [d for d, a in zip(run.dates, run.fits, strict=True) if a.ok]
    months = (ok[-1] - ok[0]).days / DAYS_PER_YEAR * 12.0 if ok else 0.0
    text = f"history: {len(ok)} fit{'s' * (len(ok) != 1)} over {months:.1f} months, "
    if run.trend is None:
        text += f"no trend (it needs {MIN_FITS} fits on 2 dates or more)"
    elif run.trend.flagged:
        flags = run.trend.flagged
        text += f"{len(flags)} flagged: " + ", ".join(f.text() for f in flags)
    else:
        text += "none flagged"
    if run.failed:
        text += f"; {len(run.failed)} failed: " + ", ".join(
            f"{a.arm} ({a.status}: {a.reason})" for a in run.failed
        )
    return text


def write_history_fits_csv(
    path: str | os.PathLike, fits: Sequence[ArmResult], dates: Sequence[dt.date]
) -> Path:
    """Writes one row per fit, in date order: ``date`` (ISO), ``fit`` (the
    log's stem), ``status``, ``reason``, ``log``, ``yaml``, then each base
    parameter NAME and ``NAME_std`` (SI; empty on a row that is not ok)."""
    names = next((a.names for a in fits if a.ok), ())
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["date", "fit", "status", "reason", "log", "yaml"]
                    + [c for n in names for c in (n, f"{n}_std")])  # fmt: skip
    for a, d in zip(fits, dates, strict=True):
        row = [d.isoformat(), a.arm, a.status, a.reason, a.log, a.yaml or ""]
        if a.ok:
            for v, s in zip(a.values, a.std, strict=True):
                row += [repr(float(v)), "" if np.isnan(s) else repr(float(s))]
        else:
            row += [""] * (2 * len(names))
        writer.writerow(row)
    return atomic_write_text(path, buf.getvalue())


def write_history_csv(path: str | os.PathLike, trend: HistoryTrend | None) -> Path:
    """Writes one row per base parameter, flagged ones first (in the order
    of :attr:`~rmdrake.dynamics.history.HistoryTrend.flagged`), then the
    others by decreasing |sigma|: ``name``, ``words``, ``unit``, ``flagged``
    (1/0), ``sigma`` (signed), ``trend_per_year`` and ``trend_std_per_year``
    (SI unit per year), ``first`` and ``last`` (the fitted line at the first
    and last dates, SI), ``relative_change`` (last / first - 1, empty where
    first is not clear of zero), ``scatter`` (sqrt of the reduced chi-square
    about the line), ``fits``. Only the header without a trend."""
    from rmdrake.dynamics.fleet import parameter_unit, parameter_words

    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["name", "words", "unit", "flagged", "sigma", "trend_per_year",
                     "trend_std_per_year", "first", "last", "relative_change",
                     "scatter", "fits"])  # fmt: skip
    if trend is not None:
        flags = {f.name: f for f in trend.flagged}
        rest = [k for k in np.argsort(-np.abs(trend.z), kind="stable")]
        order = [trend.names.index(n) for n in flags]
        order += [int(k) for k in rest if trend.names[k] not in flags]
        for k in order:
            name = trend.names[k]
            rel = flags[name].relative if name in flags else None
            if name not in flags and abs(trend.first[k]) > 0:
                rel = float(trend.last[k] / trend.first[k] - 1.0)
            writer.writerow([
                name, parameter_words(name), parameter_unit(name),
                int(name in flags), repr(round(float(trend.z[k]), 3)),
                repr(float(trend.trend[k])), repr(float(trend.trend_std[k])),
                repr(float(trend.first[k])), repr(float(trend.last[k])),
                "" if rel is None else repr(float(rel)),
                repr(round(float(trend.scatter[k]), 3)), len(trend.days),
            ])  # fmt: skip
    return atomic_write_text(path, buf.getvalue())


def run_history(
    robot: RobotModel,
    logs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    method: str = "wls",
    threshold: float | None = None,
    false_alarm: float = DEFAULT_FALSE_ALARM,
    execution: Execution | None = None,
    echo: Echo = print,
    **options: Any,
) -> HistoryRun:
    """Identifies each of one arm's dated logs, fits each base parameter's
    trend over them and flags those that drift; writes ``OUT/<stem>.yaml`` per
    log identified, ``OUT/history_fits.csv``, ``OUT/history.csv`` and
    ``OUT/history.png`` (each flagged parameter over time, or the three
    largest trends when none is); echoes each flag, the files and the summary
    (:func:`history_summary`, last).

    Args:
      robot: the robot (kinematics; its dynamics are the prior).
      logs: the arm's joint logs, each with its date in its name
        (:func:`log_dates`).
      out: the output folder (created if missing).
      method: one of :data:`~rmdrake.dynamics.fleet.FLEET_METHODS`.
      threshold: sigma over which a trend is flagged; None: the family-wise
        one of ``false_alarm`` over the base parameters.
      false_alarm: the chance that a constant arm raises any flag.
      execution: where the identifications run (default: in this process).
      options: log preparation and fit options, as for
        :func:`~rmdrake.pipelines.fleet.run_fleet`.

    Raises:
      ValueError: no logs, a log without a date in its name, two logs of one
        stem, fewer than MIN_FITS logs or one date, an option out of bounds
        (:func:`~rmdrake.pipelines.fleet.check_fleet_options`), an output
        that cannot be written (all before any identification).
    """
    check_fleet_options(method, threshold, options)
    if not logs:
        raise ValueError("logs: no joint log given; nothing to identify")
    dates = log_dates(logs)
    if len(logs) < MIN_FITS or len(set(dates)) < 2:
        raise ValueError(
            f"--history: {len(logs)} log(s) on {len(set(dates))} date(s); a trend "
            f"needs at least {MIN_FITS} logs on 2 dates or more"
        )
    order = sorted(range(len(logs)), key=lambda i: (dates[i], str(logs[i])))
    logs = [logs[i] for i in order]
    dates = [dates[i] for i in order]
    folder = Path(out)
    names = arm_names(logs)
    yamls = [folder / f"{name}.yaml" for name in names]
    table, fits_table = folder / HISTORY_CSV, folder / HISTORY_FITS_CSV
    figure = folder / HISTORY_PNG
    for path in [*yamls, table, fits_table, figure]:
        check_writable(path)
    fits = identify_arms(
        robot, logs, yamls, method=method, execution=execution, echo=echo,
        **options,
    )  # fmt: skip
    done = [i for i, a in enumerate(fits) if a.ok]
    trend = None
    if len(done) >= MIN_FITS and len({dates[i] for i in done}) >= 2:
        days = [dates[i].toordinal() for i in done]
        trend = compare_history(
            fits[done[0]].names,
            days,
            np.array([fits[i].values for i in done]),
            np.array([fits[i].std for i in done]),
            threshold=threshold,
            false_alarm=false_alarm,
        )
    fits_path = write_history_fits_csv(fits_table, fits, dates)
    path = write_history_csv(table, trend)
    drawn = None
    if trend is not None:
        from rmdrake.report.plots import plot_history

        drawn = plot_history(trend, [dates[i] for i in done], figure)
        echo(trend.describe())
    elif figure.exists():  # an earlier run's: not this run's to delete
        echo(f"note: {figure} is an earlier run's (no trend this run); left as is")
    run = HistoryRun(tuple(fits), tuple(dates), trend, path, fits_path, drawn)
    for a in fits:
        if not a.ok:
            echo(f"{a.arm}: {a.status}: {a.reason}")
    for f in [] if trend is None else trend.flagged:
        echo(f"drifts: {f.text()}")
    files = ", ".join(str(p) for p in (path, fits_path, drawn) if p is not None)
    echo(f"wrote {files} and {len(done)} identified robot YAML(s) in {folder}")
    echo(history_summary(run))
    return run
