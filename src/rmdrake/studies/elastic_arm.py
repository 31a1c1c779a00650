"""The heavy arm bends: elastostatic calibration and deflection compensation
(scenario ``demo_rh_compliance``).

The paper's motivation (its §1) is a blanket-handling arm whose errors come
"from geometric dimensions, dynamic motion, as well as joint and link
deformations". This study puts a number on the last: on an elastic arm
(``RobotModel.compliance``) with geometric errors, what a rigid calibration
(the paper's model) leaves under load, and what an elastostatic one (the joint
compliances identified with the geometry) and the compensation controller's
pre-deflection buy.

Steps (:func:`run_compliance_study`):

1. The truth: the robot's kinematics with the calibration study's errors on
   ``params`` and its joint stiffness scaled per joint by 1 + spread N(0, 1).
   The nominal model (what every controller and calibration starts from) is
   the robot without compliance: the paper's rigid model.
2. Plate readings with each payload of ``calibration_payloads``, taken in the
   Drake station (the true elastic arm settles at each configuration under a
   controller whose bandwidth is a quarter of its lowest structural mode; the
   encoders read the motor side, the range finder sees the link side).
3. LM calibration of the rigid model (``params``) and of the elastostatic one
   (``params`` and ``c<j>``), both on all the readings.
4. Static tool accuracy on held-out targets (full tool poses) at each of
   ``test_payloads``, the payload held at the tool. The variants command the
   motor side:

   - ``nominal``: the nominal IK (the targets' own configurations);
   - ``rigid``: the targets solved on the rigid calibration;
   - ``elastostatic``: solved on the elastostatic calibration, then
     pre-deflected by its compliances at the payload
     (:func:`rmdrake.dynamics.compliance.motor_angles`);
   - ``oracle``: solved on the true kinematics and pre-deflected by the true
     compliances.

   The attained tool position is where the true arm rests with its motors
   there (:func:`rmdrake.dynamics.compliance.link_angles`); the first
   ``diagram_targets`` targets are also driven in the station at the largest
   payload, with the compensation controller pre-deflecting online, and the
   tool tracker's reading is compared with that static prediction.
5. An insertion-like move along the tool's approach axis with the largest
   payload in the station, each variant's controller tracking it online
   (kinematic correction and pre-deflection inside the controller): the tool
   path error, the residual oscillation after the stop (largest distance from
   the final rest position after the programme ends) and its settling time
   (last time outside ``settle_band`` of the final position).
6. A module picked up mid-task: the compensation controller holds the first
   target with no payload; then the largest payload appears on the true arm's
   tool (its payload body's inertia, a Context parameter) and on the
   controller's ``payload_mass`` source at the same instant (``told``; for
   comparison, not on the controller's: ``not told``); and a third run,
   ``estimating``, whose controller's ``payload_mass`` comes from a
   :class:`~rmdrake.systems.payload_estimator.PayloadEstimator` on the
   measured joint signals (recursive least squares on the payload's mass and
   first moments, the elastostatic calibration's arm subtracted): the tool
   error before, after, its peak and its settling time.

In the station, ``nominal`` and ``rigid`` run computed torque on the nominal
(rigid) model, the rigid calibration's targets corrected already for the
static targets and online inside the compensation controller for the move;
``elastostatic`` and ``oracle`` run the compensation controller, which
pre-deflects its command by its calibrated model's compliances at the payload
(:class:`~rmdrake.systems.deflection.DeflectionCompensation`).

The code follows the steps, each a function returning a small frozen
dataclass: :func:`true_elastic_arm` (:class:`ElasticTruth`, step 1),
:func:`readings_step` (:class:`ElasticReadings`, 2), :func:`calibration_step`
(:class:`ElasticCalibration`, 3), :func:`static_step` (:class:`StaticAccuracy`,
4), :func:`station_step` (:class:`StationAccuracy`, 4 in the station),
:func:`insertion_step` (:class:`InsertionRuns`, 5) and :func:`pickup_step`
(:class:`PickupResult`, 6); the station runs of one variant are
:func:`drive_variant`, :func:`run_path` and :func:`run_pickup`.
:func:`write_compliance_files` prints the tables and writes the files.

Its independent pieces run as tasks (:mod:`rmdrake.execution`): the plate
readings of each payload taken in the station (:func:`payload_readings`), then
together every station run of steps 4-6 (:func:`station_calls`,
:func:`insertion_calls`, :func:`pickup_calls`: one per variant, or per
pick-up run), gathered by :func:`station_accuracy`, :func:`insertion_runs`
and :func:`pickup_result`; the figures do not depend on where they ran.

Files: ``payload_errors.png`` (tool error per target, per model and payload),
``deflection_field.png`` (tool deflection of the nominal controller with the
largest payload over the workspace), ``compliance.html`` (Meshcat: the
nominal, sagging and compensated arm in grey, red and green, deflection
magnified),
``results.yaml``.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.primitives import LogVectorOutput

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.plates.simulate import range_readings
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.compensation.correction import correct_targets
from rmdrake.compensation.paths import JointPathProgram, PlanarPath, plan_path_program
from rmdrake.dynamics.compliance import (
    joint_compliances,
    link_angles,
    lowest_structural_mode,
    motor_angles,
    with_payload_mass,
)
from rmdrake.execution import SERIAL, Execution, TaskRunner
from rmdrake.io.atomic import atomic_write_text
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.plant import payload_inertia
from rmdrake.model.robot import Compliance, RobotModel
from rmdrake.report.plots import plot_deflection_field, plot_payload_errors
from rmdrake.studies.calibration import (
    CalibrationDraw,
    draw_true_robot,
    plate_calibration,
)
from rmdrake.studies.closed_loop import drive_to_targets, start_at_command
from rmdrake.studies.compensation import held_out_configurations
from rmdrake.studies.scenarios import ComplianceStudyConfig, stream
from rmdrake.systems.measurement_runs import measure_plates_in_diagram
from rmdrake.systems.payload_estimator import PayloadEstimator
from rmdrake.systems.sensors import ToolTracker
from rmdrake.systems.station import MakeStation
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    InverseDynamicsControllerConfig,
    StationConfig,
)
from rmdrake.systems.station_sources import setpoint_move_times, setpoint_trajectory
from rmdrake.systems.visualization import save_robot_states_html

__all__ = [
    "LABELS",
    "PICKUP_ESTIMATOR_PERIOD",
    "PICKUP_FORGETTING",
    "VARIANTS",
    "ComplianceStudyResult",
    "ElasticCalibration",
    "ElasticReadings",
    "ElasticTruth",
    "InsertionRuns",
    "PathResult",
    "PickupResult",
    "StaticAccuracy",
    "StationAccuracy",
    "PICKUP_SOURCES",
    "PickupRun",
    "calibration_step",
    "drive_variant",
    "insertion_calls",
    "insertion_path",
    "insertion_program",
    "insertion_runs",
    "insertion_step",
    "payload_readings",
    "pickup_calls",
    "pickup_figures",
    "pickup_result",
    "pickup_run",
    "pickup_step",
    "readings_step",
    "run_compliance_study",
    "run_path",
    "run_pickup",
    "static_step",
    "station_accuracy",
    "station_calls",
    "station_config",
    "station_step",
    "study_models",
    "true_elastic_arm",
    "write_compliance_files",
    "write_files",
]

VARIANTS = ("nominal", "rigid", "elastostatic", "oracle")
"""The compared controllers (module docstring, step 4)."""
LABELS = {
    "nominal": "nominal controller",
    "rigid": "rigid calibration (paper)",
    "elastostatic": "elastostatic calibration + compensation",
    "oracle": "oracle (true kinematics and compliance)",
}
"""The variants' names in the figures."""
_MODEL_OF = {
    "nominal": "nominal",
    "rigid": "rigid",
    "elastostatic": "elastic",
    "oracle": "true",
}
"""The model each variant plans and pre-deflects with (keys of the ``models``
of :func:`study_models`)."""
_TRANSFER = 5.0
"""s over which a picked-up module's weight passes onto the arm (a crane or a
support lowering it), in 25 steps."""
PICKUP_ESTIMATOR_PERIOD = 0.01
"""s between the pick-up's payload estimator updates (100 Hz)."""
PICKUP_FORGETTING = 0.99
"""Forgetting factor per update of the pick-up's payload estimator: a memory
of PICKUP_ESTIMATOR_PERIOD / (1 - PICKUP_FORGETTING) = 1 s."""
PICKUP_SOURCES = ("told", "not told", "estimating")
"""The pick-up's runs: where the controller's payload mass comes from
(:func:`run_pickup`)."""


