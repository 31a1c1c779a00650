"""``rmdrake fleet``: one joint log per arm in, one identified robot YAML per
arm and ``fleet.csv`` out, and which arm has drifted from the others.

Each log is one arm, named after the log's stem (``logs/arm_07.csv`` is arm
``arm_07``, written to ``OUT/arm_07.yaml``). Each arm's identification is a
task of :mod:`rmdrake.execution` (:func:`identify_arm`: the task gets the
robot model, which pickles, and paths, and runs
:func:`~rmdrake.pipelines.identify.identify_file` in its worker: reading,
preparation, fit, sanity checks and the atomic write of the YAML). An arm
whose log is bad or whose result the sanity checks refuse is a failed row,
with its reason, and the others go on.

The estimator is least squares (``wls``: Gautier's weighted least squares,
the default; or ``ols``), whose base parameters carry the standard deviations
of their covariance sigma^2 (A^T A)^-1, recorded in each YAML's
``calibration: base_parameters: {NAME: {value, std}}``: the comparison reads
them back from there. The ``physical`` fit is not offered: its regularisation
toward the prior (weighted by generalised cross-validation on a noisy log) can
pull a worn arm's parameters toward the nominal ones, and it records no
covariance. Each YAML's dynamics are still physically
consistent (the nearest model with exactly those base parameters, see
:func:`~rmdrake.dynamics.identification.identified_model`).

The comparison (:func:`~rmdrake.dynamics.fleet.compare_fleet`: the fleet's
median and robust spread, or a reference's parameters, and the combined
standard deviations) flags each parameter beyond the threshold, in words, and
``fleet.csv`` gets one row per arm (:func:`write_fleet_csv`).
"""

from __future__ import annotations

import csv
import dataclasses
import glob
import io
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.data import check_preparation
from rmdrake.dynamics.fleet import (
    DEFAULT_BUILD_DOF,
    DEFAULT_FALSE_ALARM,
    FLEET_METHODS,
    FleetComparison,
    build_spread_of,
    check_threshold,
    compare_fleet,
)
from rmdrake.errors import ImplausibleResultError, describe_error, one_line
from rmdrake.execution import Execution, TaskFailure, TaskRunner
from rmdrake.io.atomic import atomic_write_text, check_writable
from rmdrake.model.dynamic_parameters import extended_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.model.same_robot import check_same_robot
from rmdrake.pipelines.checked import Echo
from rmdrake.pipelines.identify import identify_file

__all__ = [
    "FEW_ARMS",
    "FLEET_CSV",
    "ArmResult",
    "ArmTask",
    "FleetRun",
    "arm_names",
    "check_fleet_options",
    "expand_logs",
    "fleet_summary",
    "identify_arm",
    "identify_arms",
    "robot_build_spread",
    "reference_parameters",
    "run_fleet",
    "write_fleet_csv",
]

FLEET_CSV = "fleet.csv"
"""The table's file name in the output folder."""
FEW_ARMS = 5
"""Fleet mode warns with fewer arms identified (their spread tells little)."""


