"""The closed-loop compensation study: static pose accuracy in the manner of
ISO 9283 and path tracking, the true robot driven by its controller in the
Drake station.

Per seed (:func:`run_static_accuracy_study`), with no knowledge of the truth in
the controller:

1. The loop (:func:`~rmdrake.studies.closed_loop.run_loop`): a true robot,
   calibrated from plate readings taken in the diagram, and identified from
   an excitation run in the diagram.
2. Targets: the five ISO 9283 points of a cube (:func:`cube_targets`) with the
   tool orientation fixed, each visited ``cycles`` times in new seeded orders
   (:func:`visit_order`), then ``n_targets`` held-out targets, the nominal
   tool poses of random joint configurations away from the limits and from
   singular configurations (:func:`held_out_configurations`).
3. Four controllers (:data:`VARIANTS`), computed torque with integral action:
   ``nominal`` (nominal IK of the poses, nominal dynamics), ``corrected``
   (the poses solved on the calibrated model by
   :func:`~rmdrake.compensation.correction.correct_targets`, full pose, seeded with the
   nominal IK; nominal dynamics), ``full`` (those targets, the identified
   physically consistent dynamics and friction) and ``oracle`` (targets and
   dynamics of the true model: what is left is the servo's settle error).
   One setpoint trajectory runs through the targets (same order and move
   times in every variant); a ToolTracker's p_WM (the true tool origin,
   W = B) is logged at the end of each hold.
4. Per variant: ISO 9283 AP and RP per cube point, the mean and max distance
   of the attained tool position to its target over the held-out targets (mm
   in the printouts), and a Fig. 3-style PNG of the first seed's errors.
5. On the first ``tracking.seeds`` seeds, the path-tracking runs
   (:mod:`rmdrake.studies.tracking`: one task per cell of the grid,
   :func:`~rmdrake.studies.tracking.track_program`, then
   :func:`~rmdrake.studies.tracking.tracking_result`).

The study runs as steps, each returning a small frozen dataclass:
:func:`cube_step` (:class:`CubeTargets`, once), then per seed
:func:`loop_step` (:class:`SeedLoop`: the loop and :func:`targets_step`'s
:class:`SeedTargets`), per variant :func:`drive_step` (:class:`VariantRun`)
and, per cell of the tracking grid,
:func:`~rmdrake.studies.tracking.track_program`, gathered by
:func:`outcome_step` (:class:`SeedOutcome`: :func:`measure_step`'s
:class:`VariantAccuracy` per variant and the tracking result);
:func:`summarise_step` gathers the seeds into a
:class:`CompensationStudyResult`, and the writer
:func:`write_static_accuracy_files` prints its table and writes its figure.

:func:`run_static_accuracy_study` runs the independent pieces as tasks
(:mod:`rmdrake.execution`): the two independent halves of each seed's
:func:`loop_step` (calibration, identification), then together every
seed's :func:`drive_step` per variant and each cell of the tracking grid
(:func:`~rmdrake.studies.tracking.track_program`); the figures do not depend
on where they ran.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.geometry import Meshcat

from rmdrake.compensation.correction import correct_targets
from rmdrake.execution import SERIAL, Execution, Pending, TaskRunner
from rmdrake.kinematics.forward import tool_jacobian, tool_poses
from rmdrake.model.robot import RobotModel
from rmdrake.progress import progress_iter
from rmdrake.report.iso9283 import cube_test_points, pose_accuracy
from rmdrake.report.plots import plot_calibration_errors
from rmdrake.report.tables import aligned_table, target_check
from rmdrake.studies.closed_loop import (
    ClosedLoopModels,
    LoopCalibration,
    LoopIdentification,
    LoopRecord,
    TargetDrive,
    calibrate_loop,
    drive_to_targets,
    identify_loop,
    join_loop,
    run_loop,
)
from rmdrake.studies.scenarios import CompensationStudyConfig, stream
from rmdrake.studies.tracking import (
    TrackedProgram,
    TrackingResult,
    showcase_cell,
    track_program,
    tracking_cells,
    tracking_result,
)
from rmdrake.systems.station_sources import setpoint_move_times

__all__ = [
    "TARGET_ORACLE_RATIO",
    "VARIANTS",
    "CompensationStudyResult",
    "CubeTargets",
    "SeedLoop",
    "SeedOutcome",
    "SeedTargets",
    "StartedStudy",
    "VariantAccuracy",
    "VariantRun",
    "cube_step",
    "cube_targets",
    "drive_step",
    "held_out_configurations",
    "join_step",
    "loop_step",
    "measure_step",
    "outcome_step",
    "run_after_loop",
    "run_static_accuracy_study",
    "start_static_accuracy_study",
    "summarise_step",
    "targets_step",
    "visit_order",
    "write_static_accuracy_files",
]

VARIANTS = ("nominal", "corrected", "full", "oracle")
"""The controllers compared: nominal IK and dynamics; targets corrected on the
calibrated model (nominal dynamics); the same with the identified dynamics and
friction; targets and dynamics of the true model."""
_LABELS = {
    "nominal": "nominal controller",
    "corrected": "kinematic correction",
    "full": "full compensation",
    "oracle": "oracle (true models)",
}
TARGET_ORACLE_RATIO = 1.5
"""The largest accepted ratio of the corrected mean error to the oracle's."""


