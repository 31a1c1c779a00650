"""The compliance study's steps (see :mod:`rmdrake.studies.elastic_arm`),
each a function returning a small frozen dataclass of
:mod:`~rmdrake.studies.elastic_arm.results`:

1. :func:`true_elastic_arm` (:class:`ElasticTruth`): the robots and the
   controllers' bandwidth;
2. :func:`readings_step` (:class:`ElasticReadings`): the plate readings of
   every calibration payload, one task per payload
   (:func:`payload_readings`);
3. :func:`calibration_step` (:class:`ElasticCalibration`): the rigid and
   the elastostatic calibration; :func:`study_models` gathers the models;
4. :func:`static_step` (:class:`StaticAccuracy`): the static tool accuracy
   of each variant; in the station, :func:`station_calls` (tasks), then
   :func:`station_accuracy` (:class:`StationAccuracy`);
5. :func:`insertion_calls` (tasks), then :func:`insertion_runs`
   (:class:`InsertionRuns`): the insertion-like move;
6. :func:`pickup_calls` (tasks), then :func:`pickup_result`
   (:class:`PickupResult`): the module picked up mid-task.

The station runs of steps 4-6 are tasks (``*_calls``: functions of no
argument, keyed by variant or pick-up source name) so that the study runs them
together on its workers; run in this process, step 5 reads::

    calls = insertion_calls(truth, models, static, config)
    runs = insertion_runs(
        truth, static, config, {k: call() for k, call in calls.items()}
    )
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable

import numpy as np

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.plates.simulate import range_readings
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.dynamics.compliance import (
    joint_compliances,
    link_angles,
    lowest_structural_mode,
    motor_angles,
    with_payload_mass,
)
from rmdrake.execution import SERIAL, TaskRunner
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.robot import Compliance, RobotModel
from rmdrake.studies.calibration import draw_true_robot, plate_calibration
from rmdrake.studies.compensation import held_out_configurations
from rmdrake.studies.elastic_arm.pickup import (
    PICKUP_SOURCES,
    pickup_figures,
    pickup_run,
)
from rmdrake.studies.elastic_arm.results import (
    ElasticCalibration,
    ElasticReadings,
    ElasticTruth,
    InsertionRuns,
    PathResult,
    PickupResult,
    PickupRun,
    StaticAccuracy,
    StationAccuracy,
)
from rmdrake.studies.elastic_arm.station_runs import (
    drive_variant,
    insertion_path,
    insertion_program,
    station_config,
)
from rmdrake.studies.elastic_arm.variants import (
    ELASTOSTATIC,
    VARIANTS,
    ElasticModels,
    attained_positions,
    link_targets,
)
from rmdrake.studies.scenarios import ComplianceStudyConfig, stream
from rmdrake.systems.measurement_runs import measure_plates_in_diagram
from rmdrake.systems.station_config import InverseDynamicsControllerConfig

__all__ = [
    "calibration_step",
    "insertion_calls",
    "insertion_runs",
    "payload_readings",
    "pickup_calls",
    "pickup_result",
    "readings_step",
    "static_step",
    "station_accuracy",
    "station_calls",
    "study_models",
    "true_elastic_arm",
]


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
        # On workers, each payload's readings bar shows here at each interval.
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


def study_models(truth: ElasticTruth, calibration: ElasticCalibration) -> ElasticModels:
    """The models the variants plan with and the station runs take: the
    nominal and the true robot (``truth``) and the two calibrations."""
    return ElasticModels(
        nominal=truth.nominal,
        rigid=calibration.rigid,
        elastic=calibration.elastic,
        true=truth.true,
    )


def static_step(
    truth: ElasticTruth, models: ElasticModels, config: ComplianceStudyConfig
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
    q_link = link_targets(models, q_nom, X_BE)
    for mass in config.test_payloads:
        for variant in VARIANTS:
            q_m = variant.motor_commands(models, q_link[variant.name], mass)
            p_BE = attained_positions(true, q_m, mass)
            errors[(variant.name, mass)] = np.linalg.norm(p_BE - X_BE[:, :3, 3], axis=1)
    q_rest = link_angles(with_payload_mass(true, heaviest), q_nom, heaviest)
    deflection = np.linalg.norm(
        tool_poses(true.table, q_rest, sigma=true.sigma)[:, :3, 3]
        - tool_poses(true.table, q_nom, sigma=true.sigma)[:, :3, 3],
        axis=1,
    )
    q_comp = ELASTOSTATIC.motor_commands(models, q_link[ELASTOSTATIC.name][0], heaviest)
    return StaticAccuracy(q_nom, X_BE, q_link, errors, deflection, q_comp)


def station_calls(
    truth: ElasticTruth,
    models: ElasticModels,
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
        variant.name: functools.partial(
            drive_variant,
            config,
            variant,
            models,
            static.q_link[variant.name][:k],
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


def insertion_calls(
    truth: ElasticTruth,
    models: ElasticModels,
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> dict[str, Callable[[], PathResult]]:
    """Step 5, as tasks: per variant, the insertion-like move from the first
    target under its controller with the largest payload
    (:func:`insertion_path`); none when ``config.path_length`` is 0."""
    if not config.path_length > 0:
        return {}
    return {
        variant.name: functools.partial(
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


def pickup_calls(
    truth: ElasticTruth,
    models: ElasticModels,
    static: StaticAccuracy,
    config: ComplianceStudyConfig,
) -> dict[str, Callable[[], PickupRun]]:
    """Step 6, as tasks: the pick-up runs of :data:`PICKUP_SOURCES`
    (:func:`pickup_run`); none when ``config.path_length`` is 0."""
    if not config.path_length > 0:
        return {}
    return {
        source.name: functools.partial(
            pickup_run,
            config,
            models,
            static.q_link[ELASTOSTATIC.name][0],
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