# --- The steps' results -------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ElasticTruth:
    """Step 1: the robots and the controllers' bandwidth.

    Attributes:
      nominal: the robot without compliance (the paper's rigid model), what
        every controller and calibration starts from.
      true: the elastic true robot (geometric errors, stiffness spread).
      draw: the geometric errors, plates, planned readings and held-out
        poses, drawn by :func:`~rmdrake.studies.calibration.draw_true_robot`.
      heaviest: the largest of ``test_payloads``, kg.
      mode: lowest structural mode of the robot with ``heaviest`` at its home
        position (joints at 0, clipped to the limits), rad/s.
      bandwidth: every controller's feedback bandwidth, rad/s.
    """

    nominal: RobotModel
    true: RobotModel
    draw: CalibrationDraw
    heaviest: float
    mode: float
    bandwidth: float


@dataclasses.dataclass(frozen=True)
class ElasticReadings:
    """Step 2: the plate readings of every calibration payload.

    Attributes:
      data: the readings (range-finder distances, m; motor-side joint
        angles, rad), with their ``payload`` column, kg.
      wall_time: wall time of taking them, s.
    """

    data: PlaneMeasurements
    wall_time: float


@dataclasses.dataclass(frozen=True)
class ElasticCalibration:
    """Step 3: the rigid and the elastostatic calibration.

    Attributes:
      rigid: the rigid calibration (``params`` from the lightest payload's
        readings).
      elastic: the elastostatic one (``params`` and the joint compliances
        from all readings).
      verdicts: fit name -> its check against the declared reading noise
        ("plausible" or "flagged: " and the reasons).
      stiffness: (n,) the true joint stiffness, N m/rad.
      stiffness_identified: (n,) the elastostatic calibration's, NaN where
        not identified, N m/rad.
      geometric: "rigid" and "elastostatic" -> mean tool-point error of the
        calibrated kinematics at the held-out poses, no load, m.
    """

    rigid: RobotModel
    elastic: RobotModel
    verdicts: dict[str, str]
    stiffness: np.ndarray
    stiffness_identified: np.ndarray
    geometric: dict[str, float]


@dataclasses.dataclass(frozen=True)
class StaticAccuracy:
    """Step 4: static tool accuracy at the held-out targets (SI units).

    Attributes:
      q_nominal: (K, n) the targets' nominal configurations, rad.
      X_BE: (K, 4, 4) the target tool poses in the base frame B (the nominal
        kinematics at ``q_nominal``), m.
      q_link: variant -> (K, n) its link-side joint targets, rad.
      errors: (variant, payload kg) -> (K,) tool position errors of the true
        arm at rest with the variant's motor commands, m.
      deflection: (K,) tool deflection of the nominal commands with the
        largest payload (rest against rigid), m.
      q_compensated: (n,) the elastostatic variant's motor command for the
        first target with the largest payload, rad.
    """

    q_nominal: np.ndarray
    X_BE: np.ndarray
    q_link: dict[str, np.ndarray]
    errors: dict[tuple[str, float], np.ndarray]
    deflection: np.ndarray
    q_compensated: np.ndarray


@dataclasses.dataclass(frozen=True)
class StationAccuracy:
    """Step 4 in the station: the first targets driven with the largest
    payload.

    Attributes:
      errors: variant -> (k,) tool errors read by the tool tracker, m (empty
        when no target is driven).
      gap: largest |station - static prediction| over those, m.
    """

    errors: dict[str, np.ndarray]
    gap: float


@dataclasses.dataclass(frozen=True)
class PathResult:
    """Step 5, the insertion-like move under one variant (SI units).

    Attributes:
      max_error: largest tool distance from the path point at the same time
        during the move, m.
      final_error: tool distance from the path's end at the end of the hold, m.
      oscillation: largest tool distance from its final rest position after
        the programme ends, m.
      settling_time: time after the programme's end until the tool stays
        within the settle band of its final position, s.
    """

    max_error: float
    final_error: float
    oscillation: float
    settling_time: float


@dataclasses.dataclass(frozen=True)
class InsertionRuns:
    """Step 5: the insertion-like move with the largest payload.

    Attributes:
      program: the joint programme, planned on the nominal model.
      results: variant -> :class:`PathResult`.
    """

    program: JointPathProgram
    results: dict[str, PathResult]


@dataclasses.dataclass(frozen=True)
class PickupResult:
    """Step 6, a module picked up mid-task (SI units): the arm holds a target
    with no payload, then the payload's mass appears on the tool (the true
    plant's payload body, a Context parameter) and, for ``told``, on the
    controller's ``payload_mass`` source at the same instant.

    Attributes:
      before: tool error at the end of the unloaded hold, m.
      told, untold: tool error at the end of the loaded hold, with the
        controller's payload mass updated and left at 0, m.
      peak: largest tool error after the pick-up (told), m.
      settling_time: time after the pick-up until the told arm stays within the
        settle band of its final position, s.
      estimating, estimating_peak, estimating_settling_time: the same three
        figures (final error m, peak m, settling s) with the controller's
        payload mass from the online estimator (:func:`run_pickup`).
      estimated_mass: the estimator's payload mass at the end, kg.
    """

    before: float
    told: float
    untold: float
    peak: float
    settling_time: float
    estimating: float = float("nan")
    estimating_peak: float = float("nan")
    estimating_settling_time: float = float("nan")
    estimated_mass: float = float("nan")