def cube_targets(
    nominal: RobotModel, cube_q: object, side: float
) -> tuple[np.ndarray, np.ndarray]:
    """The ISO 9283 points P1..P5, (5, 3) m in B, of the cube of edge ``side``
    (m) centred at the nominal tool position at ``cube_q`` (rad or m), edges along
    the base axes; and the fixed tool orientation R_BE (3, 3), the nominal one
    at ``cube_q``."""
    q = np.asarray(cube_q, dtype=float).reshape(1, -1)
    if q.shape[1] != nominal.n_joints:
        raise ValueError(
            f"compensation.cube_q: expected {nominal.n_joints} joint positions, "
            f"found {q.shape[1]}"
        )
    X = tool_poses(nominal.table, q, sigma=nominal.sigma)[0]
    return cube_test_points(X[:3, 3], side), X[:3, :3].copy()


def visit_order(count: int, cycles: int, seed: int) -> np.ndarray:
    """(count * cycles,) point indices: ``cycles`` seeded permutations of
    0..count-1, each starting on a point other than the previous cycle's last
    (no point is approached from itself)."""
    rng = np.random.default_rng(seed)
    order: list[int] = []
    for _ in range(cycles):
        perm = rng.permutation(count)
        while order and count > 1 and perm[0] == order[-1]:
            perm = rng.permutation(count)
        order.extend(int(i) for i in perm)
    return np.asarray(order, dtype=np.int64)


def held_out_configurations(
    nominal: RobotModel, count: int, *, margin: float, min_singular: float, seed: int
) -> np.ndarray:
    """(count, n) joint positions (rad or m), uniform in each joint range less
    ``margin`` of it at both ends, kept when the smallest singular value of
    the 6 x n tool Jacobian (linear rows m/rad or m/m, angular rad/rad or 0 for
    a prismatic joint) is at least
    ``min_singular`` (away from wrist, elbow and shoulder singularities).

    Raises:
      ValueError: fewer than ``count`` kept after 50 batches.
    """
    rng = np.random.default_rng(seed)
    lo, hi = nominal.limits.lower, nominal.limits.upper
    a, b = lo + margin * (hi - lo), hi - margin * (hi - lo)
    kept = np.zeros((0, nominal.n_joints))
    for _ in range(50):
        q = rng.uniform(a, b, (4 * count, nominal.n_joints))
        J = tool_jacobian(nominal.table, q, sigma=nominal.sigma)
        s = np.linalg.svd(J, compute_uv=False)
        kept = np.concatenate([kept, q[s.min(axis=1) >= min_singular]])
        if kept.shape[0] >= count:
            return kept[:count]
    raise ValueError(
        f"compensation.min_singular: only {kept.shape[0]} of {count} random "
        f"configurations have a tool Jacobian with sigma_min >= {min_singular}"
    )


