"""The compliance study's runs of one variant in the Drake station: its
controller driving the true elastic arm, holding a payload, to static targets
(:func:`drive_variant`, step 4) and along the insertion-like move
(:func:`insertion_path`, step 5). Each is a task of
:mod:`rmdrake.execution` (its arguments pickle); the tool tracker's p_WM
(the true tool origin, W = B, m) is what they read.

Example, the oracle driven to the first target with the largest payload::

    p_WM = drive_variant(
        config, ORACLE, models, static.q_link["oracle"][:1], mass, bandwidth
    )
"""

from __future__ import annotations

import copy

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from rmdrake.compensation.paths import JointPathProgram, PlanarPath, plan_path_program
from rmdrake.dynamics.compliance import with_payload_mass
from rmdrake.model.robot import RobotModel
from rmdrake.studies.closed_loop import (
    TargetDrive,
    drive_to_targets,
    start_at_command,
)
from rmdrake.studies.elastic_arm.results import PathResult
from rmdrake.studies.elastic_arm.variants import ElasticModels, Variant
from rmdrake.studies.scenarios import ComplianceStudyConfig
from rmdrake.systems.sensors import ToolTracker
from rmdrake.systems.station import MakeStation, simulation_progress
from rmdrake.systems.station_config import ControllerConfig, StationConfig
from rmdrake.systems.station_sources import setpoint_move_times

__all__ = [
    "add_tool_tracker",
    "drive_variant",
    "insertion_path",
    "insertion_program",
    "run_path",
    "settling",
    "station_config",
]


def station_config(
    config: ComplianceStudyConfig, bandwidth: float, controller: ControllerConfig
) -> StationConfig:
    """A copy of the study's station (``config.station``, its sensors seeded
    with ``config.seed``) with ``controller`` at ``bandwidth`` rad/s."""
    station = copy.deepcopy(config.station)
    station.sensors.seed = int(config.seed)
    station.controller = controller
    station.controller.bandwidth = float(bandwidth)
    return station


def settling(
    t: np.ndarray, p: np.ndarray, after: np.ndarray, origin: float, band: float
) -> tuple[float, float]:
    """How the tool came to rest: (the largest distance of the tool positions
    ``p`` (K, 3), m, in the ``after`` samples (K,) bool from the last one, m;
    the time from ``origin`` s of the last of those outside ``band`` m of it,
    s, 0 when none is). ``t``: (K,) sample times, s."""
    drift = np.linalg.norm(p[after] - p[-1], axis=1)
    outside = np.flatnonzero(drift > band)
    settle = float(t[after][outside[-1]] - origin) if outside.size else 0.0
    return float(drift.max()), settle


def add_tool_tracker(
    builder: DiagramBuilder, plant: MultibodyPlant, signals: dict[str, OutputPort]
) -> VectorLogSink:
    """A station's ``add_systems``: the tool tracker and a 20 Hz log of its
    reading p_WM (3,), m; returns the log (the station's ``extras``).
    ``signals`` (the station's measured joint signals) are not used."""
    tracker = ToolTracker.AddToBuilder(builder, plant)
    return LogVectorOutput(tracker.get_output_port(), builder, 0.05)