@dataclasses.dataclass
class ComplianceStudyResult:
    """Outcome of :func:`run_compliance_study` (SI units).

    Attributes:
      true, rigid, elastic: the true robot and the two calibrated models.
      readings: plate readings used (all payloads).
      stiffness: (n,) true stiffness; stiffness_identified: (n,) the
        elastostatic calibration's (NaN where not identified), N m/rad.
      static: (variant, payload kg) -> (K,) tool errors at the targets, m.
      deflection: (K,) tool deflection of the nominal commands with the
        largest payload (rest against rigid), m.
      diagram: variant -> (k,) tool errors of the station runs, m.
      diagram_gap: largest |station - static prediction| over those, m.
      mode: lowest structural mode of the nominal robot, rad/s; bandwidth:
        the controllers', rad/s.
      path: variant -> :class:`PathResult`.
      pickup: the module picked up mid-task (:class:`PickupResult`), or None.
      files: written files.
    """

    true: RobotModel
    rigid: RobotModel
    elastic: RobotModel
    readings: int
    stiffness: np.ndarray
    stiffness_identified: np.ndarray
    static: dict[tuple[str, float], np.ndarray]
    deflection: np.ndarray
    diagram: dict[str, np.ndarray]
    diagram_gap: float
    mode: float
    bandwidth: float
    path: dict[str, PathResult]
    pickup: PickupResult | None = None
    files: list[Path] = dataclasses.field(default_factory=list)

    def mean(self, variant: str, payload: float) -> float:
        """Mean static tool error of ``variant`` at ``payload`` kg, m."""
        return float(np.mean(self.static[(variant, payload)]))


# --- The study ----------------------------------------------------------------


def run_compliance_study(
    robot: RobotModel,
    config: ComplianceStudyConfig,
    out_dir: str | os.PathLike,
    *,
    echo: Callable[[str], None] = print,
    execution: Execution | TaskRunner = SERIAL,
) -> ComplianceStudyResult:
    """Runs the study (module docstring) on ``robot`` (elastic, with a payload
    entry), prints its tables and writes its files into ``out_dir``.

    The steps: :func:`true_elastic_arm`, :func:`readings_step`,
    :func:`calibration_step`, :func:`static_step`, :func:`station_step`,
    :func:`insertion_step`, :func:`pickup_step`, then
    :func:`write_compliance_files`; the readings of each payload and the
    station runs of the last three steps are tasks of ``execution`` (default:
    in this process), the result the same wherever they run.

    Raises:
      ValueError: a rigid robot or one without a payload, bad configuration
        values, and what the station and the calibration refuse.
    """
    out = Path(out_dir)
    truth = true_elastic_arm(robot, config)
    out.mkdir(parents=True, exist_ok=True)
    echo(
        f"true robot: {_mm(config.mean_error)} mm mean geometric error; stiffness "
        f"{np.array2string(truth.true.compliance.stiffness, precision=3)} N m/rad; "
        f"lowest structural mode {truth.mode:.1f} rad/s "
        f"({truth.mode / 2 / np.pi:.2f} Hz) with {truth.heaviest:g} kg, "
        f"controllers' bandwidth {truth.bandwidth:.2f} rad/s"
    )
    payloads = len(config.calibration_payloads) if config.readings_in_diagram else 0
    driven = len(VARIANTS) if min(config.diagram_targets, config.n_targets) > 0 else 0
    moves = len(VARIANTS) + len(PICKUP_SOURCES) if config.path_length > 0 else 0
    with TaskRunner(execution, tasks=payloads + driven + moves, echo=echo) as runner:
        readings = readings_step(robot, truth, config, runner=runner)
        echo(
            f"readings: {readings.data.n_readings} with payloads "
            f"{config.calibration_payloads} kg "
            f"({'in the Drake station' if config.readings_in_diagram else 'static'}"
            f"; {readings.wall_time:.0f} s)"
        )
        calibration = calibration_step(truth, readings, config)
        models = study_models(truth, calibration)
        static = static_step(truth, models, config)
        calls: dict[tuple[str, str], Callable[[], Any]] = {}
        for step, step_calls in (
            ("station", station_calls(truth, models, static, config)),
            ("insertion", insertion_calls(truth, models, static, config)),
            ("pickup", pickup_calls(truth, models, static, config)),
        ):
            calls.update({(step, k): call for k, call in step_calls.items()})
        done = runner.run_calls(list(calls.values()), desc="station runs")
    outputs = dict(zip(calls, done, strict=True))

    def of(step: str) -> dict[str, Any]:
        return {k: v for (s, k), v in outputs.items() if s == step}

    station = station_accuracy(truth, static, config, of("station"))
    insertion = insertion_runs(truth, static, config, of("insertion"))
    pickup = pickup_result(static, config, of("pickup"))
    result = ComplianceStudyResult(
        true=truth.true,
        rigid=calibration.rigid,
        elastic=calibration.elastic,
        readings=readings.data.n_readings,
        stiffness=calibration.stiffness,
        stiffness_identified=calibration.stiffness_identified,
        static=static.errors,
        deflection=static.deflection,
        diagram=station.errors,
        diagram_gap=station.gap,
        mode=truth.mode,
        bandwidth=truth.bandwidth,
        path={} if insertion is None else insertion.results,
        pickup=pickup,
    )
    result.files = write_compliance_files(
        out,
        config,
        result,
        calibration=calibration,
        static=static,
        insertion=insertion,
        echo=echo,
    )
    return result


def true_elastic_arm(robot: RobotModel, config: ComplianceStudyConfig) -> ElasticTruth:
    """Step 1: the nominal rigid model, the true elastic robot (the calibration
    study's draw of geometric errors with seed ``config.seed``, then the
    robot's joint stiffness times 1 + ``stiffness_spread`` N(0, 1), clipped to
    [0.5, 2], from stream 7 of the seed) and the controllers' bandwidth
    (``config.bandwidth``, or a quarter of the robot's lowest structural mode
    with the largest test payload at its home position), rad/s.

    Raises:
      ValueError: a robot without compliance or without a payload entry.
    """
    if robot.compliance is None or robot.payload is None:
        raise ValueError(
            f"robot '{robot.name}': the compliance study needs a robot with "
            "compliance (joint stiffness) and a payload entry"
        )
    nominal = dataclasses.replace(robot, compliance=None)
    draw = draw_true_robot(nominal, config, config.seed)
    rng = np.random.default_rng(stream(config.seed, 7))
    k = robot.compliance.stiffness
    factor = np.clip(1 + config.stiffness_spread * rng.standard_normal(k.size), 0.5, 2)
    true = dataclasses.replace(
        draw.true, name=f"{robot.name}_true", compliance=Compliance(k * factor)
    )
    heaviest = float(max(config.test_payloads))
    home = np.clip(np.zeros(robot.n_joints), robot.limits.lower, robot.limits.upper)
    mode = lowest_structural_mode(with_payload_mass(robot, heaviest), home, heaviest)
    bandwidth = config.bandwidth or 0.25 * mode
    return ElasticTruth(nominal, true, draw, heaviest, mode, bandwidth)