@dataclasses.dataclass
class CompensationStudyResult:
    """Outcome of :func:`run_static_accuracy_study` (all in m, rad, s).

    Attributes:
      seeds: the scenario seeds.
      cube_points: (5, 3) P1..P5 in B.
      cube_R_BE: (3, 3) the fixed tool orientation at the cube points.
      AP, RP: variant -> (S, 5) ISO 9283 accuracy and repeatability per point.
      mean_error, max_error: variant -> (S,) over the held-out targets.
      held_out_errors: variant -> (N,) first seed's per-target errors.
      settle_error: variant -> (S,) largest |q - q_target| at a reading, rad
        (m for a prismatic joint).
      model_before, model_after: (S,) mean tool error of the nominal and the
        calibrated model on the calibration study's held-out poses.
      model_max_after: (S,) its max.
      calibration_readings: (S,) valid plate readings used.
      wall_time: (S,) wall time of the station runs per seed.
      png: the figure written.
      loop: per seed, how well the loop learnt the true robot.
      tracking: the path-tracking results of the first seeds.
      target_mean_error: the corrected variant's goal, m (from the config).

    Example:

    >>> import dataclasses
    >>> from rmdrake.studies import CompensationStudyResult
    >>> [f.name for f in dataclasses.fields(CompensationStudyResult)][:3]
    ['seeds', 'cube_points', 'cube_R_BE']
    """

    seeds: list[int]
    cube_points: np.ndarray
    cube_R_BE: np.ndarray
    AP: dict[str, np.ndarray]
    RP: dict[str, np.ndarray]
    mean_error: dict[str, np.ndarray]
    max_error: dict[str, np.ndarray]
    held_out_errors: dict[str, np.ndarray]
    settle_error: dict[str, np.ndarray]
    model_before: np.ndarray
    model_after: np.ndarray
    model_max_after: np.ndarray
    calibration_readings: np.ndarray
    wall_time: np.ndarray
    png: Path | None = None
    target_mean_error: float = 0.03e-3
    loop: list[LoopRecord] = dataclasses.field(default_factory=list)
    tracking: list[TrackingResult] = dataclasses.field(default_factory=list)

    def table(self) -> str:
        """The first seed's ISO 9283 and held-out table, the statistics over
        the seeds and the study's pass checks, in mm."""
        mm = 1e3
        points = [f"P{i + 1}" for i in range(5)]
        rows = [
            [_LABELS[v]]
            + [f"{x * mm:.4f}" for x in (*self.AP[v][0], *self.RP[v][0])]
            + [f"{self.mean_error[v][0] * mm:.4f}", f"{self.max_error[v][0] * mm:.4f}"]
            for v in VARIANTS
        ]
        lines = [
            f"seed {self.seeds[0]}: ISO 9283 per cube point and held-out targets "
            f"({self.held_out_errors['nominal'].size}) [mm]",
            *aligned_table(
                ["variant", *points, *points, "mean", "max"],
                rows,
                groups=[("AP", 5), ("RP", 5), ("held-out", 2)],
            ),
        ]
        S = len(self.seeds)
        rows = []
        for v in VARIANTS:
            m = self.mean_error[v] * mm
            rows.append(
                [
                    _LABELS[v],
                    f"{np.median(m):.4f}",
                    f"{m.max():.4f}",
                    f"{self.max_error[v].max() * mm:.4f}",
                    f"{self.AP[v].max() * mm:.4f}",
                    f"{self.settle_error[v].max() * 1e6:.1f}",
                ]
            )
        lines += [
            "",
            f"over {S} seed(s) (true robots) [mm]; settle |dq| [urad or um]",
            *aligned_table(
                ["variant", "median", "worst", "worst", "worst AP", "settle |dq|"],
                rows,
                groups=[("held-out mean", 2), ("max", 1)],
            ),
        ]
        after, before = np.median(self.model_after), np.median(self.model_before)
        lines.append(
            f"{'calibrated model':<24} mean tool error {after * mm:.4f} mm "
            f"(median; nominal {before * mm:.3f} mm), "
            f"max {self.model_max_after.max() * mm:.4f} mm, from "
            f"{int(np.median(self.calibration_readings))} readings in the diagram"
        )
        for r in self.loop[:1]:
            errors = ", ".join(f"{m} {e:.2%}" for m, e in r.torque_error.items())
            lines.append(
                f"{'identified dynamics':<24} excitation cond(A) "
                f"{r.excitation_cond:.3g}; torque error vs the true model: {errors}"
            )
        for warning in dict.fromkeys(r.excitation_warning for r in self.loop):
            if warning:  # a wall-time budget stopped a design
                lines.append(f"warning: {warning}")
        corr = float(np.median(self.mean_error["full"]))
        oracle = float(np.median(self.mean_error["oracle"]))
        mean = target_check(
            "full compensation mean",
            corr * mm,
            "<=",
            self.target_mean_error * mm,
            unit=" mm",
            digits=".4f",
            reason=f"this run's calibrated model alone is {after * mm:.4f} mm off "
            "on average",
        )
        ratio = (
            target_check(
                "full / oracle =",
                corr / oracle,
                "<=",
                TARGET_ORACLE_RATIO,
                reason=f"the oracle, the true models, at {oracle * mm:.4f} mm; the "
                "full compensation has this run's calibrated and identified ones",
            )
            if oracle > 1e-9  # m: below that the oracle is at round-off
            else "the oracle is at round-off (no ratio)"
        )
        lines.append(f"targets: {mean}; {ratio}")
        return "\n".join(lines)


def _check(config: CompensationStudyConfig) -> None:
    rules = [
        ("seeds", config.seeds >= 1, "at least 1"),
        ("cycles", config.cycles >= 2, "at least 2"),
        ("n_targets", config.n_targets >= 1, "at least 1"),
        ("cube_side", config.cube_side > 0, "> 0 m"),
        ("settle_time", config.settle_time > 0, "> 0 s"),
        ("calibration_settle_time", config.calibration_settle_time > 0, "> 0 s"),
        ("speed", 0 < config.speed <= 1, "in (0, 1]"),
        ("target_margin", 0 <= config.target_margin < 0.5, "in [0, 0.5)"),
    ]
    for name, ok, rule in rules:
        if not ok:
            value = getattr(config, name)
            raise ValueError(f"compensation.{name}: expected {rule}, found {value}")