@dataclasses.dataclass(frozen=True)
class ArmTask:
    """One arm's identification, as a task sent to a worker (plain data).

    Attributes:
      arm: the arm's name (its log's stem).
      log: the joint log's path.
      out: the identified robot YAML to write.
      robot: the robot (kinematics; dynamics = prior), a plain dataclass.
      method: one of :data:`FLEET_METHODS`.
      options: other keyword options of
        :func:`~rmdrake.pipelines.identify.identify_file` (log preparation:
        rate, cutoff, derivative_cutoff, time_window, coulomb_width in rad/s,
        decimate, idle_speed).
    """

    arm: str
    log: str
    out: str
    robot: RobotModel
    method: str = "wls"
    options: dict[str, Any] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class ArmResult:
    """One arm's outcome.

    Attributes:
      arm, log: as in :class:`ArmTask`.
      status: ``ok``, ``refused`` (the sanity checks refused the fit: nothing
        written) or ``failed`` (a bad log or option, or a worker lost).
      reason: one line, why not ``ok`` ("" when ok).
      yaml: the identified robot YAML written, or None.
      names: (p,) base parameter names (empty unless ok).
      values, std: (p,) the base parameters and their standard deviations,
        SI (None unless ok).
      warnings: the identification's warnings (unexplained shares).
    """

    arm: str
    log: str
    status: str
    reason: str = ""
    yaml: str | None = None
    names: tuple[str, ...] = ()
    values: np.ndarray | None = None
    std: np.ndarray | None = None
    warnings: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True when the arm was identified and written."""
        return self.status == "ok"


def identify_arm(task: ArmTask) -> ArmResult:
    """Identifies one arm (runs in a worker): writes its YAML and returns its
    base parameters and stds as read back from the YAML's record, or a failed
    result naming the reason (a refused fit, or a ValueError or OSError of the
    log or options, on one line)."""
    lines: list[str] = []
    try:
        path = identify_file(
            task.robot,
            task.log,
            task.out,
            method=task.method,
            echo=lines.append,
            **task.options,
        )
    except ImplausibleResultError as e:
        return ArmResult(task.arm, task.log, "refused", one_line(str(e)))
    except (ValueError, OSError) as e:
        return ArmResult(task.arm, task.log, "failed", one_line(describe_error(e)))
    record = load_robot(path).calibration or {}
    params = record.get("base_parameters") or {}
    values = np.array([float(v["value"]) for v in params.values()])
    std = np.array([float(v.get("std", np.nan)) for v in params.values()])
    return ArmResult(
        arm=task.arm,
        log=task.log,
        status="ok",
        yaml=str(path),
        names=tuple(params),
        values=values,
        std=std,
        warnings=tuple(w[len(_WARNING) :] for w in lines if w.startswith(_WARNING)),
    )


_WARNING = "warning: "  # how identify_file's echo starts a warning


def expand_logs(patterns: Sequence[str | os.PathLike]) -> list[Path]:
    """The log files of ``patterns``: each a path or a glob pattern
    (``logs/*.csv``; a pattern's matches sorted, folders left out), in order,
    each file once.

    Raises:
      ValueError: one line: a pattern or path that names no file.
    """
    out: list[Path] = []
    for pattern in patterns:
        text = os.fspath(pattern)
        if glob.has_magic(text):
            found = sorted(Path(p) for p in glob.glob(text) if os.path.isfile(p))
        else:
            found = [Path(text)] if os.path.lexists(text) else []
        if not found:
            raise ValueError(f"--logs {text!r}: no file matches; nothing to identify")
        out += [p for p in found if p not in out]
    return out


def arm_names(logs: Sequence[str | os.PathLike]) -> list[str]:
    """Each log's arm name: its file name without the suffix.

    Raises:
      ValueError: two logs with one name (both named): their YAMLs would be
        one file.
    """
    names: dict[str, Path] = {}
    for log in map(Path, logs):
        if log.stem in names:
            raise ValueError(
                f"logs {names[log.stem]} and {log}: both are arm '{log.stem}' "
                "(an arm is named after its log's stem); rename one"
            )
        names[log.stem] = log
    return list(names)


def robot_build_spread(robot: RobotModel, relative: float) -> np.ndarray:
    """Each base parameter's arm-to-arm standard deviation, SI, when every
    standard dynamic parameter of ``robot`` (inertias, first moments, mass,
    Ia, fv, fc of each link; not fcn, tau0) varies by ``relative`` of itself
    between arms, independently (as ``perturb --dynamics-std`` draws them):
    :func:`~rmdrake.dynamics.fleet.build_spread_of` on the regrouping of the
    robot's base parameters and terms.

    Raises:
      ValueError: a robot without dynamics, a relative spread < 0.
    """
    if robot.dynamics is None:
        raise ValueError(
            f"--build-spread: robot '{robot.name}' has no dynamics to take it of"
        )
    base = base_parameters(robot, terms=robot.dynamic_terms)
    chi = extended_parameters(robot)[: base.width]
    rel = np.zeros(base.width)
    rel[: 13 * robot.n_joints] = relative
    return build_spread_of(chi, base.K_full, rel)


def reference_parameters(
    robot: RobotModel, reference: RobotModel, names: Sequence[str]
) -> tuple[np.ndarray, np.ndarray | None]:
    """A known-good model's base parameters ``names`` (SI) and their stds.

    From the reference's ``calibration: base_parameters`` record when it is an
    identification of the same base parameters (stds when it recorded them,
    e.g. ``wls`` or ``ols``; else None); otherwise its dynamics regrouped with
    the base parameters of ``robot`` and its terms (stds None).

    Raises:
      ValueError: a reference of another robot
        (:func:`~rmdrake.model.same_robot.check_same_robot`: other joints or
        kinematics), a reference with neither, or base parameters other than
        ``names``.
    """
    check_same_robot(
        robot,
        reference,
        what="--reference",
        remedy=f"give an identification or model of robot '{robot.name}' (its "
        "arms are compared with it)",
    )
    names = tuple(names)
    record = (reference.calibration or {}).get("base_parameters")
    if isinstance(record, dict) and tuple(record) == names:
        values = np.array([float(v["value"]) for v in record.values()])
        if all("std" in v for v in record.values()):
            return values, np.array([float(v["std"]) for v in record.values()])
        return values, None
    if reference.dynamics is None:
        raise ValueError(
            f"--reference: robot '{reference.name}' has no dynamics and no "
            "identified base parameters to compare with"
        )
    if reference.n_joints != robot.n_joints:
        raise ValueError(
            f"--reference: robot '{reference.name}' has {reference.n_joints} "
            f"joints but robot '{robot.name}' has {robot.n_joints}"
        )
    base = base_parameters(robot, terms=robot.dynamic_terms)
    if base.names != names:
        raise ValueError(
            f"--reference: the base parameters of robot '{robot.name}' are not "
            "the arms' (other terms?)"
        )
    return base.regroup(extended_parameters(reference)[: base.width]), None


@dataclasses.dataclass(frozen=True)
class FleetRun:
    """What :func:`run_fleet` did.

    Attributes:
      arms: one result per log, in log order.
      comparison: the comparison of the arms identified (None: none was).
      csv: the table written.
    """

    arms: tuple[ArmResult, ...]
    comparison: FleetComparison | None
    csv: Path

    @property
    def failed(self) -> list[ArmResult]:
        """The arms not identified (failed or refused)."""
        return [a for a in self.arms if not a.ok]

    @property
    def flagged(self) -> dict[str, list]:
        """{arm: its :class:`~rmdrake.dynamics.fleet.Flag` list} of the
        flagged arms."""
        return {} if self.comparison is None else self.comparison.flagged


def fleet_summary(run: FleetRun) -> str:
    """The final line: ``fleet: 21 arms, 1 flagged: arm_07 (joint 3 viscous
    friction +48 % (6.2 sigma), ...)``, then the failed arms."""
    flagged = run.flagged
    text = f"fleet: {len(run.arms)} arm{'s' * (len(run.arms) != 1)}, "
    if flagged:
        text += f"{len(flagged)} flagged: " + ", ".join(
            f"{arm} ({', '.join(f.text() for f in flags)})"
            for arm, flags in flagged.items()
        )
    else:
        text += "none flagged"
    if run.failed:
        text += f"; {len(run.failed)} failed: " + ", ".join(
            f"{a.arm} ({a.status}: {a.reason})" for a in run.failed
        )
    return text


def write_fleet_csv(
    path: str | os.PathLike,
    arms: Sequence[ArmResult],
    comparison: FleetComparison | None,
) -> Path:
    """Writes the fleet table atomically: one row per arm, in log order.

    Columns: ``arm``, ``status`` (ok, refused, failed), ``flags`` (the
    flagged parameters in words, ``; ``-separated), ``reason`` (why not ok),
    ``largest_sigma`` and ``largest_sigma_parameter`` (the arm's parameter
    furthest from the centre, in sigma: :mod:`rmdrake.dynamics.fleet`),
    ``warnings``, ``log``,
    ``yaml``, then for each base parameter NAME its value ``NAME`` and its
    standard deviation ``NAME_std`` (SI units of the parameter; empty on a
    row that is not ok). Numbers in full precision (repr)."""
    names: tuple[str, ...] = comparison.names if comparison is not None else ()
    head = ["arm", "status", "flags", "reason", "largest_sigma"]
    head += ["largest_sigma_parameter", "warnings", "log", "yaml"]
    head += [c for n in names for c in (n, f"{n}_std")]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(head)
    for a in arms:
        row = [a.arm, a.status, "", a.reason, "", "", "; ".join(a.warnings)]
        row += [a.log, a.yaml or ""]
        if a.ok and comparison is not None:
            flags = comparison.flags(a.arm)
            row[2] = "; ".join(f.text() for f in flags)
            name, z = comparison.largest(a.arm)
            row[4], row[5] = repr(round(z, 3)), name
            for v, s in zip(a.values, a.std, strict=True):
                row += [repr(float(v)), "" if np.isnan(s) else repr(float(s))]
        else:
            row += [""] * (2 * len(names))
        writer.writerow(row)
    return atomic_write_text(path, buf.getvalue())


def identify_arms(
    robot: RobotModel,
    logs: Sequence[str | os.PathLike],
    yamls: Sequence[str | os.PathLike],
    *,
    method: str = "wls",
    execution: Execution | None = None,
    echo: Echo = print,
    **options: Any,
) -> tuple[ArmResult, ...]:
    """Identifies each log (:func:`identify_arm`, one task each on
    ``execution``) into its YAML; a task lost is a failed result, and the
    YAML of an arm not identified is not written (an earlier run's file there
    is left as it is: no command deletes a file it did not write; the arm's
    row says it failed). Named after each log's stem; results in log order."""
    names = arm_names(logs)
    tasks = [
        ArmTask(name, str(log), str(y), robot, method, dict(options))
        for name, log, y in zip(names, logs, yamls, strict=True)
    ]
    results: list[ArmResult | None] = [None] * len(tasks)
    ex = Execution(workers=0) if execution is None else execution
    with TaskRunner(ex, tasks=len(tasks), echo=echo) as runner:
        for i, out_i in runner.imap(identify_arm, tasks, desc="arms", failures=True):
            if isinstance(out_i, TaskFailure):
                out_i = ArmResult(tasks[i].arm, tasks[i].log, "failed", out_i.reason)
            results[i] = out_i
    return tuple(r for r in results if r is not None)


def run_fleet(
    robot: RobotModel,
    logs: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    method: str = "wls",
    threshold: float | None = None,
    false_alarm: float = DEFAULT_FALSE_ALARM,
    build_spread: float | None = None,
    build_dof: float = DEFAULT_BUILD_DOF,
    reference: RobotModel | None = None,
    execution: Execution | None = None,
    echo: Echo = print,
    **options: Any,
) -> FleetRun:
    """Identifies each log as one arm, compares the arms, writes
    ``OUT/<arm>.yaml`` per arm identified and ``OUT/fleet.csv``; echoes one line
    per flagged or failed arm, the files written and the summary
    (:func:`fleet_summary`, last).

    Args:
      robot: the robot (kinematics; its dynamics are the prior).
      logs: joint-log paths, one per arm (an arm is named after its log's stem).
      out: the output folder (created if missing).
      method: one of :data:`FLEET_METHODS`.
      threshold: sigma (:mod:`rmdrake.dynamics.fleet`) over which a
        parameter is flagged; None: the family-wise threshold of
        ``false_alarm`` over arms x parameters tests.
      false_alarm: the chance that a healthy fleet raises any flag.
      build_spread: the known build spread, relative (0.03: each standard
        dynamic parameter varies by 3 % between arms;
        :func:`robot_build_spread`), pooled with the fleet's with
        ``build_dof`` degrees of freedom; None: the fleet's alone.
      build_dof: its degrees of freedom (inf: taken as exact).
      reference: a known-good robot model to compare with instead of the
        fleet's median (:func:`reference_parameters`).
      execution: where the identifications run (default: in this process).
      options: log preparation and fit options of
        :func:`~rmdrake.pipelines.identify.identify_file` (rate, cutoff,
        derivative_cutoff, time_window, coulomb_width, decimate, idle_speed),
        the same for every arm.

    Returns:
      The run; it does not raise for failed arms (see :attr:`FleetRun.failed`).

    Raises:
      ValueError: no logs, two logs of one name, an unknown method, a
        threshold over :data:`~rmdrake.dynamics.fleet.MAX_THRESHOLD`, a
        preparation option out of bounds
        (:func:`~rmdrake.dynamics.data.check_preparation`), an output that
        cannot be written, a reference of another robot or that does not fit
        the arms, a build spread without dynamics (all before any
        identification).
    """
    check_fleet_options(method, threshold, options)
    if not logs:
        raise ValueError("logs: no joint log given; nothing to identify")
    folder = Path(out)
    names = arm_names(logs)
    yamls = [folder / f"{name}.yaml" for name in names]
    table = folder / FLEET_CSV
    for path in [*yamls, table]:
        check_writable(path)
    known = None  # the reference's (values, stds), checked before any work
    if reference is not None:
        base = base_parameters(robot, terms=robot.dynamic_terms)
        known = reference_parameters(robot, reference, base.names)
    build = None if build_spread is None else robot_build_spread(robot, build_spread)
    arms = identify_arms(
        robot, logs, yamls, method=method, execution=execution, echo=echo,
        **options,
    )  # fmt: skip
    name = None if reference is None else reference.name
    rule = {"threshold": threshold, "false_alarm": false_alarm,
            "build_spread": build, "build_dof": build_dof}  # fmt: skip
    comparison = _compare(robot, arms, rule, known, name)
    path = write_fleet_csv(table, arms, comparison)
    run = FleetRun(arms=arms, comparison=comparison, csv=path)
    if comparison is not None:
        echo(comparison.describe())
        few = len(comparison.arms)
        if reference is None and build is None and few < FEW_ARMS:
            echo(
                f"warning: {few} arm(s) identified: too few for the spread between "
                "arms to single one out (a ratio of 1000 is 4.4 sigma with 3); "
                "give the build spread (--build-spread), more arms or a --reference"
            )
    flagged = run.flagged
    for a, y in zip(arms, yamls, strict=True):
        if not a.ok:
            echo(f"{a.arm}: {a.status}: {a.reason}")
            if y.exists():  # not written in this run: not this run's to delete
                echo(f"note: {y} is an earlier run's, left as is (not this fit)")
        elif a.arm in flagged:
            echo(f"{a.arm}: " + ", ".join(f.text() for f in flagged[a.arm]))
    written = sum(a.ok for a in arms)
    echo(f"wrote {path} and {written} identified robot YAML(s) in {folder}")
    echo(fleet_summary(run))
    return run


def check_fleet_options(
    method: str, threshold: float | None, options: dict[str, Any]
) -> None:
    """Refuses, before any log is read, the options of :func:`run_fleet` (and
    the history's) that no arm could satisfy: an unknown ``method``, a
    ``threshold`` out of bounds (:func:`~rmdrake.dynamics.fleet.
    check_threshold`), a preparation option out of bounds
    (:func:`~rmdrake.dynamics.data.check_preparation`): one refusal instead
    of a failed row per arm.

    Raises:
      ValueError: one line naming the option and its bound."""
    if method not in FLEET_METHODS:
        raise ValueError(
            f"method: expected one of {', '.join(FLEET_METHODS)}, found {method!r}"
        )
    if threshold is not None:
        check_threshold(threshold)
    check_preparation(**options)


def _compare(
    robot: RobotModel,
    arms: Sequence[ArmResult],
    rule: dict[str, Any],
    known: tuple[np.ndarray, np.ndarray | None] | None,
    reference_name: str | None,
) -> FleetComparison | None:
    """The comparison of the arms identified (with the reference's values and
    stds ``known``, else the fleet's centre; ``rule``: compare_fleet's
    threshold, false_alarm, build_spread, build_dof), or None when none was."""
    done = [a for a in arms if a.ok]
    if not done:
        return None
    names = done[0].names
    for a in done[1:]:
        if a.names != names:
            raise ValueError(
                f"arms {done[0].arm} and {a.arm} have different base parameters"
            )
    ref, ref_std = (None, None) if known is None else known
    sigma = robot.sigma
    return compare_fleet(
        [a.arm for a in done],
        names,
        np.array([a.values for a in done]),
        np.array([a.std for a in done]),
        reference=ref,
        reference_std=ref_std,
        reference_name=reference_name or "reference",
        prismatic=None if sigma is None else np.asarray(sigma) == 1,
        **rule,
    )