def readings_step(
    robot: RobotModel,
    truth: ElasticTruth,
    config: ComplianceStudyConfig,
    *,
    runner: TaskRunner | None = None,
) -> ElasticReadings:
    """Step 2: the plate readings of every calibration payload
    (:func:`payload_readings`; taken in the station, one task of ``runner``
    per payload, default in this process; the default execution starts its
    cluster at once for two or more: a payload's campaign takes minutes),
    with their payload column."""
    t0 = time.perf_counter()
    calls = [
        functools.partial(payload_readings, robot, truth, config, k, progress=True)
        for k in range(len(config.calibration_payloads))
    ]
    if config.readings_in_diagram:
        runner = runner or TaskRunner(SERIAL)
        if len(calls) > 1:
            runner.start_cluster()
        if runner.parallel:  # no progress bars from the workers
            calls = [functools.partial(c, progress=False) for c in calls]
        parts = runner.run_calls(calls, desc="payloads", progress=runner.parallel)
    else:  # from the static model: milliseconds
        parts = [call() for call in calls]
    masses = config.calibration_payloads
    data = PlaneMeasurements(
        np.concatenate([d.plane for d in parts]),
        np.concatenate([d.q for d in parts]),
        np.concatenate([d.distance for d in parts]),
        payload=np.concatenate(
            [np.full(d.n_readings, m) for d, m in zip(parts, masses, strict=True)]
        ),
    )
    return ElasticReadings(data, time.perf_counter() - t0)


def payload_readings(
    robot: RobotModel,
    truth: ElasticTruth,
    config: ComplianceStudyConfig,
    k: int,
    *,
    progress: bool = True,
) -> PlaneMeasurements:
    """Step 2 for the k-th of ``config.calibration_payloads`` (kg): the plate
    readings (range-finder distances, m; motor-side joint angles, rad), taken
    in the station (``config.readings_in_diagram``; ``progress`` shows them)
    or from the static model; in the station, the moves are integrated with
    ``config.readings_integration_schemes[k]`` when given. The configurations
    planned on the nominal model are pre-sagged for the payload with the
    robot's design stiffness (``robot.compliance``, not the truth's), as an
    operator aims the range finder at a plate under load. Noise seed: stream
    10 + k of the seed."""
    nominal, true, sim = truth.nominal, truth.true, truth.draw.simulation
    lo, hi = nominal.limits.lower + 5e-3, nominal.limits.upper - 5e-3
    mass = config.calibration_payloads[k]
    true_m, nominal_m = (
        with_payload_mass(true, mass),
        with_payload_mass(nominal, mass),
    )
    q_plan = np.clip(
        motor_angles(with_payload_mass(robot, mass), sim.data.q, mass), lo, hi
    )
    if config.readings_in_diagram:
        station = station_config(
            config, truth.bandwidth, InverseDynamicsControllerConfig()
        )
        station.sensors.seed = stream(config.seed, 10 + k)
        if config.readings_integration_schemes:
            scheme = config.readings_integration_schemes[k]
            station.simulator.integration_scheme = scheme
        run = measure_plates_in_diagram(
            station,
            true_model=true_m,
            plates=sim.plates,
            poses=[q_plan[sim.data.plane == p] for p in range(len(sim.plates))],
            nominal_model=nominal_m,
            reading_noise=config.noise,
            settle_time=config.settle_time,
            speed=config.speed,
            progress=progress,
            joint_log=False,
        )
        return run.data
    q_l = link_angles(true_m, q_plan, mass)
    rng = np.random.default_rng(stream(config.seed, 10 + k))
    d = range_readings(true.table, q_l, sim.plates, sim.data.plane, sigma=true.sigma)
    d = d + config.noise * rng.standard_normal(d.size)
    hit = np.isfinite(d)  # the beam may miss a plate the arm sags off
    return PlaneMeasurements(sim.data.plane[hit], q_plan[hit], d[hit])


def calibration_step(
    truth: ElasticTruth, readings: ElasticReadings, config: ComplianceStudyConfig
) -> ElasticCalibration:
    """Step 3: the rigid and the elastostatic calibration, by LM
    (:func:`~rmdrake.studies.calibration.plate_calibration`). The rigid one is
    the paper's: ``params`` from the readings of the lightest payload (a rigid
    model fitted to readings under several loads is told a contradiction; its
    fit on all of them is checked, not used). The elastostatic one: ``params``
    and every joint's compliance (those the readings cannot see are dropped by
    the identifiability analysis) from all readings. Each fit is checked
    against the declared reading noise (m); the calibrated kinematics are
    compared with the truth's at the draw's held-out poses."""
    nominal, data = truth.nominal, readings.data
    rigid = plate_calibration(config)
    elastic = dataclasses.replace(rigid, compliance=True)
    unloaded = data.subset(data.payload == data.payload.min())
    fits = {
        "rigid (lightest payload)": make_calibrator(rigid, nominal).fit(unloaded),
        "rigid (all payloads)": make_calibrator(rigid, nominal).fit(data),
        "elastostatic": make_calibrator(elastic, nominal).fit(data),
    }
    verdicts = {}
    for name, est in fits.items():
        check = est.sanity_  # against the declared noise (rigid.noise)
        flags = [*check.reasons, *check.warnings]
        verdicts[name] = "plausible" if not flags else "flagged: " + "; ".join(flags)
    rigid_model = fits["rigid (lightest payload)"].model_
    elastic_model = fits["elastostatic"].model_
    c_true, c_hat = joint_compliances(truth.true), joint_compliances(elastic_model)
    k_hat = np.where(c_hat > 0, 1.0 / np.where(c_hat > 0, c_hat, 1.0), np.nan)
    q_val = truth.draw.q_validation
    geometric = {
        name: tool_point_errors(m, truth.true, q_val).mean
        for name, m in (("rigid", rigid_model), ("elastostatic", elastic_model))
    }
    return ElasticCalibration(
        rigid=rigid_model,
        elastic=elastic_model,
        verdicts=verdicts,
        stiffness=1.0 / c_true,
        stiffness_identified=k_hat,
        geometric=geometric,
    )


def study_models(
    truth: ElasticTruth, calibration: ElasticCalibration
) -> dict[str, RobotModel]:
    """The ``models`` the variants plan with and the station runs take:
    ``nominal``, ``rigid``, ``elastic`` (the two calibrations) and ``true``."""
    return {
        "nominal": truth.nominal,
        "rigid": calibration.rigid,
        "elastic": calibration.elastic,
        "true": truth.true,
    }