@dataclasses.dataclass(frozen=True)
class CubeTargets:
    """The ISO 9283 cube of :func:`cube_step`, the same for every seed (B = W).

    Attributes:
      p_BP: (5, 3) the points P1..P5 in B, m.
      R_BE: (3, 3) the fixed tool orientation at them (nominal at ``cube_q``).
      q_nominal: (5, n) the nominal model's IK of the points with R_BE, rad or
        m (seeded with ``cube_q``).
    """

    p_BP: np.ndarray
    R_BE: np.ndarray
    q_nominal: np.ndarray


@dataclasses.dataclass(frozen=True)
class SeedTargets:
    """One seed's targets (:func:`targets_step`): K = 5 ``cycles`` cube
    visits, then N held-out tool poses, and each variant's joint targets for
    them (B = W).

    Attributes:
      order: (K,) the cube point (0..4) of each visit.
      p_BE: (K + N, 3) target tool positions in B, m.
      R_BE: (K + N, 3, 3) target tool orientations in B.
      q: variant -> (K + N, n) its controller's joint targets, rad or m
        (``full`` shares ``corrected``'s).
      q_start: (n,) where each run starts (mid-range), rad or m.
      move_time: (K + N,) move times of the nominal targets (at least 0.2 s),
        5 % longer for the corrections' extra dq: the same in every variant, s.
      unreachable: variant -> the summary of its correction, for a variant
        whose corrected targets are not all reachable.
    """

    order: np.ndarray
    p_BE: np.ndarray
    R_BE: np.ndarray
    q: dict[str, np.ndarray]
    q_start: np.ndarray
    move_time: np.ndarray
    unreachable: dict[str, str]


@dataclasses.dataclass(frozen=True)
class VariantRun:
    """One variant driven through a seed's targets in the station
    (:func:`drive_step`).

    Attributes:
      q: (K + N, n) encoder positions at the end of each hold, rad or m.
      p_WM: (K + N, 3) attained tool positions (a ToolTracker, W = B), m.
      wall_time: wall-clock time of the simulation, s.
    """

    q: np.ndarray
    p_WM: np.ndarray
    wall_time: float


@dataclasses.dataclass(frozen=True)
class VariantAccuracy:
    """What one variant attained (:func:`measure_step`).

    Attributes:
      settle_error: largest |q - q_target| at a reading, rad (m for a
        prismatic joint).
      AP, RP: (5,) ISO 9283 pose accuracy and repeatability per cube point, m.
      held_out_errors: (N,) |p_WM - p_BE| at the held-out targets, m.
    """

    settle_error: float
    AP: np.ndarray
    RP: np.ndarray
    held_out_errors: np.ndarray


@dataclasses.dataclass(frozen=True)
class SeedLoop:
    """One seed's loop and targets (:func:`loop_step`): what its station runs
    start from.

    Attributes:
      seed: the scenario seed.
      models: what the loop learnt, and the truth.
      record: how well it learnt it.
      targets: the seed's targets for each variant.
    """

    seed: int
    models: ClosedLoopModels
    record: LoopRecord
    targets: SeedTargets


@dataclasses.dataclass(frozen=True)
class SeedOutcome:
    """One seed's true robot through the loop, its targets and the station
    runs (:func:`outcome_step`).

    Attributes:
      seed: the scenario seed.
      record: how well the loop learnt the true robot.
      accuracy: variant -> what it attained.
      wall_time: of the loop and the station runs, s.
      tracking: the path-tracking result, on the first ``tracking.seeds``
        seeds (else None).
    """

    seed: int
    record: LoopRecord
    accuracy: dict[str, VariantAccuracy]
    wall_time: float
    tracking: TrackingResult | None


def cube_step(nominal: RobotModel, config: CompensationStudyConfig) -> CubeTargets:
    """The cube (module docstring, item 2): the points of edge
    ``config.cube_side`` (m) about the nominal tool at ``config.cube_q``
    (:func:`cube_targets`) and their nominal IK with the fixed orientation.

    Raises:
      ValueError: a ``cube_q`` of the wrong length, or a cube point the
        nominal robot cannot reach with that orientation.
    """
    p_BP, R_BE = cube_targets(nominal, config.cube_q, config.cube_side)
    ik = correct_targets(
        nominal,
        p_BP,
        q_seed=np.tile(np.asarray(config.cube_q, dtype=float), (5, 1)),
        orientation=np.tile(R_BE, (5, 1, 1)),
    )
    if not ik.reachable.all():
        raise ValueError(
            "compensation.cube_q, cube_side: the nominal robot cannot reach the "
            f"cube points with the fixed orientation: {ik.summary()}"
        )
    return CubeTargets(p_BP, R_BE, ik.q)


