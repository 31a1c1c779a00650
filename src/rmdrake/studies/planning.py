"""Monte Carlo planning of a kinematic calibration: will a plan of readings
reach a tool accuracy on every arm built, and with what confidence?

The arms: N "true" arms drawn near the nominal robot as built within its
tolerances (:class:`PlanConfig`): every MDH error parameter of ``params`` gets
an independent zero-mean normal error, ``length_std`` (m) for the lengths
``dd<j>``, ``dr<j>`` and ``angle_std`` (rad) for the angles ``dalpha<j>``,
``dtheta<j>``, ``dbeta<j>``; on a robot with elastic joints each stiffness is
multiplied by exp(``stiffness_std`` N(0, 1)) (all three by
:func:`~rmdrake.model.perturb.perturb_robot`). Arm i is drawn from the seed
``task_seed(seed, i)`` (:func:`~rmdrake.execution.task_seed`), the same arm for
every plan variant.

The plans: range-finder readings on plates (``plates`` x ``per_plate``, noise
in m, :func:`~rmdrake.calibration.plates.simulate.simulate_plates`), tracker
points (``poses`` x ``markers``, noise in m per coordinate,
:func:`~rmdrake.calibration.points.simulate.simulate_points`), the poses
random or the D-optimal ones of a pool 4 times larger (``poses_from``),
planned with the nominal, or a ball seated in sockets (``placements`` of a
two-socket plate x 2 x ``per_socket`` configurations, seating noise in m per
coordinate, :func:`~rmdrake.calibration.sockets.simulate.simulate_sockets`;
random configurations only). ``readings`` sweeps the plan's size: for plates
the total readings (``per_plate`` = readings / ``plates``), for points the
poses, for sockets the configurations in all (``per_socket`` = readings / (2
``placements``)).

Each (arm, variant) is one task (:func:`plan_arm`), run where the
:class:`~rmdrake.execution.Execution` says: it takes the arm's readings,
calibrates the drawn parameters on them with LM (the project's calibrator:
:class:`~rmdrake.calibration.plates.estimators.PlaneLM` on plates, ``full``
its identifiable subset; :class:`~rmdrake.calibration.points.lm.PointLM` on
points, their identifiable subset: the instrument pose and the markers
absorb the base and tool frames; :class:`~rmdrake.calibration.sockets.lm.
SocketLM` on sockets, the subset they identify well: the socket points absorb
the base frame) and its sanity checks
against the declared noise (a refusal fails the arm), and measures the
tool-point error (m, in the base frame B) of the calibrated model against the
true arm at ``n_validation`` held-out joint positions uniform within the
limits (never seen by the calibration); after a best-fit rigid alignment when
some perturbed parameter is not identified (the base frame is then not
observable). Points: the tool point is the markers' centroid in E (a
tracker sees the markers, not the tool frame). Elastic robots: both models at
rest under gravity (link angles of :func:`~rmdrake.dynamics.compliance.
link_angles` at the same encoder angles, no payload).

An arm meets the target when its mean held-out error is at most ``target``
(m); a failed arm (no readings, a calibration that raised, did not converge or
was refused by its sanity checks, a task whose worker died) does not.
:func:`run_plan` writes into its folder:

- ``plan.yaml``: the config (written first; ``resume`` refuses another);
- ``robots.csv``: one row per (variant, arm): readings, arm, the arm's seed,
  every true error parameter by name (m or rad; ``k<j>`` the true stiffness,
  N m/rad or N/m, with ``stiffness_std``), the fitted set's size, the held-out
  error's mean, 95th percentile and max (m), status (``ok``/``failed``) and
  reason. Rows are appended as they arrive (one unbuffered write each), and
  rewritten at the end sorted by (readings, arm) with floats in ``repr``: the
  same config gives the same bytes whatever the workers;
- ``summary.yaml``: per variant the median, 95th percentile and worst of the
  arms' mean held-out error (m, over the arms that succeeded), the arms
  meeting the target and their fraction (with its one-sided 95 % Clopper-
  Pearson lower bound); and the recommendation: the fewest readings whose
  fraction is at least ``confidence``, or null with the reason;
- ``plan.png``: the arms' mean held-out errors per variant (log axis) and the
  target.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rmdrake.calibration.kind import PlanSizing, plan_count, reach_span
from rmdrake.calibration.registry import KINDS
from rmdrake.calibration.sanity import CalibrationBounds
from rmdrake.calibration.simulate import MAX_NOISE_SHARE, random_poses
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.errors import one_line
from rmdrake.execution import SERIAL, Execution, TaskFailure, TaskRunner, task_seed
from rmdrake.io.atomic import atomic_write_text
from rmdrake.io.paths import not_a_regular_file
from rmdrake.io.yaml import read_yaml
from rmdrake.limits import check_memory
from rmdrake.model.perturb import perturb_names, perturb_robot
from rmdrake.model.robot import RobotModel
from rmdrake.report.plots import plot_plan_errors

__all__ = [
    "MAX_TARGET_SHARE",
    "PLAN_KINDS",
    "POSES_FROM",
    "RESUME_SAMPLE",
    "ArmRow",
    "ArmTask",
    "PlanConfig",
    "PlanResult",
    "PlanVariant",
    "TrueArm",
    "draw_arm",
    "plan_arm",
    "plan_line",
    "run_plan",
    "summarise_plan",
]

PLAN_KINDS: tuple[str, ...] = tuple(KINDS)
"""The measurements a plan takes: range-finder readings on plates, tracker
points of markers on the tool, or a ball on the tool seated in sockets."""
POSES_FROM: tuple[str, ...] = ("random", "d-optimal")
"""How a plan's poses are chosen: random valid ones, or the D-optimal ones of
a pool 4 times larger, planned with the nominal."""

MAX_TARGET_SHARE = 0.1
"""The largest ``target`` (m), as a share of the robot's reach: a mean tool
error of a tenth of the arm is no calibration's goal (``--target 10`` on a
1.2 m arm is a target in mm or cm given as m)."""
RESUME_SAMPLE = 3
"""The ``ok`` rows of a resumed ``robots.csv`` recomputed in full from their
seeds (a sample seeded by the file's bytes): a row whose held-out errors
were edited is refused when drawn."""

_FILES = ("plan.yaml", "robots.csv", "summary.yaml", "plan.png")
_CRITERION = (
    "an arm meets the target when the mean of its tool-point errors at the "
    "held-out poses (m) is at most the target; a failed arm does not"
)


PlanVariant = PlanSizing
"""One size of the plan: a kind's :class:`~rmdrake.calibration.kind.
PlanSizing` (``readings``, ``describe()``; plates: ``plates`` x
``per_plate``, points: ``poses`` x ``markers``, sockets: ``placements`` x 2
x ``per_socket``)."""


def _finite(value: Any, what: str, low: float, *, strict: bool = False) -> float:
    """``value`` as a finite float >= ``low`` (> with ``strict``)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected a number, found {value!r}") from None
    if not math.isfinite(v) or v < low or (strict and v == low):
        sign = ">" if strict else ">="
        raise ValueError(f"{what}: expected a finite number {sign} {low:g}, found {v}")
    return v


@dataclasses.dataclass(frozen=True, kw_only=True, eq=False)
class PlanConfig:
    """A calibration plan to try on many arms (see the module docstring).

    Attributes:
      robot: the nominal robot (what every calibration starts from).
      robots: arms drawn.
      plan: the measurements, one kind's plan
        (:class:`~rmdrake.calibration.plates.plan.PlatePlan`: plate
        locations and readings per plate;
        :class:`~rmdrake.calibration.points.plan.PointPlan`: robot poses and
        markers on the tool; :class:`~rmdrake.calibration.sockets.plan.
        SocketPlan`: placements of a two-socket plate and seated
        configurations per socket; ``KINDS[name].plan(size)`` of
        :data:`rmdrake.calibration.registry.KINDS`).
      noise: the instrument's standard deviation, m (range finder: per
        reading; tracker and sockets: per coordinate); declared to the sanity
        checks.
      length_std: m, std of the true length errors (``dd<j>``, ``dr<j>``).
      angle_std: rad, std of the true angle errors (``dalpha<j>``,
        ``dtheta<j>``, ``dbeta<j>``).
      stiffness_std: std of log k of each elastic joint (dimensionless);
        robots with elastic joints only.
      params: the error parameters drawn (``paper``, ``full`` or comma
        names) and fitted (``full`` and points: their identifiable subset).
      readings: the plan sizes swept (plates: readings in all, each a
        multiple of ``plates``, overriding ``per_plate``; points: poses,
        overriding ``poses``; sockets: configurations in all, each a multiple
        of 2 ``placements``, overriding ``per_socket``); empty: the one plan
        of ``plan``.
      poses_from: ``random`` or ``d-optimal`` (:data:`POSES_FROM`).
      target: m, the mean held-out tool-point error an arm must reach.
      confidence: the fraction of arms that must reach it, in (0, 1): the
        recommendation asks the fraction's one-sided 95 % lower bound to
        reach it.
      seed: the plan's seed (arm i: ``task_seed(seed, i)``).
      n_validation: held-out joint positions per arm.

    Raises:
      ValueError: (one line) a bad count, std, noise or confidence, a target
        over :data:`MAX_TARGET_SHARE` of the robot's reach; an
        unknown pose choice or parameter name, or one the plan cannot take; a
        readings count the plan cannot divide or given twice;
        ``stiffness_std`` on a robot without elastic joints.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import KINDS
    >>> from rmdrake.studies import PlanConfig
    >>> config = PlanConfig(robot=load_robot("rv3sb"), robots=200, noise=2e-6,
    ...                     plan=KINDS["plates"].plan(5, 12), target=5e-5)
    >>> config.robots, config.params
    (200, 'paper')
    """

    robot: RobotModel
    robots: int
    noise: float
    plan: PlanSizing
    length_std: float = 0.0
    angle_std: float = 0.0
    stiffness_std: float = 0.0
    params: str = "paper"
    readings: tuple[int, ...] = ()
    poses_from: str = "random"
    target: float = 1e-4
    confidence: float = 0.95
    seed: int = 0
    n_validation: int = 200

    def __post_init__(self) -> None:
        if not isinstance(self.plan, PlanSizing):
            raise ValueError(
                f"plan: expected the plan of a kind ({', '.join(PLAN_KINDS)}), "
                f"found {self.plan!r}"
            )
        if self.poses_from not in POSES_FROM:
            raise ValueError(
                f"poses_from: expected one of {', '.join(POSES_FROM)}, found "
                f"{self.poses_from!r}"
            )
        self.plan.check(self.poses_from)
        plan_count(self.robots, "robots")
        plan_count(self.n_validation, "n_validation")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise ValueError(f"seed: expected an integer >= 0, found {self.seed!r}")
        if self.seed < 0:
            raise ValueError(f"seed: expected an integer >= 0, found {self.seed}")
        _finite(self.noise, "noise", 0.0)
        _finite(self.target, "target", 0.0, strict=True)
        confidence = _finite(self.confidence, "confidence", 0.0, strict=True)
        if confidence >= 1:
            raise ValueError(
                f"confidence: {confidence:g}: expected 0 < value < 1 (no number of "
                "arms shows 100 %: the 95 % lower bound of N arms of N is "
                "0.05^(1/N)); give e.g. 0.99"
            )
        readings = tuple(plan_count(r, "readings") for r in self.readings)
        if len(set(readings)) != len(readings):
            raise ValueError(f"readings: a count given twice in {list(readings)}")
        for r in readings:
            self.plan.sized(r)  # one the plan cannot divide fails here
        object.__setattr__(self, "readings", tuple(sorted(readings)))
        self._check_sizes()
        perturb_names(self.robot, self.params)  # an unknown name fails here
        if self.length_std or self.angle_std or self.stiffness_std:
            self.perturbed(0)  # the stds checked by perturb_robot itself

    def _check_sizes(self) -> None:
        """Refuses a target over :data:`MAX_TARGET_SHARE` of the robot's
        reach, a noise no instrument of the plan gives, and sizes whose tasks,
        readings or held-out poses would not fit in memory."""
        noise = float(self.noise)
        reach, of_robot = reach_span(self.robot)
        if float(self.target) > MAX_TARGET_SHARE * reach:
            raise ValueError(
                f"target: {float(self.target):g} m is over {MAX_TARGET_SHARE:g} of "
                f"{of_robot} ({reach:.3g} m): the target is a mean tool error in m "
                "(1e-4 = 0.1 mm); mm? give m"
            )
        span, of = self.plan.noise_span(self.robot)
        limit = MAX_NOISE_SHARE * span
        if noise > limit:
            raise ValueError(
                f"noise: {noise:g} m is over {MAX_NOISE_SHARE:g} of {of} "
                f"({limit / MAX_NOISE_SHARE:.3g} m); the noise is a standard "
                "deviation in m"
            )
        variants = self.variants
        n = self.robot.n_joints
        check_memory(
            float(self.robots) * len(variants),
            f"{self.robots} arms x {len(variants)} plans",
            "fewer arms or plan sizes",
            itemsize=4096,  # a task and its row
        )
        most = max(v.readings for v in variants) * self.plan.per_reading
        check_memory(float(most) * 4 * (n + 32), f"{most} readings", "fewer readings")
        check_memory(
            float(self.n_validation) * (n + 40),
            f"{self.n_validation} held-out poses",
            "fewer held-out poses",
        )

    @property
    def kind(self) -> str:
        """The plan's measurement kind (:data:`PLAN_KINDS`)."""
        return self.plan.kind

    @property
    def variants(self) -> tuple[PlanSizing, ...]:
        """The plan sizes, fewest readings first."""
        return tuple(self.plan.sized(r) for r in self.readings) or (self.plan,)

    @property
    def names(self) -> list[str]:
        """The error parameters drawn (m or rad), in ``params``' order."""
        return perturb_names(self.robot, self.params)

    @property
    def stiffness_columns(self) -> list[str]:
        """``k<j>`` of each elastic joint when ``stiffness_std`` > 0, else none."""
        c = self.robot.compliance
        if not self.stiffness_std or c is None:
            return []
        return [f"k{j + 1}" for j in np.flatnonzero(c.elastic)]

    @property
    def columns(self) -> list[str]:
        """The header of ``robots.csv``."""
        return [
            "readings",
            "arm",
            "seed",
            *self.names,
            *self.stiffness_columns,
            "fitted",
            "held_out_mean",
            "held_out_p95",
            "held_out_max",
            "status",
            "reason",
        ]

    def perturbed(self, seed: int) -> tuple[RobotModel, dict[str, float]]:
        """:func:`~rmdrake.model.perturb.perturb_robot` of the robot with
        these tolerances and ``seed``: (the true robot, {name: delta in m or
        rad} of the errors drawn with a std > 0)."""
        return perturb_robot(
            self.robot,
            params=self.params,
            length_std=self.length_std,
            angle_std=self.angle_std,
            stiffness_std=self.stiffness_std,
            seed=seed,
        )

    def record(self) -> dict[str, Any]:
        """The plan as plain data (``plan.yaml``): ``rows`` (what the rows of
        ``robots.csv`` depend on: the robot, the tolerances, the plans, the
        seed) and ``criterion`` (target, m, and confidence: the summary
        only)."""
        plan: dict[str, Any] = {"kind": self.kind, **self.plan.record()}
        plan.update(
            readings=[v.readings for v in self.variants],  # per_plate, poses
            poses_from=self.poses_from,
            noise=float(self.noise),
        )
        rows = {
            "robots": self.robots,
            "seed": int(self.seed),
            "validation": self.n_validation,
            "tolerances": {
                "params": self.params,
                "length_std": float(self.length_std),
                "angle_std": float(self.angle_std),
                "stiffness_std": float(self.stiffness_std),
            },
            "plan": plan,
            "robot": self.robot.to_dict(),
        }
        criterion = {
            "target": float(self.target),
            "confidence": float(self.confidence),
        }
        return {"rows": rows, "criterion": criterion}


@dataclasses.dataclass(frozen=True)
class TrueArm:
    """One arm as built (:func:`draw_arm`).

    Attributes:
      arm: its index.
      seed: its seed, ``task_seed(config.seed, arm)``.
      robot: the true robot.
      deltas: every drawn error parameter by name, m or rad (0 when its std
        is 0).
      stiffness: ``k<j>`` -> the true stiffness, N m/rad or N/m (with
        ``stiffness_std`` only).
      streams: three seeds spawned from ``seed``: the errors, the readings and
        the held-out poses.
    """

    arm: int
    seed: int
    robot: RobotModel
    deltas: dict[str, float]
    stiffness: dict[str, float]
    streams: tuple[int, int, int]

    @property
    def values(self) -> tuple[float, ...]:
        """The true parameters in ``robots.csv``'s column order."""
        return (*self.deltas.values(), *self.stiffness.values())


def draw_arm(config: PlanConfig, arm: int) -> TrueArm:
    """Arm ``arm`` of the plan: the same robot for every plan variant.

    Its seed ``task_seed(config.seed, arm)`` spawns three independent streams
    (``numpy.random.SeedSequence(seed).spawn(3)``): the errors (given to
    :func:`~rmdrake.model.perturb.perturb_robot`), the readings and the
    held-out poses. With every std 0 the arm is the nominal.
    """
    seed = task_seed(config.seed, arm)
    errors, readings, held_out = (
        int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(3)
    )
    names = config.names
    true, drawn = config.robot, {}
    if config.length_std or config.angle_std or config.stiffness_std:
        true, drawn = config.perturbed(errors)
    deltas = {n: float(drawn.get(n, 0.0)) for n in names}
    stiffness = {}
    if config.stiffness_columns:
        k = true.compliance.stiffness
        stiffness = {c: float(k[int(c[1:]) - 1]) for c in config.stiffness_columns}
    return TrueArm(arm, seed, true, deltas, stiffness, (errors, readings, held_out))


@dataclasses.dataclass(frozen=True)
class ArmTask:
    """One task of a plan: arm ``arm`` with plan variant ``variant`` (an index
    into ``config.variants``). Plain data: it pickles to a worker."""

    config: PlanConfig
    arm: int
    variant: int


@dataclasses.dataclass(frozen=True)
class ArmRow:
    """One row of ``robots.csv``.

    Attributes:
      readings: the variant's readings (plates) or poses (points).
      arm, seed: the arm and its seed.
      true: the true parameters, in the columns' order (m, rad; N m/rad).
      fitted: the calibrated parameters' count (None: no fit).
      mean, p95, max: the held-out tool-point error, m (None: failed).
      status: ``ok`` or ``failed``.
      reason: why it failed (one line), empty when ok.
    """

    readings: int
    arm: int
    seed: int
    true: tuple[float, ...]
    fitted: int | None
    mean: float | None
    p95: float | None
    max: float | None
    status: str
    reason: str = ""

    @property
    def ok(self) -> bool:
        """The arm was calibrated and measured."""
        return self.status == "ok"

    def line(self) -> str:
        """The CSV line, newline included (floats in ``repr``: exact)."""

        def num(v: float | None) -> str:
            return "" if v is None else repr(float(v))

        cells = [str(self.readings), str(self.arm), str(self.seed)]
        cells += [repr(float(v)) for v in self.true]
        cells += ["" if self.fitted is None else str(self.fitted)]
        cells += [num(self.mean), num(self.p95), num(self.max)]
        cells += [self.status, one_line(self.reason)]
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(cells)
        return buf.getvalue()

    @classmethod
    def parse(cls, cells: list[str], n_true: int) -> ArmRow:
        """The row of a line's cells (:meth:`line`'s); ValueError if malformed."""
        if len(cells) != n_true + 9:
            raise ValueError(f"{len(cells)} cells, expected {n_true + 9}")

        def num(text: str) -> float | None:
            return None if text == "" else float(text)

        status = cells[-2]
        if status not in ("ok", "failed"):
            raise ValueError(f"status {status!r}: expected ok or failed")
        head, tail = cells[3 : 3 + n_true], cells[3 + n_true :]
        return cls(
            readings=int(cells[0]),
            arm=int(cells[1]),
            seed=int(cells[2]),
            true=tuple(float(v) for v in head),
            fitted=None if tail[0] == "" else int(tail[0]),
            mean=num(tail[1]),
            p95=num(tail[2]),
            max=num(tail[3]),
            status=status,
            reason=cells[-1],
        )


def _failed(
    task: ArmTask, arm: TrueArm, reason: str, fitted: int | None = None
) -> ArmRow:
    """The ``failed`` row of ``task`` on ``arm``."""
    variant = task.config.variants[task.variant]
    return ArmRow(
        variant.readings,
        arm.arm,
        arm.seed,
        arm.values,
        fitted,
        *(None,) * 3,
        "failed",
        reason,
    )


def plan_arm(task: ArmTask) -> ArmRow:
    """One arm with one plan variant (see the module docstring): draws the
    arm (:func:`draw_arm`), simulates its readings, calibrates with LM and the
    sanity checks against the declared noise, and measures its held-out
    tool-point error (m). Expected failures (readings not found, a fit that
    raises, does not converge or is refused) are a ``failed`` row with the
    reason; anything else raises (the runner makes it a failed row)."""
    config = task.config
    arm = draw_arm(config, task.arm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the row says what went wrong
        try:
            sim = _readings(task, arm)
        except (ValueError, np.linalg.LinAlgError) as e:
            return _failed(task, arm, f"readings: {e}")
        try:
            est, names = _calibrate(task, arm, sim)
        except (ValueError, np.linalg.LinAlgError) as e:
            return _failed(task, arm, f"calibration: {e}")
        fitted = len(est.names_)
        if not est.result_.success:
            why = f"calibration: LM did not converge ({est.result_.message})"
            return _failed(task, arm, why, fitted)
        sanity = est.sanity_  # against the declared noise (_calibrate's config)
        if not sanity.ok:
            why = "sanity: " + "; ".join(sanity.reasons)
            return _failed(task, arm, why, fitted)
        q_val = random_poses(config.robot, config.n_validation, arm.streams[2])
        markers = task.config.variants[task.variant].tool_points(est, sim)
        align = bool(set(names) - set(est.names_))
        err = tool_point_errors(
            est.model_, arm.robot, q_val, align=align, at_rest=True, **markers
        )
    return ArmRow(
        task.config.variants[task.variant].readings,
        arm.arm,
        arm.seed,
        arm.values,
        fitted,
        err.mean,
        float(np.percentile(err.errors, 95)),
        err.max,
        "ok",
    )


def _readings(task: ArmTask, arm: TrueArm) -> Any:
    """The simulated readings of ``arm`` with ``task``'s plan (seeded by the
    arm's readings stream; D-optimal poses planned with the nominal)."""
    config = task.config
    variant = config.variants[task.variant]
    return variant.simulate(
        arm.robot, config.noise, arm.streams[1], config.poses_from, config.robot
    )


def _calibrate(task: ArmTask, arm: TrueArm, sim: Any) -> tuple[Any, list[str]]:
    """(the fitted LM estimator, the drawn names) of an arm's readings, fitted
    as ``rmdrake calibrate --method lm --params PARAMS --noise NOISE`` would
    (the plan's :meth:`~rmdrake.calibration.kind.PlanSizing.calibrator`:
    plates the drawn names or ``full``, points and sockets the subset of the
    drawn names they identify at the nominal)."""
    config = task.config
    names = list(arm.deltas)
    noise = config.noise if config.noise > 0 else None
    variant = config.variants[task.variant]
    est = variant.calibrator(config.robot, sim, names, config.params, noise)
    return est.fit(sim.data), names


# ---- the plan's files ------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class PlanResult:
    """Outcome of :func:`run_plan`.

    Attributes:
      rows: every row, sorted by (readings, arm).
      summary: the content of ``summary.yaml``.
      line: the recommendation in one line (:func:`plan_line`).
      files: ``robots.csv``, ``summary.yaml``, ``plan.png``, ``plan.yaml``.
      ran: tasks run by this call (the others were in ``robots.csv``).
    """

    rows: list[ArmRow]
    summary: dict[str, Any]
    line: str
    files: dict[str, Path]
    ran: int


def _percent(fraction: float) -> str:
    """``97``, ``94.5``: the percentage rounded down to 0.1 (never shows a
    fraction under the confidence as reaching it)."""
    return f"{math.floor(1000 * fraction + 1e-9) / 10:g}"


def _lower_bound(meeting: int, arms: int) -> float:
    """One-sided 95 % Clopper-Pearson lower bound of a binomial fraction."""
    import scipy.stats

    if meeting == 0:
        return 0.0
    return float(scipy.stats.beta.ppf(0.05, meeting, arms - meeting + 1))


def _arms_needed(confidence: float) -> int:
    """The fewest arms whose 95 % lower bound reaches ``confidence`` (in (0,
    1)) when every one meets the target: 0.05^(1/N) >= confidence."""
    return max(1, math.ceil(math.log(0.05) / math.log(confidence) - 1e-9))


def summarise_plan(config: PlanConfig, rows: list[ArmRow]) -> dict[str, Any]:
    """The content of ``summary.yaml`` (plain data; errors in m, the
    statistics over the arms that succeeded; see the module docstring). The
    recommendation is the fewest readings whose fraction's one-sided 95 %
    lower bound (``fraction_lower_95``) is at least ``confidence``: what the
    arms drawn show, not the share they happened to give."""
    variants = []
    for v in config.variants:
        mine = [r for r in rows if r.readings == v.readings]
        ok = np.array([r.mean for r in mine if r.ok], dtype=np.float64)
        meeting = int(np.sum(ok <= config.target))
        reasons: dict[str, int] = {}
        for r in mine:
            if not r.ok:
                reasons[r.reason] = reasons.get(r.reason, 0) + 1
        top = sorted(reasons.items(), key=lambda kv: (-kv[1], kv[0]))[:5]
        entry: dict[str, Any] = {"readings": v.readings, "plan": v.describe()}
        entry.update(v.summary())
        entry.update(
            arms=len(mine),
            ok=int(ok.size),
            failed=len(mine) - int(ok.size),
            median=float(np.median(ok)) if ok.size else None,
            p95=float(np.percentile(ok, 95)) if ok.size else None,
            worst=float(np.max(ok)) if ok.size else None,
            meeting=meeting,
            fraction=meeting / len(mine) if mine else 0.0,
            fraction_lower_95=_lower_bound(meeting, len(mine)),
            failures=[{"reason": k, "arms": n} for k, n in top],
        )
        variants.append(entry)
    best = next(
        (e for e in variants if e["fraction_lower_95"] >= config.confidence), None
    )
    reason = None
    if best is None:
        top = max(variants, key=lambda e: (e["fraction"], -e["readings"]))
        reason = (
            f"no plan meets the target on >= {_percent(config.confidence)} % of "
            f"{config.robots} arm{'s' * (config.robots != 1)}; the best, "
            f"{top['plan']}, on "
            f"{_percent(top['fraction'])} % (95 % lower bound "
            f"{_percent(top['fraction_lower_95'])} %)"
        )
        need = _arms_needed(config.confidence)
        if config.robots < need:
            reason += (
                f"; {config.robots} arm{'s' * (config.robots != 1)} cannot show "
                f"{_percent(config.confidence)} "
                f"% even if all meet it: raise --robots to >= {need}"
            )
    recommendation = None
    if best is not None:
        recommendation = {
            k: best[k] for k in ("readings", "plan", "fraction", "fraction_lower_95")
        }
    return {
        "robot": config.robot.name,
        "kind": config.kind,
        "arms": config.robots,
        "target": float(config.target),
        "confidence": float(config.confidence),
        "criterion": _CRITERION,
        "units": "errors in m (mean, 95th percentile and worst over the arms "
        "that succeeded, of each arm's mean held-out tool-point error)",
        "variants": variants,
        "recommendation": recommendation,
        "reason": reason,
    }


def plan_line(summary: dict[str, Any]) -> str:
    """The recommendation of a summary in one line, e.g. ``plan: 60 readings
    (5 plates x 12) meet 0.05 mm on 99 % of 200 arms (95 % lower bound 97.6 %
    >= 95 %)``."""
    target = f"{summary['target'] * 1e3:g} mm"
    arms, want = summary["arms"], _percent(summary["confidence"])
    best = summary["recommendation"]
    if best is not None:
        return (
            f"plan: {best['plan']} meet {target} on {_percent(best['fraction'])} % "
            f"of {arms} arm{'s' * (arms != 1)} (95 % lower bound "
            f"{_percent(best['fraction_lower_95'])} % >= {want} %)"
        )
    return f"plan: {summary['reason'].replace('the target', target, 1)}"


def _table(summary: dict[str, Any]) -> list[str]:
    """The variants, one line each, errors in mm."""

    def mm(v: float | None) -> str:
        return f"{v * 1e3:9.4f}" if v is not None else f"{'-':>9}"

    lines = [
        f"{'plan':<32} {'arms':>5} {'failed':>6} {'median':>9} {'p95':>9} "
        f"{'worst':>9} {'meeting':>8}   (mean held-out error per arm, mm)"
    ]
    for e in summary["variants"]:
        lines.append(
            f"{e['plan']:<32} {e['arms']:5d} {e['failed']:6d} {mm(e['median'])} "
            f"{mm(e['p95'])} {mm(e['worst'])} {_percent(e['fraction']):>6} %"
        )
    return lines


def _first_difference(a: Any, b: Any, where: str = "") -> str | None:
    """The first key path at which two plain-data trees differ, or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if k not in a or k not in b:
                return f"{where}{k}"
            found = _first_difference(a[k], b[k], f"{where}{k}.")
            if found is not None:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            found = _first_difference(x, y, f"{where}{i}.")
            if found is not None:
                return found
        return None
    return None if a == b else where.rstrip(".") or "(the whole file)"


def _read_rows(path: Path, config: PlanConfig) -> dict[tuple[int, int], ArmRow]:
    """The complete rows of an interrupted ``robots.csv``, by (readings,
    arm), each checked against the plan (:func:`_check_row`: its true
    parameters drawn again from its seed, its errors those of a calibrated
    arm) and :data:`RESUME_SAMPLE` of its ``ok`` rows recomputed in full; a
    last line without its newline (cut by the interrupt) is dropped from the
    file (atomically, once every row passed).

    Raises:
      ValueError: a file that is not a regular one or is larger than this
        plan's rows can be; a header or a row that is not this plan's (one
        line, naming the line).
    """
    _check_regular(path, "--resume reads the plan's robots.csv", _csv_cap(config))
    text = path.read_text(encoding="utf-8")
    cut = bool(text) and not text.endswith("\n")
    if cut:
        text = text[: text.rfind("\n") + 1]
    lines = text.splitlines()
    header = ",".join(config.columns)
    if not lines or lines[0] != header:
        raise ValueError(
            f"{path}: its header is not that of this plan ({len(config.columns)} "
            "columns: readings,arm,seed,<the drawn parameters>,fitted,...); resume "
            "with the plan's own options, or choose another --out"
        )
    sizes = {v.readings: i for i, v in enumerate(config.variants)}
    rows: dict[tuple[int, int], ArmRow] = {}
    numbers: dict[tuple[int, int], int] = {}
    arms: dict[int, TrueArm] = {}
    n_true = len(config.names) + len(config.stiffness_columns)
    for number, line in enumerate(lines[1:], start=2):
        where = f"{path}: line {number}"
        try:
            row = ArmRow.parse(next(csv.reader([line])), n_true)
        except (ValueError, StopIteration) as e:
            raise ValueError(f"{where}: not a row of a plan: {e}") from None
        if row.readings not in sizes or not 0 <= row.arm < config.robots:
            raise ValueError(
                f"{where}: readings {row.readings}, arm {row.arm} is not a task of "
                "this plan"
            )
        if row.seed != task_seed(config.seed, row.arm):
            raise ValueError(f"{where}: arm {row.arm}'s seed is not this plan's")
        if row.arm not in arms:
            arms[row.arm] = draw_arm(config, row.arm)
        _check_row(row, arms[row.arm], where)
        key = (row.readings, row.arm)
        if key in rows and rows[key] != row:
            raise ValueError(
                f"{where}: a second, different row of readings {row.readings}, arm "
                f"{row.arm} (line {numbers[key]}): not this plan's file; delete it "
                "or choose another --out"
            )
        rows.setdefault(key, row)
        numbers.setdefault(key, number)
    _recompute_sample(config, rows, numbers, path, text)
    if cut:
        atomic_write_text(path, text)
    return rows


def _csv_cap(config: PlanConfig) -> int:
    """The largest ``robots.csv`` this plan's rows can make, bytes: 64 KiB a
    row (a row is a few hundred bytes; its reason at most a few kB), 1 MiB
    at least."""
    tasks = config.robots * len(config.variants)
    return 2**20 + tasks * 2**16


def _check_regular(path: Path, what: str, cap: int) -> None:
    """Refuses a ``path`` that is not a regular file (a FIFO, ``/dev/zero``, a
    folder: reading it would hang or never end) or is over ``cap`` bytes."""
    reason = not_a_regular_file(path)
    if reason is not None:
        raise ValueError(f"{path}: {reason}; {what}")
    info = os.stat(path)
    if info.st_size > cap:
        raise ValueError(
            f"{path}: {info.st_size} bytes is over the {cap} this plan's rows can "
            f"make; {what}: delete it or choose another --out"
        )


def _close(a: float | None, b: float | None, rel: float) -> bool:
    """``a`` and ``b`` both None, or both within ``rel`` of each other."""
    if a is None or b is None:
        return a is None and b is None
    return math.isclose(a, b, rel_tol=rel, abs_tol=1e-15)


def _check_row(row: ArmRow, arm: TrueArm, where: str) -> None:
    """Refuses a row of ``robots.csv`` that its own seed contradicts: true
    parameters other than those drawn again from the seed (to 1e-9), an
    ``ok`` row whose held-out errors are not finite and >= 0 m or whose mean
    or 95th percentile exceeds its max, a ``failed`` row with errors or no
    reason.

    Raises:
      ValueError: one line starting with ``where``.
    """
    fix = "not this plan's file; delete it or choose another --out"
    true = arm.values
    if len(row.true) != len(true) or not all(
        _close(a, b, 1e-9) for a, b in zip(row.true, true, strict=True)
    ):
        raise ValueError(
            f"{where}: true parameters differ from those drawn from arm {row.arm}'s "
            f"seed {row.seed}: {fix}"
        )
    errors = (row.mean, row.p95, row.max)
    if not row.ok:
        if any(e is not None for e in errors) or not row.reason.strip():
            raise ValueError(
                f"{where}: a failed row with held-out errors or no reason: {fix}"
            )
        return
    values = [e for e in errors if e is not None]
    sound = len(values) == 3 and all(math.isfinite(e) and e >= 0 for e in values)
    if sound:
        top = row.max * (1 + 1e-9) + 1e-15
        sound = row.mean <= top and row.p95 <= top and (row.fitted or 0) >= 1
    if not sound:
        shown = ", ".join("-" if e is None else f"{e:g}" for e in errors)
        raise ValueError(
            f"{where}: held-out errors (mean, p95, max) {shown} m are not those of "
            f"a calibrated arm (finite, >= 0, at most the max): {fix}"
        )


def _recompute_sample(
    config: PlanConfig,
    rows: dict[tuple[int, int], ArmRow],
    numbers: dict[tuple[int, int], int],
    path: Path,
    text: str,
) -> None:
    """Recomputes :data:`RESUME_SAMPLE` of the ``ok`` rows (drawn with a seed
    of the file's bytes) with :func:`plan_arm` and refuses the file when one
    differs (status, fitted count, or held-out errors beyond 1e-6 relative:
    round-off between machines passes, an edit does not)."""
    ok = sorted(k for k, r in rows.items() if r.ok)
    if not ok:
        return
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    rng = np.random.default_rng(int.from_bytes(digest[:8], "little"))
    picked = rng.choice(len(ok), size=min(RESUME_SAMPLE, len(ok)), replace=False)
    index = {v.readings: i for i, v in enumerate(config.variants)}
    for i in sorted(int(i) for i in picked):
        key = ok[i]
        row = rows[key]
        again = plan_arm(ArmTask(config, row.arm, index[row.readings]))
        same = again.status == row.status and again.fitted == row.fitted
        same = same and all(
            _close(a, b, 1e-6)
            for a, b in (
                (again.mean, row.mean),
                (again.p95, row.p95),
                (again.max, row.max),
            )
        )
        if not same:
            was = "failed" if not again.ok else f"{again.mean * 1e3:.4g} mm"
            raise ValueError(
                f"{path}: line {numbers[key]}: recomputed from arm {row.arm}'s seed, "
                f"its held-out mean error is {was}, the file says "
                f"{row.mean * 1e3:.4g} mm: not this plan's file; delete it or "
                "choose another --out"
            )


def _start(
    config: PlanConfig, out: Path, resume: bool
) -> dict[tuple[int, int], ArmRow]:
    """Checks the folder and returns the rows already done (see
    :func:`run_plan`); writes ``plan.yaml`` and a header-only ``robots.csv``
    for a new plan."""
    csv_path, plan_path = out / "robots.csv", out / "plan.yaml"
    record = yaml.safe_load(yaml.safe_dump(config.record(), sort_keys=False))
    done: dict[tuple[int, int], ArmRow] = {}
    if resume:
        if plan_path.exists():
            _check_regular(plan_path, "--resume reads the plan's plan.yaml", 2**24)
        else:
            raise ValueError(
                f"{plan_path}: not found: there is no plan to resume in {out}; run "
                "without --resume"
            )
        stored = read_yaml(plan_path, "plan")
        differ = _first_difference(
            stored.get("rows") if isinstance(stored, dict) else stored,
            record["rows"],
        )
        if differ is not None:
            raise ValueError(
                f"{plan_path}: this plan differs from the one being resumed (at "
                f"{differ}): resume with the same options, or choose another --out"
            )
        if csv_path.exists():
            done = _read_rows(csv_path, config)
    elif csv_path.exists():
        raise ValueError(
            f"{csv_path}: exists, a plan was run in {out}: continue it with --resume, "
            "or choose another --out (nothing was changed)"
        )
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(plan_path, yaml.safe_dump(record, sort_keys=False))
    if not csv_path.exists():
        atomic_write_text(csv_path, ",".join(config.columns) + "\n")
    return done


def _too_few(config: PlanConfig) -> list[str]:
    """A note per plan size whose readings cannot fit the drawn parameters
    and the kind's own unknowns with the degrees of freedom the sanity checks
    need (its arms will fail, saying so; plates); none for ``full`` (its
    identifiable subset depends on the readings)."""
    if config.params == "full":
        return []
    k, dof = len(config.names), CalibrationBounds().min_dof
    notes = (v.too_few(k, dof) for v in config.variants)
    return [note for note in notes if note is not None]


def run_plan(
    config: PlanConfig,
    out_dir: str | Path,
    *,
    execution: Execution | TaskRunner = SERIAL,
    resume: bool = False,
    echo: Callable[[str], None] = print,
    progress: bool = True,
) -> PlanResult:
    """Runs every (variant, arm) task of ``config`` and writes the plan's
    files into ``out_dir`` (see the module docstring).

    Each task is :func:`plan_arm` on a :class:`~rmdrake.execution.TaskRunner`
    of ``execution`` with ``failures=True``: a task that raises or whose
    worker keeps dying is a ``failed`` row with the reason, and the plan goes
    on. Rows are appended to ``robots.csv`` as they arrive (one unbuffered
    write each), so an interrupted plan keeps the rows done; ``resume``
    continues it: ``plan.yaml`` must hold the same plan (target and confidence
    may change: they only enter the summary), a last line cut by the
    interrupt is dropped, and only the missing tasks run.

    Args:
      config: the plan.
      out_dir: the folder (created if missing).
      execution: where the tasks run (default: in this process).
      resume: continue the plan in ``out_dir``.
      echo: where the progress lines, the table and the recommendation go.
      progress: show a progress bar over the tasks.

    Raises:
      ValueError: (one line) ``robots.csv`` exists and not ``resume``;
        ``resume`` without ``plan.yaml``, with another plan, or a
        ``robots.csv`` whose header or rows are not this plan's.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import KINDS
    >>> from rmdrake.studies import PlanConfig
    >>> plan = KINDS["plates"].plan(5, 12)
    >>> config = PlanConfig(robot=load_robot("rv3sb"), robots=20, noise=2e-6, plan=plan,
    ...                 target=5e-5)
    ...
    >>> config.robots, config.target
    (20, 5e-05)

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake.studies import run_plan
        result = run_plan(config, "plan_out")
    """
    out = Path(out_dir)
    done = _start(config, out, resume)
    csv_path = out / "robots.csv"
    variants = config.variants
    todo = [
        (v, a)
        for v, variant in enumerate(variants)
        for a in range(config.robots)
        if (variant.readings, a) not in done
    ]
    total = len(variants) * config.robots
    echo(
        f"plan: {config.robots} arms of '{config.robot.name}' x {len(variants)} "
        f"plan(s) ({', '.join(v.describe() for v in variants)}): {total} tasks"
        + (f", {total - len(todo)} done, {len(todo)} to run" if resume else "")
    )
    for line in _too_few(config):
        echo(line)
    items = [ArmTask(config, a, v) for v, a in todo]
    with (
        open(csv_path, "ab", buffering=0) as f,  # one write per row, unbuffered
        TaskRunner(execution, tasks=len(items), echo=echo) as runner,
    ):
        for i, row in runner.imap(
            plan_arm, items, desc="arms", progress=progress, failures=True
        ):
            if isinstance(row, TaskFailure):
                row = _failed(items[i], draw_arm(config, todo[i][1]), row.reason)
            f.write(row.line().encode("utf-8"))
            done[(row.readings, row.arm)] = row
    rows = [done[k] for k in sorted(done)]
    header = ",".join(config.columns) + "\n"
    files = {"plan.yaml": (out / "plan.yaml").resolve()}
    files["robots.csv"] = atomic_write_text(
        csv_path, header + "".join(r.line() for r in rows)
    )
    summary = summarise_plan(config, rows)
    files["summary.yaml"] = atomic_write_text(
        out / "summary.yaml", yaml.safe_dump(summary, sort_keys=False)
    )
    errors = {
        v.describe(): np.array(
            [r.mean for r in rows if r.readings == v.readings and r.ok], dtype=float
        )
        for v in variants
    }
    failed = {e["plan"]: e["failed"] for e in summary["variants"]}
    files["plan.png"] = plot_plan_errors(
        errors,
        config.target,
        out / "plan.png",
        failed=failed,
        title=(
            f"{config.robot.name}: mean held-out tool error of {config.robots} "
            f"arms per plan (noise {config.noise * 1e6:g} um, length std "
            f"{config.length_std * 1e3:g} mm, angle std {config.angle_std * 1e3:g} "
            f"mrad, {config.params}; poses {config.poses_from})"
        ),
    )
    for line in _table(summary):
        echo(line)
    line = plan_line(summary)
    echo(line)
    echo(f"wrote {', '.join(str(files[k]) for k in _FILES[1:])}")
    return PlanResult(rows, summary, line, files, len(items))