def static_step(
    truth: ElasticTruth, models: dict[str, RobotModel], config: ComplianceStudyConfig
) -> StaticAccuracy:
    """Step 4, static: ``config.n_targets`` held-out targets (stream 8 of the
    seed), each variant's motor commands for them at every test payload and
    the tool position errors of the true arm at rest there; the nominal
    commands' tool deflection with the largest payload."""
    nominal, true, heaviest = truth.nominal, truth.true, truth.heaviest
    q_nom = held_out_configurations(
        nominal,
        config.n_targets,
        margin=config.target_margin,
        min_singular=config.min_singular,
        seed=stream(config.seed, 8),
    )
    X_BE = tool_poses(nominal.table, q_nom, sigma=nominal.sigma)
    errors: dict[tuple[str, float], np.ndarray] = {}
    q_link = _link_targets(models, q_nom, X_BE)
    for mass in config.test_payloads:
        for variant in VARIANTS:
            q_m = _command(variant, models, q_link[variant], mass)
            p_BE = _attained(true, q_m, mass)
            errors[(variant, mass)] = np.linalg.norm(p_BE - X_BE[:, :3, 3], axis=1)
    q_rest = link_angles(with_payload_mass(true, heaviest), q_nom, heaviest)
    deflection = np.linalg.norm(
        tool_poses(true.table, q_rest, sigma=true.sigma)[:, :3, 3]
        - tool_poses(true.table, q_nom, sigma=true.sigma)[:, :3, 3],
        axis=1,
    )
    q_comp = _command("elastostatic", models, q_link["elastostatic"][0], heaviest)
    return StaticAccuracy(q_nom, X_BE, q_link, errors, deflection, q_comp)