def targets_step(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    cube: CubeTargets,
    models: ClosedLoopModels,
    seed: int,
) -> SeedTargets:
    """The seed's targets (module docstring, item 2): the cube visits in
    ``cycles`` orders drawn from stream 3 of ``seed``, then ``n_targets``
    held-out tool poses (p_BE, R_BE) from stream 2; each variant's joint
    targets (the nominal IK, the poses solved on the calibrated and on the
    true model, full pose, seeded with the nominal IK) and the move times,
    at ``config.speed`` of the joint limits, from mid-range."""
    lim = nominal.limits
    q_home = 0.5 * (lim.lower + lim.upper)
    order = visit_order(5, config.cycles, stream(seed, 3))
    q_held = held_out_configurations(
        nominal,
        config.n_targets,
        margin=config.target_margin,
        min_singular=config.min_singular,
        seed=stream(seed, 2),
    )
    X_held = tool_poses(nominal.table, q_held, sigma=nominal.sigma)
    p_target = np.concatenate([cube.p_BP[order], X_held[:, :3, 3]])
    R_cube_visits = np.tile(cube.R_BE, (order.size, 1, 1))
    R_target = np.concatenate([R_cube_visits, X_held[:, :3, :3]])
    q_nom = np.concatenate([cube.q_nominal[order], q_held])
    q_targets, unreachable = {"nominal": q_nom}, {}
    for v, model in (("corrected", models.calibrated), ("oracle", models.true)):
        c = correct_targets(model, p_target, q_seed=q_nom, orientation=R_target)
        if not c.reachable.all():
            unreachable[v] = c.summary()
        q_targets[v] = c.q
    q_targets["full"] = q_targets["corrected"]
    v_max, a_max = (config.speed * x for x in (lim.velocity, lim.acceleration))
    need = setpoint_move_times(
        q_nom, velocity=v_max, acceleration=a_max, q_start=q_home
    )
    move_time = 1.05 * np.maximum(need, 0.2)
    return SeedTargets(
        order, p_target, R_target, q_targets, q_home, move_time, unreachable
    )


def drive_step(
    config: CompensationStudyConfig,
    models: ClosedLoopModels,
    targets: SeedTargets,
    variant: str,
    *,
    seed: int,
) -> VariantRun:
    """The true robot (module docstring, item 3) driven through ``variant``'s
    joint targets in ``config.station`` (sensor noise seeded with ``seed``;
    holds of ``config.settle_time`` s), by computed torque with integral
    action on the nominal dynamics, the identified physically consistent ones
    (``full``) or the true ones (``oracle``)."""
    station = copy.deepcopy(config.station)
    station.sensors.seed = int(seed)
    dynamics = {"full": models.identified["physical"], "oracle": models.true}
    drive = TargetDrive(
        targets.q[variant], targets.move_time, config.settle_time, targets.q_start
    )
    q, p_WM, wall = drive_to_targets(
        station,
        drive,
        true_model=models.true,
        nominal_model=models.nominal,
        identified_model=dynamics.get(variant),
    )
    return VariantRun(q, p_WM, wall)


def run_after_loop(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    cube: CubeTargets,
    seed: int,
    calibration: LoopCalibration,
    identification: LoopIdentification,
    run: str | tuple[int, int, int],
) -> VariantRun | TrackedProgram:
    """One station run of the seed, on its loop joined from the two halves
    (:func:`join_step`, some 20 ms): ``run`` a variant (:func:`drive_step`) or
    a cell of the tracking grid
    (:func:`~rmdrake.studies.tracking.track_program`). One task that can start
    as soon as the halves are done."""
    loop = join_step(nominal, config, cube, seed, calibration, identification)
    if isinstance(run, str):
        return drive_step(config, loop.models, loop.targets, run, seed=seed)
    return track_program(loop.models, config, run)


@dataclasses.dataclass
class StartedStudy:
    """The study's tasks started ahead (:func:`start_static_accuracy_study`).

    Attributes:
      cube: the cube (:func:`cube_step`).
      halves: (``"calibration"`` or ``"identification"``, seed) -> the
        loop's half.
      runs: (seed, variant or tracking cell) -> the station run.
    """

    cube: CubeTargets
    halves: dict[tuple[str, int], Pending]
    runs: dict[tuple[int, Any], Pending]