def drive_variant(
    config: ComplianceStudyConfig,
    variant: Variant,
    models: ElasticModels,
    q_link: np.ndarray,
    mass: float,
    bandwidth: float,
) -> np.ndarray:
    """Tool positions p_WM (k, 3), m, of the true arm driven in the station by
    ``variant``'s controller for static targets (at ``bandwidth`` rad/s) to
    the link-side targets ``q_link`` (k, n), rad, holding ``mass`` kg:
    pre-deflected online where the variant compensates, as commands
    otherwise; ``config.settle_time`` s of hold at each."""
    controller, calibrated = variant.target_controller(models, bandwidth, mass)
    station = station_config(config, bandwidth, controller)
    nominal_m = with_payload_mass(models.nominal, mass)
    limits = nominal_m.limits
    moves = setpoint_move_times(
        q_link,
        velocity=config.speed * limits.velocity,
        acceleration=config.speed * limits.acceleration,
        q_start=q_link[0],
    )
    drive = TargetDrive(
        q_link, np.maximum(moves, 1.0), config.settle_time, q_start=q_link[0]
    )
    _, p_WM, _ = drive_to_targets(
        station,
        drive,
        true_model=with_payload_mass(models.true, mass),
        nominal_model=nominal_m,
        identified_model=None if calibrated is None else nominal_m,
        calibrated_model=None
        if calibrated is None
        else with_payload_mass(calibrated, mass),
        controller=station.controller,
    )
    return p_WM


def insertion_program(
    nominal: RobotModel,
    q_start: np.ndarray,
    X_BE: np.ndarray,
    config: ComplianceStudyConfig,
) -> JointPathProgram:
    """The joint programme of a straight move of ``config.path_length`` m
    along the tool's approach axis z_E from the tool pose ``X_BE`` (4, 4; m,
    in the base frame B) at ``config.path_speed``, planned on the ``nominal``
    model from near ``q_start`` (n,), rad."""
    R = X_BE[:3, :3]
    R_BP = np.column_stack([R[:, 2], R[:, 0], R[:, 1]])  # P's x = tool z
    path = PlanarPath("line", X_BE[:3, 3], R_BP, config.path_length)
    return plan_path_program(
        nominal, path, R, q_seed=q_start, speed=config.path_speed, samples=101
    )


def run_path(
    config: ComplianceStudyConfig,
    variant: Variant,
    models: ElasticModels,
    program: JointPathProgram,
    mass: float,
    bandwidth: float,
) -> PathResult:
    """The insertion-like move of ``program`` under ``variant``'s controller
    for the move, with ``mass`` kg at ``bandwidth`` rad/s, then
    ``config.path_hold`` s of hold: the tool path error, the residual
    oscillation after the stop and its settling time (within
    ``config.settle_band`` m)."""
    controller, calibrated = variant.move_controller(models, bandwidth, mass)
    setup = station_config(config, bandwidth, controller)
    setup.simulator.start_time = 0.0
    nominal_m, true_m = (
        with_payload_mass(models.nominal, mass),
        with_payload_mass(models.true, mass),
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
        add_systems=add_tool_tracker,
        joint_logs=False,
    )
    context = station.CreateDefaultContext()
    start_at_command(station, context)
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(setup.simulator, simulator)
    T = program.duration
    with simulation_progress(simulator, T + config.path_hold):
        simulator.Initialize()
        simulator.AdvanceTo(T + config.path_hold)
    log = station.extras.FindLog(context)
    t, p = log.sample_times(), log.data().T
    moving = t <= T
    error = np.linalg.norm(p - program.tool_points(np.minimum(t, T)), axis=1)
    oscillation, settle = settling(t, p, ~moving, T, config.settle_band)
    return PathResult(
        max_error=float(error[moving].max()),
        final_error=float(error[-1]),
        oscillation=oscillation,
        settling_time=settle,
    )


def insertion_path(
    config: ComplianceStudyConfig,
    variant: Variant,
    models: ElasticModels,
    q_start: np.ndarray,
    X_BE: np.ndarray,
    mass: float,
    bandwidth: float,
) -> PathResult:
    """Step 5 for one variant, as a task: the program of
    :func:`insertion_program` from the tool pose ``X_BE`` (4, 4) near
    ``q_start`` (n,), rad, planned on ``models.nominal`` here (it holds a
    Drake trajectory, which does not pickle), then :func:`run_path` with
    ``mass`` kg at ``bandwidth`` rad/s."""
    program = insertion_program(models.nominal, q_start, X_BE, config)
    return run_path(config, variant, models, program, mass, bandwidth)