def station_step(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> StationAccuracy:
    """Step 4 in the station, in this process: :func:`station_calls`, then
    :func:`station_accuracy`."""
    calls = station_calls(truth, models, static, config)
    runs = {variant: call() for variant, call in calls.items()}
    return station_accuracy(truth, static, config, runs)


def station_calls(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> dict[str, Callable[[], np.ndarray]]:
    """Step 4 in the station, as tasks: per variant, the first
    ``diagram_targets`` targets driven by its controller with the largest
    payload (:func:`drive_variant`: the tool positions p_WM (k, 3), m; the
    elastostatic and oracle controllers pre-deflect online); none when no
    target is driven."""
    k = min(config.diagram_targets, config.n_targets)
    if k <= 0:
        return {}
    return {
        variant: functools.partial(
            drive_variant,
            config,
            variant,
            models,
            static.q_link[variant][:k],
            truth.heaviest,
            truth.bandwidth,
        )
        for variant in VARIANTS
    }


def station_accuracy(
    truth: ElasticTruth,
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
    p_WM: dict[str, np.ndarray],
) -> StationAccuracy:
    """Step 4 in the station: each variant's tool errors (m) at the driven
    targets from its tool positions ``p_WM`` (k, 3), m (of
    :func:`station_calls`), compared with the static prediction."""
    errors: dict[str, np.ndarray] = {}
    gap = 0.0
    k = min(config.diagram_targets, config.n_targets)
    for variant, p in p_WM.items():
        errors[variant] = np.linalg.norm(p - static.X_BE[:k, :3, 3], axis=1)
        predicted = static.errors[(variant, truth.heaviest)][:k]
        gap = max(gap, float(np.abs(errors[variant] - predicted).max()))
    return StationAccuracy(errors, gap)


def insertion_step(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> InsertionRuns | None:
    """Step 5, in this process: :func:`insertion_calls`, then
    :func:`insertion_runs`; None when ``config.path_length`` is 0."""
    calls = insertion_calls(truth, models, static, config)
    results = {variant: call() for variant, call in calls.items()}
    return insertion_runs(truth, static, config, results)


def insertion_calls(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> dict[str, Callable[[], PathResult]]:
    """Step 5, as tasks: per variant, the insertion-like move from the first
    target under its controller with the largest payload
    (:func:`insertion_path`); none when ``config.path_length`` is 0."""
    if not config.path_length > 0:
        return {}
    return {
        variant: functools.partial(
            insertion_path,
            config,
            variant,
            models,
            static.q_nominal[0],
            static.X_BE[0],
            truth.heaviest,
            truth.bandwidth,
        )
        for variant in VARIANTS
    }


def insertion_runs(
    truth: ElasticTruth,
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
    results: dict[str, PathResult],
) -> InsertionRuns | None:
    """Step 5: the program (:func:`insertion_program`) and the variants'
    ``results`` (of :func:`insertion_calls`); None when
    ``config.path_length`` is 0."""
    if not config.path_length > 0:
        return None
    program = insertion_program(
        truth.nominal, static.q_nominal[0], static.X_BE[0], config
    )
    return InsertionRuns(program, results)


def pickup_step(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> PickupResult | None:
    """Step 6: the largest payload picked up while the elastostatic controller
    holds the first target (:func:`run_pickup`), in this process; None when
    ``config.path_length`` is 0."""
    calls = pickup_calls(truth, models, static, config)
    runs = {source: call() for source, call in calls.items()}
    return pickup_result(static, config, runs)


def pickup_calls(
    truth: ElasticTruth,
    models: dict[str, RobotModel],
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> dict[str, Callable[[], PickupRun]]:
    """Step 6, as tasks: the pick-up runs of :data:`PICKUP_SOURCES`
    (:func:`pickup_run`); none when ``config.path_length`` is 0."""
    if not config.path_length > 0:
        return {}
    return {
        source: functools.partial(
            pickup_run,
            config,
            models,
            static.q_link["elastostatic"][0],
            truth.heaviest,
            truth.bandwidth,
            source,
        )
        for source in PICKUP_SOURCES
    }


def pickup_result(
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
    runs: dict[str, PickupRun],
) -> PickupResult | None:
    """Step 6: the figures of the pick-up ``runs`` (of :func:`pickup_calls`,
    by source) against the first target's tool position
    (:func:`pickup_figures`); None without runs."""
    if not runs:
        return None
    return pickup_figures(config, runs, static.X_BE[0, :3, 3])


def write_compliance_files(
    out_dir: str | os.PathLike,
    config: ComplianceStudyConfig,
    result: ComplianceStudyResult,
    *,
    calibration: ElasticCalibration,
    static: StaticAccuracy,
    insertion: InsertionRuns | None,
    echo: Callable[[str], None] = print,
) -> list[Path]:
    """Prints the study's tables (calibration checks, stiffness, static and
    station accuracy, the move and the pick-up), writes its files into
    ``out_dir`` (created if missing; :func:`write_files`), prints their names
    and returns them."""
    out = Path(out_dir)
    heaviest = float(max(config.test_payloads))
    for name, verdict in calibration.verdicts.items():
        echo(f"calibration {name}: {verdict}")
    echo("joint  stiffness true  identified  error")
    pairs = zip(result.stiffness, result.stiffness_identified, strict=True)
    for j, (kt, kh) in enumerate(pairs, start=1):
        err = "not seen" if np.isnan(kh) else f"{100 * (kh / kt - 1):+.2f} %"
        echo(f"{j:5d}  {kt:14.4g}  {kh:10.4g}  {err}")
    echo(
        "calibrated kinematics (no load), mean tool error: "
        + ", ".join(f"{k} {_mm(v)} mm" for k, v in calibration.geometric.items())
    )
    static_errors = result.static
    echo(f"static tool error over {config.n_targets} held-out targets, mean (max) mm:")
    echo("payload kg  " + "  ".join(f"{v:>18s}" for v in VARIANTS))
    for mass in config.test_payloads:
        cells = [
            f"{_mm(static_errors[(v, mass)].mean())} "
            f"({_mm(static_errors[(v, mass)].max())})"
            for v in VARIANTS
        ]
        echo(f"{mass:10g}  " + "  ".join(f"{c:>18s}" for c in cells))
    deflection = result.deflection
    echo(
        f"tool deflection under {heaviest:g} kg at the nominal commands: mean "
        f"{_mm(deflection.mean())} mm, max {_mm(deflection.max())} mm"
    )
    k = min(config.diagram_targets, config.n_targets)
    if k > 0:
        echo(
            f"in the Drake station ({k} targets, {heaviest:g} kg), mean mm: "
            + ", ".join(f"{v} {_mm(e.mean())}" for v, e in result.diagram.items())
            + f"; largest gap to the static prediction {_mm(result.diagram_gap)} mm"
        )
    if insertion is not None:
        echo(
            f"insertion: {config.path_length:g} m along the tool axis in "
            f"{insertion.program.duration:.1f} s, then {config.path_hold:g} s of "
            f"hold, {heaviest:g} kg"
        )
        echo("variant        path max mm  final mm  oscillation mm  settling s")
        for variant, r in insertion.results.items():
            echo(
                f"{variant:13s} {_mm(r.max_error):>11s}  {_mm(r.final_error):>8s}  "
                f"{_mm(r.oscillation):>14s}  {r.settling_time:10.2f}"
            )
    pickup = result.pickup
    if pickup is not None:
        echo(
            f"pick-up of {heaviest:g} kg while holding a target: tool error "
            f"{_mm(pickup.before)} mm before, {_mm(pickup.told)} mm after with the "
            f"controller's payload mass updated ({_mm(pickup.untold)} mm left at "
            f"0), peak {_mm(pickup.peak)} mm, settled in {pickup.settling_time:.1f} s"
        )
        echo(
            f"  estimating (payload estimator, {1 / PICKUP_ESTIMATOR_PERIOD:g} Hz, "
            f"forgetting {PICKUP_FORGETTING:g}): {_mm(pickup.estimating)} mm "
            f"after, peak {_mm(pickup.estimating_peak)} mm, settled in "
            f"{pickup.estimating_settling_time:.1f} s; estimated "
            f"{pickup.estimated_mass:.1f} kg"
        )
    out.mkdir(parents=True, exist_ok=True)
    files = write_files(result, config, out, static.q_nominal[0], static.q_compensated)
    for f in files:
        echo(f"wrote {f}")
    return files


def write_files(
    result: ComplianceStudyResult,
    config: ComplianceStudyConfig,
    out: Path,
    q0: np.ndarray,
    q_comp: np.ndarray,
) -> list[Path]:
    """Writes the study's PNGs, Meshcat page and ``results.yaml`` (module
    docstring) into the existing folder ``out``, silently; ``q0`` (n,) is a
    target's nominal configuration and ``q_comp`` (n,) the elastostatic
    variant's motor command for it with the largest payload, rad."""
    heaviest = float(max(config.test_payloads))
    files = [
        plot_payload_errors(
            {
                LABELS[v]: {m: result.static[(v, m)] for m in config.test_payloads}
                for v in VARIANTS
            },
            out / "payload_errors.png",
        ),
        plot_deflection_field(
            with_payload_mass(result.true, heaviest),
            heaviest,
            out / "deflection_field.png",
        ),
    ]
    # Meshcat: nominal target pose (grey), the sagging arm (nominal commands, red)
    # and the compensated one (green), the deflection magnified so that it shows
    # on an 8 m arm.
    true_m = with_payload_mass(result.true, heaviest)
    sag = link_angles(true_m, q0, heaviest) - q0
    comp = link_angles(true_m, q_comp, heaviest)
    scale = 20.0
    files.append(
        save_robot_states_html(
            true_m,
            {
                "nominal": (q0, 0.5),
                f"sagging x{scale:g}": (q0 + scale * sag, 1.0),
                f"compensated x{scale:g}": (q0 + scale * (comp - q0), 0.6),
            },
            out / "compliance.html",
            note=(
                f"{heaviest:g} kg payload (see-through spheres); link deflections "
                f"x{scale:g}; where the compensated arm reaches the nominal pose "
                "it covers the grey one"
            ),
        )
    )
    summary = {
        "lowest_mode_rad_s": result.mode,
        "bandwidth_rad_s": result.bandwidth,
        "readings": result.readings,
        "stiffness_true": result.stiffness.tolist(),
        "stiffness_identified": [
            None if np.isnan(v) else float(v) for v in result.stiffness_identified
        ],
        "deflection_mm": {
            "mean": 1e3 * float(result.deflection.mean()),
            "max": 1e3 * float(result.deflection.max()),
        },
        "static_mean_mm": {
            v: {float(m): 1e3 * result.mean(v, m) for m in config.test_payloads}
            for v in VARIANTS
        },
        "diagram_mean_mm": {
            v: 1e3 * float(e.mean()) for v, e in result.diagram.items()
        },
        "diagram_gap_mm": 1e3 * result.diagram_gap,
        "path": {
            v: {k: float(x) for k, x in dataclasses.asdict(r).items()}
            for v, r in result.path.items()
        },
        "pickup": None
        if result.pickup is None
        else {k: float(x) for k, x in dataclasses.asdict(result.pickup).items()},
    }
    files.append(
        atomic_write_text(
            out / "results.yaml", yaml.safe_dump(summary, sort_keys=False)
        )
    )
    return files


# --- The static model of the variants -------------------------------------------


def _link_targets(
    models: dict[str, RobotModel], q_nom: np.ndarray, X_BE: np.ndarray
) -> dict[str, np.ndarray]:
    """Link-side joint targets (K, n) of each variant, rad: the nominal IK (the
    targets' own configurations ``q_nom``), or the full tool poses ``X_BE``
    (K, 4, 4) solved on the variant's model, seeded there."""
    p, R = X_BE[:, :3, 3], X_BE[:, :3, :3]
    out = {"nominal": q_nom}
    for variant in VARIANTS[1:]:
        model = models[_MODEL_OF[variant]]
        out[variant] = correct_targets(model, p, q_seed=q_nom, orientation=R).q
    return out


def _command(
    variant: str, models: dict[str, RobotModel], q_link: np.ndarray, mass: float
) -> np.ndarray:
    """Motor-side commands (rad) of ``variant`` for its link-side targets
    ``q_link``: pre-deflected at ``mass`` kg by its model's compliances where
    it has them."""
    model = models[_MODEL_OF[variant]]
    if model.compliance is None:
        return q_link
    return motor_angles(with_payload_mass(model, mass), q_link, mass)


def _attained(true: RobotModel, q_m: np.ndarray, mass: float) -> np.ndarray:
    """(K, 3) tool positions p_BE of the true arm at rest with its motors at
    q_m (rad) holding ``mass`` kg, m."""
    q_l = link_angles(with_payload_mass(true, mass), q_m, mass)
    return tool_poses(true.table, q_l, sigma=true.sigma)[:, :3, 3]


def _mm(x: float) -> str:
    """``x`` m in mm, three decimals."""
    return f"{1e3 * x:.3f}"


# --- The station runs -----------------------------------------------------------


def station_config(
    config: ComplianceStudyConfig, bandwidth: float, controller
) -> StationConfig:
    """The study's station with ``controller`` at ``bandwidth`` rad/s."""
    station = copy.deepcopy(config.station)
    station.sensors.seed = int(config.seed)
    station.controller = controller
    station.controller.bandwidth = float(bandwidth)
    return station


def _controller(variant: str, bandwidth: float, mass: float):
    """The station controller of ``variant`` for static targets: computed
    torque on the nominal model for ``nominal`` and ``rigid`` (the targets are
    corrected already), the compensation controller pre-deflecting by its
    calibrated model's compliances at ``mass`` kg for ``elastostatic`` and
    ``oracle``."""
    if variant in ("nominal", "rigid"):
        return InverseDynamicsControllerConfig(bandwidth=bandwidth)
    return CompensationControllerConfig(
        bandwidth=bandwidth,
        kinematic_correction=False,
        deflection_compensation=True,
        payload_mass=mass,
    )


def _settling(
    t: np.ndarray, p: np.ndarray, after: np.ndarray, origin: float, band: float
) -> tuple[float, float]:
    """(largest distance of the tool positions ``p`` (K, 3) in the ``after``
    samples from the last one, m; the time from ``origin`` of the last of
    those outside ``band`` of it, s, 0 when none is)."""
    drift = np.linalg.norm(p[after] - p[-1], axis=1)
    outside = np.flatnonzero(drift > band)
    settle = float(t[after][outside[-1]] - origin) if outside.size else 0.0
    return float(drift.max()), settle


def _add_tool_tracker(builder, plant, signals):
    """Adds the tool tracker and a 20 Hz log of its reading p_WM (m)."""
    tracker = ToolTracker.AddToBuilder(builder, plant)
    return LogVectorOutput(tracker.get_output_port(), builder, 0.05)


def drive_variant(config, variant, models, q_link, mass, bandwidth):
    """Tool positions p_WM (k, 3), m, of the true arm driven in the station to
    the link-side targets ``q_link`` (k, n), rad (pre-deflected online where
    the variant compensates; as commands otherwise), holding ``mass`` kg."""
    station = station_config(config, bandwidth, _controller(variant, bandwidth, mass))
    nominal_m = with_payload_mass(models["nominal"], mass)
    calibrated = {"elastostatic": models["elastic"], "oracle": models["true"]}.get(
        variant
    )
    limits = nominal_m.limits
    moves = setpoint_move_times(
        q_link,
        velocity=config.speed * limits.velocity,
        acceleration=config.speed * limits.acceleration,
        q_start=q_link[0],
    )
    _, p_WM, _ = drive_to_targets(
        station,
        true_model=with_payload_mass(models["true"], mass),
        nominal_model=nominal_m,
        q_list=q_link,
        move_time=np.maximum(moves, 1.0),
        settle_time=config.settle_time,
        q_start=q_link[0],
        identified_model=None if calibrated is None else nominal_m,
        calibrated_model=None
        if calibrated is None
        else with_payload_mass(calibrated, mass),
        controller=station.controller,
    )
    return p_WM


def insertion_program(nominal, q_start, X_BE, config):
    """The joint programme of a straight move of ``path_length`` (m) along the
    tool's approach axis z_E from the tool pose ``X_BE`` (4, 4), planned on
    the nominal model from near ``q_start`` (n,), rad."""
    R = X_BE[:3, :3]
    R_BP = np.column_stack([R[:, 2], R[:, 0], R[:, 1]])  # P's x = tool z
    path = PlanarPath("line", X_BE[:3, 3], R_BP, config.path_length)
    return plan_path_program(
        nominal, path, R, q_seed=q_start, speed=config.path_speed, samples=101
    )


def run_path(config, variant, models, program, mass, bandwidth) -> PathResult:
    """The insertion-like move of ``program`` under ``variant``'s controller
    with ``mass`` kg at ``bandwidth`` rad/s, then ``config.path_hold`` s of
    hold (module docstring, step 5)."""
    layers = {
        "nominal": InverseDynamicsControllerConfig(bandwidth=bandwidth),
        "rigid": CompensationControllerConfig(
            bandwidth=bandwidth, deflection_compensation=False
        ),
    }
    controller = layers.get(variant) or CompensationControllerConfig(
        bandwidth=bandwidth, deflection_compensation=True, payload_mass=mass
    )
    setup = station_config(config, bandwidth, controller)
    setup.simulator.start_time = 0.0
    calibrated = {
        "rigid": models["rigid"],
        "elastostatic": models["elastic"],
        "oracle": models["true"],
    }.get(variant)
    nominal_m, true_m = (
        with_payload_mass(models["nominal"], mass),
        with_payload_mass(models["true"], mass),
    )
    station = MakeStation(
        setup,
        true_model=true_m,
        trajectory=program.trajectory,
        nominal_model=nominal_m,
        calibrated_model=None
        if calibrated is None
        else with_payload_mass(calibrated, mass),
        identified_model=None if calibrated is None else nominal_m,
        add_systems=_add_tool_tracker,
        joint_logs=False,
    )
    context = station.CreateDefaultContext()
    start_at_command(station, context)
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(setup.simulator, simulator)
    simulator.Initialize()
    T = program.duration
    simulator.AdvanceTo(T + config.path_hold)
    log = station.extras.FindLog(context)
    t, p = log.sample_times(), log.data().T
    moving = t <= T
    error = np.linalg.norm(p - program.tool_points(np.minimum(t, T)), axis=1)
    oscillation, settle = _settling(t, p, ~moving, T, config.settle_band)
    return PathResult(
        max_error=float(error[moving].max()),
        final_error=float(error[-1]),
        oscillation=oscillation,
        settling_time=settle,
    )


def insertion_path(
    config: ComplianceStudyConfig,
    variant: str,
    models: dict[str, RobotModel],
    q_start: np.ndarray,
    X_BE: np.ndarray,
    mass: float,
    bandwidth: float,
) -> PathResult:
    """Step 5 for one variant, as a task: the program of
    :func:`insertion_program` from the tool pose ``X_BE`` (4, 4) near
    ``q_start`` (n,), rad, planned on ``models["nominal"]`` here (it holds a
    Drake trajectory, which does not pickle), then :func:`run_path` with
    ``mass`` kg at ``bandwidth`` rad/s."""
    program = insertion_program(models["nominal"], q_start, X_BE, config)
    return run_path(config, variant, models, program, mass, bandwidth)


@dataclasses.dataclass(frozen=True)
class PickupRun:
    """One pick-up run (:func:`pickup_run`).

    Attributes:
      t: (K,) log times, s.
      p_WM: (K, 3) tool positions, m.
      estimated_mass: the estimator's payload mass at the end, kg (None
        without an estimator).
    """

    t: np.ndarray
    p_WM: np.ndarray
    estimated_mass: float | None


def pickup_run(config, models, q_link, mass, bandwidth, source: str) -> PickupRun:
    """One run of :func:`run_pickup`, the controller's payload mass from
    ``source`` (one of :data:`PICKUP_SOURCES`)."""
    t, p, m = _hold_with_pickup(config, models, q_link, mass, bandwidth, source)
    return PickupRun(t, p, m)


def run_pickup(config, models, q_link, target, mass, bandwidth) -> PickupResult:
    """The elastostatic controller holds the link-side target ``q_link`` for
    ``config.path_hold`` s after a 1 s move, its ``payload_mass`` port at 0;
    then a ``mass`` kg module's weight passes onto the tool over 5 s (the true
    plant's payload body inertia, a Context parameter) and, in the told run,
    the port follows it step by step; then another ``path_hold`` s.
    ``target``: the tool position aimed at (3,), m. Times in the result count
    from the end of the transfer. A third run, ``estimating``, leaves the
    port to a :class:`~rmdrake.systems.payload_estimator.PayloadEstimator`
    (mass and first moments, every :data:`PICKUP_ESTIMATOR_PERIOD` s,
    forgetting factor :data:`PICKUP_FORGETTING`) on the station's measured q,
    qd, qdd and tau, with the elastostatic calibration's arm (no payload).

    The port sets the pre-deflection and the payload's gravity feedforward
    (``payload_effort``); the controller's rigid-body model holds the module's
    inertia throughout: a computed-torque loop with integral action whose
    model inertia is under 1/9 of the truth's is unstable (its closed-loop
    polynomial fails Routh's test), and the 4.5 t module 0.8 m ahead of the
    tool multiplies the wrist joints' inertia about twentyfold.
    """
    runs = {
        source: pickup_run(config, models, q_link, mass, bandwidth, source)
        for source in PICKUP_SOURCES
    }
    return pickup_figures(config, runs, target)


def pickup_figures(
    config: ComplianceStudyConfig, runs: dict[str, PickupRun], target: np.ndarray
) -> PickupResult:
    """The :class:`PickupResult` of the pick-up ``runs`` by source (every one
    of :data:`PICKUP_SOURCES`) against the tool position aimed at,
    ``target`` (3,), m; times count from the end of the transfer, s."""
    t0 = 1.0 + float(config.path_hold)
    ends, figures, estimated = {}, {}, float("nan")
    for source in PICKUP_SOURCES:
        run = runs[source]
        t, p, m = run.t, run.p_WM, run.estimated_mass
        ends[source] = (t, p, np.linalg.norm(p - target, axis=1))
        after = t > t0
        _, settle = _settling(t, p, after, t0 + _TRANSFER, config.settle_band)
        figures[source] = (float(ends[source][2][after].max()), settle)
        if m is not None:
            estimated = m
    t, p, error = ends["told"]
    after = t > t0
    return PickupResult(
        before=float(error[~after][-1]),
        told=float(error[-1]),
        untold=float(ends["not told"][2][-1]),
        peak=figures["told"][0],
        settling_time=figures["told"][1],
        estimating=float(ends["estimating"][2][-1]),
        estimating_peak=figures["estimating"][0],
        estimating_settling_time=figures["estimating"][1],
        estimated_mass=estimated,
    )


def _hold_with_pickup(config, models, q_link, mass, bandwidth, source: str):
    """One pick-up run (see :func:`run_pickup`) with the controller's payload
    mass ``source`` (``told``, ``not told`` or ``estimating``): (t (K,) s, p_WM
    (K, 3) m, the estimator's final mass in kg or None)."""
    hold = float(config.path_hold)
    true_m = with_payload_mass(models["true"], mass)
    # The rigid-body model holds the module's inertia; the payload_mass port
    # sets the gravity feedforward and the pre-deflection (run_pickup).
    loaded = with_payload_mass(models["nominal"], mass)
    estimating = source == "estimating"
    controller = CompensationControllerConfig(
        bandwidth=bandwidth,
        kinematic_correction=False,
        payload_mass=0.0,
        payload_mass_input=estimating,
    )
    setup = station_config(config, bandwidth, controller)
    setup.simulator.start_time = 0.0
    end = 1.0 + 2 * hold + _TRANSFER
    add_systems = _add_tool_tracker
    if estimating:
        arm = dataclasses.replace(models["elastic"], payload=None)
        noise = np.asarray(setup.sensors.torque_noise, dtype=np.float64)
        std = noise if np.all(noise > 0) else None

        def add_systems(builder, plant, signals):
            log = _add_tool_tracker(builder, plant, signals)
            PayloadEstimator.AddToBuilder(
                builder,
                model=arm,
                **signals,
                payload_mass=builder.GetMutableSubsystemByName(
                    "controller"
                ).GetInputPort("payload_mass"),
                period=PICKUP_ESTIMATOR_PERIOD,
                forgetting=PICKUP_FORGETTING,
                torque_std=std,
                coulomb_width=float(setup.v_eps),
            )
            return log

    station = MakeStation(
        setup,
        true_model=true_m,
        trajectory=setpoint_trajectory(q_link[None, :], move_time=1.0, settle_time=end),
        nominal_model=loaded,
        calibrated_model=with_payload_mass(models["elastic"], mass),
        identified_model=loaded,
        add_systems=add_systems,
        joint_logs=False,
    )
    context = station.CreateDefaultContext()
    plant = station.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    body = plant.GetBodyByName("payload")
    if not estimating:
        mass_source = station.diagram.GetSubsystemByName("payload_mass")
        source_value = mass_source.get_mutable_source_value(
            mass_source.GetMyMutableContextFromRoot(context)
        )
    body.SetSpatialInertiaInBodyFrame(plant_context, payload_inertia(true_m.payload, 0))
    start_at_command(station, context, payload_mass=0.0)
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(setup.simulator, simulator)
    simulator.Initialize()
    simulator.AdvanceTo(1.0 + hold)
    for k in range(1, 26):
        m = mass * k / 25
        body.SetSpatialInertiaInBodyFrame(
            plant_context, payload_inertia(true_m.payload, m)
        )
        if source == "told":
            source_value.SetFromVector([m])
        simulator.AdvanceTo(1.0 + hold + _TRANSFER * k / 25)
    simulator.AdvanceTo(end)
    log = station.extras.FindLog(context)
    estimated = None
    if estimating:
        estimator = station.diagram.GetSubsystemByName("payload_estimator")
        port = estimator.GetOutputPort("payload_mass")
        estimated = float(port.Eval(estimator.GetMyContextFromRoot(context))[0])
    return log.sample_times(), log.data().T, estimated