def start_static_accuracy_study(
    nominal: RobotModel, config: CompensationStudyConfig, runner: TaskRunner
) -> StartedStudy:
    """Starts every task of :func:`run_static_accuracy_study` ahead of need
    (:meth:`~rmdrake.execution.TaskRunner.start`): on a running cluster they
    fill the workers at once, each station run as soon as its seed's loop
    halves are done (:func:`run_after_loop`), while
    this process does something else (a scenario's identification study);
    otherwise they run when the study asks. No live Meshcat run.

    Raises:
      ValueError: as :func:`run_static_accuracy_study`, before any task.
    """
    _check(config)
    cube = cube_step(nominal, config)
    seeds = list(range(config.seeds))
    halves = {
        (name, seed): runner.start(half, nominal, config, seed, progress=True)
        for name, half in (
            ("calibration", calibrate_loop),
            ("identification", identify_loop),
        )
        for seed in seeds
    }
    tracked = seeds[: config.tracking.seeds]
    keys = [(seed, v) for seed in seeds for v in VARIANTS] + [
        (seed, cell) for seed in tracked for cell in tracking_cells(config.tracking)
    ]
    runs = {
        (seed, run): runner.start(
            run_after_loop,
            nominal,
            config,
            cube,
            seed,
            halves["calibration", seed],
            halves["identification", seed],
            run,
        )
        for seed, run in keys
    }
    return StartedStudy(cube, halves, runs)


def measure_step(
    cube: CubeTargets,
    targets: SeedTargets,
    run: VariantRun,
    variant: str,
    *,
    cycles: int,
) -> VariantAccuracy:
    """Module docstring, item 4: ISO 9283 AP and RP of ``run``'s p_WM (m, in
    W = B) at the ``cycles`` visits of each cube point, its distances to the
    held-out targets (m) and its largest joint settle error (rad or m)
    against ``variant``'s targets."""
    K = targets.order.size
    settle = np.abs(run.q - targets.q[variant]).max()
    attained = np.zeros((5, cycles, 3))
    for i in range(5):
        attained[i] = run.p_WM[:K][targets.order == i]
    iso = pose_accuracy(cube.p_BP, attained)
    e = np.linalg.norm(run.p_WM[K:] - targets.p_BE[K:], axis=1)
    return VariantAccuracy(settle, iso.AP, iso.RP, e)


def loop_step(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    cube: CubeTargets,
    seed: int,
    *,
    progress: bool = True,
) -> SeedLoop:
    """Items 1-2 of the module docstring on the true robot of ``seed``: the
    loop (:func:`~rmdrake.studies.closed_loop.run_loop`; ``progress`` shows
    its station runs) and :func:`targets_step`."""
    models, record = run_loop(nominal, config, seed, progress=progress)
    targets = targets_step(nominal, config, cube, models, seed)
    return SeedLoop(seed, models, record, targets)


def join_step(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    cube: CubeTargets,
    seed: int,
    calibration: LoopCalibration,
    identification: LoopIdentification,
) -> SeedLoop:
    """The seed's loop from its two independent halves
    (:func:`~rmdrake.studies.closed_loop.join_loop`) and its targets
    (:func:`targets_step`, some 20 ms)."""
    models, record = join_loop(nominal, calibration, identification)
    targets = targets_step(nominal, config, cube, models, seed)
    return SeedLoop(seed, models, record, targets)


def outcome_step(
    config: CompensationStudyConfig,
    cube: CubeTargets,
    loop: SeedLoop,
    runs: dict[str, VariantRun],
    tracked: list[TrackedProgram] | None,
    *,
    out: Path,
    echo: Callable[[str], None] = print,
    meshcat: Meshcat | None = None,
) -> SeedOutcome:
    """One seed's outcome from its ``loop``, its variants' ``runs`` and, on a
    tracked seed, its ``tracked`` cells of the tracking grid (None: not
    tracked): ``echo`` prints the variants whose targets are not all
    reachable, :func:`measure_step` per variant, and
    :func:`~rmdrake.studies.tracking.tracking_result` writes the tracking
    files into ``out`` (the HTML built on ``meshcat`` if given)."""
    for v, summary in loop.targets.unreachable.items():
        echo(f"seed {loop.seed}, {v}: {summary}")
    wall = loop.record.wall_time
    accuracy = {}
    for v in VARIANTS:
        wall += runs[v].wall_time
        accuracy[v] = measure_step(cube, loop.targets, runs[v], v, cycles=config.cycles)
    paths = None
    if tracked is not None:
        paths = tracking_result(
            loop.models,
            config,
            out,
            tracked,
            seed=loop.seed,
            echo=echo,
            meshcat=meshcat,
        )
    return SeedOutcome(loop.seed, loop.record, accuracy, wall, paths)


def summarise_step(
    cube: CubeTargets,
    outcomes: list[SeedOutcome],
    config: CompensationStudyConfig,
) -> CompensationStudyResult:
    """The seeds' outcomes as the study's result (per variant, one row per
    seed; the first seed's held-out errors; m, rad or m, s); no figure yet."""

    def per_seed(field: str) -> dict[str, np.ndarray]:
        return {
            v: np.array([getattr(o.accuracy[v], field) for o in outcomes])
            for v in VARIANTS
        }

    errors = {v: [o.accuracy[v].held_out_errors for o in outcomes] for v in VARIANTS}
    return CompensationStudyResult(
        seeds=[o.seed for o in outcomes],
        cube_points=cube.p_BP,
        cube_R_BE=cube.R_BE,
        AP=per_seed("AP"),
        RP=per_seed("RP"),
        mean_error={v: np.array([e.mean() for e in errors[v]]) for v in VARIANTS},
        max_error={v: np.array([e.max() for e in errors[v]]) for v in VARIANTS},
        held_out_errors={v: errors[v][0] for v in VARIANTS},
        settle_error=per_seed("settle_error"),
        model_before=np.array([o.record.model_before for o in outcomes], float),
        model_after=np.array([o.record.model_after for o in outcomes], float),
        model_max_after=np.array([o.record.model_max_after for o in outcomes], float),
        calibration_readings=np.array(
            [o.record.readings for o in outcomes], dtype=np.int64
        ),
        wall_time=np.array([o.wall_time for o in outcomes], float),
        target_mean_error=config.target_mean_error,
        loop=[o.record for o in outcomes],
        tracking=[o.tracking for o in outcomes if o.tracking is not None],
    )


def write_static_accuracy_files(
    out_dir: str | os.PathLike,
    nominal: RobotModel,
    config: CompensationStudyConfig,
    result: CompensationStudyResult,
    *,
    echo: Callable[[str], None] = print,
) -> Path:
    """The writer: prints the scenario, the study's table
    (:meth:`CompensationStudyResult.table`, mm), writes
    ``static_accuracy_fig3.png`` (the first seed's held-out tool position
    errors, m, per variant against the nominal controller) into ``out_dir``
    (created if missing), prints its path and the tracking tables; returns
    the figure's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    c = result.cube_points[0]
    echo(
        f"Scenario: {nominal.name}, true robot = {config.params} kinematic errors "
        f"(nominal mean tool error {config.mean_error * 1e3:.3g} mm) + dynamics "
        f"perturbed 10-30 % per link; LM calibration from {config.plates} plates x "
        f"{config.per_plate} readings taken in the diagram ({config.noise * 1e6:.3g}"
        f" um noise); dynamics identified in the diagram. ISO 9283 cube: centre "
        f"({c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}) m (nominal tool at q = "
        f"{np.round(config.cube_q, 3).tolist()} rad or m), side "
        f"{config.cube_side * 1e3:.0f} mm, tool orientation fixed, {config.cycles} "
        f"cycles; {config.n_targets} held-out targets; holds of "
        f"{config.settle_time:g} s; station wall time {result.wall_time.sum():.0f} s."
    )
    echo(result.table())
    png = plot_calibration_errors(
        result.held_out_errors["nominal"],
        {_LABELS[v]: result.held_out_errors[v] for v in VARIANTS[1:]},
        out / "static_accuracy_fig3.png",
        title=(
            f"Static tool position error at {config.n_targets} held-out targets\n"
            f"{nominal.name} in Drake, seed {result.seeds[0]} ('before': nominal "
            "controller)"
        ),
        reference={
            f"target {config.target_mean_error * 1e3:g} mm": config.target_mean_error
        },
    )
    echo(f"wrote {png}")
    for tracking in result.tracking:
        echo(tracking.table())
    return png


def run_static_accuracy_study(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    out_dir: str | os.PathLike,
    *,
    progress: bool = True,
    echo: Callable[[str], None] = print,
    meshcat: Meshcat | None = None,
    execution: Execution | TaskRunner = SERIAL,
    started: StartedStudy | None = None,
) -> CompensationStudyResult:
    """Runs the study (see the module docstring), prints its table and writes
    ``static_accuracy_fig3.png`` and the tracking figures and scenes into
    ``out_dir`` (created if missing); ``meshcat`` shows the first seed's
    fastest soft-gain tracking run live (run in this process).

    The steps: :func:`cube_step`; the two halves of :func:`loop_step` per
    seed (calibration, identification: independent) as tasks of
    ``execution`` (default: in this process), joined by :func:`join_step`;
    then as tasks together
    :func:`drive_step` per seed and variant and
    :func:`~rmdrake.studies.tracking.track_program` per cell of the tracking
    grid of the first ``tracking.seeds`` seeds; then per seed
    :func:`outcome_step`, :func:`summarise_step` and the writer
    :func:`write_static_accuracy_files`. The result is the same wherever the
    tasks run (wall times aside). ``started``: the tasks started ahead by
    :func:`start_static_accuracy_study` with the same ``nominal`` and
    ``config``, gathered here instead (``meshcat`` then draws nothing live).

    Raises:
      ValueError: a value out of range (naming ``compensation.<field>``), a
        ``cube_q`` of the wrong length, or unreachable random targets.

    Example:

    >>> from rmdrake.studies import CompensationStudyConfig
    >>> config = CompensationStudyConfig(seeds=1)
    >>> config.seeds
    1

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake import load_robot
        from rmdrake.studies import run_static_accuracy_study
        result = run_static_accuracy_study(load_robot("rv3sb"), config, "out")
        print(result.table())
    """
    _check(config)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(config.seeds))
    tracked_seeds = seeds[: config.tracking.seeds]
    cells = tracking_cells(config.tracking)
    showcase = next((c for c in cells if showcase_cell(config.tracking, c)), None)
    live = meshcat is not None and bool(tracked_seeds) and showcase is not None
    if started is not None:
        cube, live = started.cube, False
        loops, runs = _gather(nominal, config, started, progress=progress)
    else:
        cube = cube_step(nominal, config)
        loops, runs = _run_tasks(
            nominal,
            config,
            cube,
            execution,
            echo=echo,
            progress=progress,
            skip=(seeds[0], showcase) if live else None,
        )
    if live:  # the showcase run, drawn live, in this process
        runs[seeds[0], showcase] = track_program(
            loops[0].models, config, showcase, meshcat=meshcat
        )
    outcomes = [
        outcome_step(
            config,
            cube,
            loop,
            {v: runs[loop.seed, v] for v in VARIANTS},
            [runs[loop.seed, cell] for cell in cells]
            if loop.seed in tracked_seeds
            else None,
            out=out,
            echo=echo,
            meshcat=meshcat if loop.seed == seeds[0] else None,
        )
        for loop in loops
    ]
    result = summarise_step(cube, outcomes, config)
    result.png = write_static_accuracy_files(out, nominal, config, result, echo=echo)
    return result


def _gather(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    started: StartedStudy,
    *,
    progress: bool,
) -> tuple[list[SeedLoop], dict[tuple[int, Any], Any]]:
    """The loops and station runs of tasks started ahead, in task order."""
    seeds = list(range(config.seeds))
    loops = [
        join_step(
            nominal,
            config,
            started.cube,
            seed,
            started.halves["calibration", seed].result(),
            started.halves["identification", seed].result(),
        )
        for seed in seeds
    ]
    runs = {}
    for key, pending in progress_iter(
        list(started.runs.items()), desc="station runs", disable=not progress
    ):
        runs[key] = pending.result()
    return loops, runs


def _run_tasks(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    cube: CubeTargets,
    execution: Execution | TaskRunner,
    *,
    echo: Callable[[str], None],
    progress: bool,
    skip: tuple[int, Any] | None,
) -> tuple[list[SeedLoop], dict[tuple[int, Any], Any]]:
    """The loops, then the station runs (all but ``skip``), as two batches of
    tasks of ``execution``."""
    seeds = list(range(config.seeds))
    tracked_seeds = seeds[: config.tracking.seeds]
    cells = tracking_cells(config.tracking)
    tasks = len(seeds) * (2 + len(VARIANTS)) + len(tracked_seeds) * len(cells)
    with TaskRunner(execution, tasks=tasks, echo=echo) as runner:
        # A worker's bars that run past the progress interval show here.
        halves = runner.run_calls(
            [
                functools.partial(half, nominal, config, seed, progress=True)
                for half in (calibrate_loop, identify_loop)
                for seed in seeds
            ],
            desc="true robots (calibration, identification)",
            progress=progress,
        )
        S = len(seeds)
        loops = [
            join_step(nominal, config, cube, seed, halves[k], halves[S + k])
            for k, seed in enumerate(seeds)
        ]
        calls = {
            (loop.seed, v): functools.partial(
                drive_step, config, loop.models, loop.targets, v, seed=loop.seed
            )
            for loop in loops
            for v in VARIANTS
        }
        for loop in loops[: len(tracked_seeds)]:
            for cell in cells:
                if (loop.seed, cell) != skip:
                    calls[loop.seed, cell] = functools.partial(
                        track_program, loop.models, config, cell
                    )
        done = runner.run_calls(
            list(calls.values()), desc="station runs", progress=progress
        )
    return loops, dict(zip(calls, done, strict=True))
