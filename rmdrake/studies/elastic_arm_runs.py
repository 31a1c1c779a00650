"""The station runs of the elastic-arm study (:mod:`rmdrake.studies.elastic_arm`):
targets driven in the Drake station and the insertion-like move, each under
the controller of a variant.

Variants: ``nominal`` and ``rigid`` run computed torque on the nominal
(rigid) model, the rigid calibration's targets corrected already for the
static runs and online inside the compensation controller for the move;
``elastostatic`` and ``oracle`` run the compensation controller, which
pre-deflects its command by its calibrated model's compliances at the
payload (:class:`~rmdrake.systems.deflection.DeflectionCompensation`).
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import yaml
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.primitives import LogVectorOutput

from rmdrake.compensation.paths import PlanarPath, plan_path_program
from rmdrake.dynamics.compliance import link_angles, with_payload_mass
from rmdrake.io.atomic import atomic_write_text
from rmdrake.model.plant import payload_inertia
from rmdrake.report.plots import plot_deflection_field, plot_payload_errors
from rmdrake.studies.closed_loop import drive_to_targets, start_at_command
from rmdrake.studies.compliance_config import ComplianceStudyConfig
from rmdrake.systems.sensors import ToolTracker
from rmdrake.systems.station import MakeStation
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    InverseDynamicsControllerConfig,
)
from rmdrake.systems.station_sources import setpoint_move_times, setpoint_trajectory
from rmdrake.systems.visualization import save_robot_states_html

VARIANTS = ("nominal", "rigid", "elastostatic", "oracle")
"""The compared controllers (:mod:`rmdrake.studies.elastic_arm`, step 4)."""
LABELS = {
    "nominal": "nominal controller",
    "rigid": "rigid calibration (paper)",
    "elastostatic": "elastostatic calibration + compensation",
    "oracle": "oracle (true kinematics and compliance)",
}

__all__ = [
    "LABELS",
    "VARIANTS",
    "PathResult",
    "PickupResult",
    "drive_variant",
    "insertion_program",
    "run_path",
    "run_pickup",
    "station_config",
    "write_files",
]


def station_config(config: ComplianceStudyConfig, bandwidth: float, controller):
    """The study's station with ``controller`` at ``bandwidth`` rad/s."""
    station = copy.deepcopy(config.station)
    station.sensors.seed = int(config.seed)
    station.controller = controller
    station.controller.bandwidth = float(bandwidth)
    return station


@dataclasses.dataclass
class PathResult:
    """The insertion-like move under one variant (SI units).

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


def _controller(variant: str, bandwidth: float, mass: float):
    """The station controller of ``variant``: computed torque on the nominal
    model for ``nominal`` and ``rigid`` (the targets are corrected already),
    the compensation controller pre-deflecting by its calibrated model's
    compliances for ``elastostatic`` and ``oracle``."""
    if variant in ("nominal", "rigid"):
        return InverseDynamicsControllerConfig(bandwidth=bandwidth)
    return CompensationControllerConfig(
        bandwidth=bandwidth,
        kinematic_correction=False,
        deflection_compensation=True,
        payload_mass=mass,
    )


def drive_variant(config, variant, models, q_link, mass, bandwidth):
    """Tool positions (k, 3) of the true arm driven in the station to the
    link-side targets ``q_link`` (pre-deflected online where the variant
    compensates; as commands otherwise)."""
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


def run_path(config, variant, models, program, mass, bandwidth) -> PathResult:
    """The insertion-like move of ``program`` under ``variant``'s controller,
    then ``config.path_hold`` s of hold (module docstring, step 5)."""
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

    def add_tracker(builder, plant, signals):
        tracker = ToolTracker.AddToBuilder(builder, plant)
        return LogVectorOutput(tracker.get_output_port(), builder, 0.05)

    station = MakeStation(
        setup,
        true_model=true_m,
        trajectory=program.trajectory,
        nominal_model=nominal_m,
        calibrated_model=None
        if calibrated is None
        else with_payload_mass(calibrated, mass),
        identified_model=None if calibrated is None else nominal_m,
        add_systems=add_tracker,
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


@dataclasses.dataclass
class PickupResult:
    """A module picked up mid-task (SI units): the arm holds a target with no
    payload, then the payload's mass appears on the tool (the true plant's
    payload body, a Context parameter) and, for ``told``, on the controller's
    ``payload_mass`` source at the same instant.

    Attributes:
      before: tool error at the end of the unloaded hold, m.
      told, untold: tool error at the end of the loaded hold, with the
        controller's payload mass updated and left at 0, m.
      peak: largest tool error after the pick-up (told), m.
      settling_time: time after the pick-up until the told arm stays within the
        settle band of its final position, s.
    """

    before: float
    told: float
    untold: float
    peak: float
    settling_time: float


_TRANSFER = 5.0
"""s over which a picked-up module's weight passes onto the arm (a crane or a
support lowering it), in 25 steps."""


def _hold_with_pickup(config, models, q_link, mass, bandwidth, told: bool):
    """One pick-up run (see :func:`run_pickup`): (t (K,), p_WM (K, 3))."""
    hold = float(config.path_hold)
    true_m = with_payload_mass(models["true"], mass)
    # The rigid-body model holds the module's inertia; the payload_mass port
    # sets the gravity feedforward and the pre-deflection (run_pickup).
    loaded = with_payload_mass(models["nominal"], mass)
    controller = CompensationControllerConfig(
        bandwidth=bandwidth, kinematic_correction=False, payload_mass=0.0
    )
    setup = station_config(config, bandwidth, controller)
    setup.simulator.start_time = 0.0

    def add_tracker(builder, plant, signals):
        tracker = ToolTracker.AddToBuilder(builder, plant)
        return LogVectorOutput(tracker.get_output_port(), builder, 0.05)

    end = 1.0 + 2 * hold + _TRANSFER
    station = MakeStation(
        setup,
        true_model=true_m,
        trajectory=setpoint_trajectory(q_link[None, :], move_time=1.0, settle_time=end),
        nominal_model=loaded,
        calibrated_model=with_payload_mass(models["elastic"], mass),
        identified_model=loaded,
        add_systems=add_tracker,
    )
    context = station.CreateDefaultContext()
    plant = station.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    body = plant.GetBodyByName("payload")
    source = station.diagram.GetSubsystemByName("payload_mass")
    source_value = source.get_mutable_source_value(
        source.GetMyMutableContextFromRoot(context)
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
        if told:
            source_value.SetFromVector([m])
        simulator.AdvanceTo(1.0 + hold + _TRANSFER * k / 25)
    simulator.AdvanceTo(end)
    log = station.extras.FindLog(context)
    return log.sample_times(), log.data().T


def run_pickup(config, models, q_link, target, mass, bandwidth) -> PickupResult:
    """The elastostatic controller holds the link-side target ``q_link`` for
    ``config.path_hold`` s after a 1 s move, its ``payload_mass`` port at 0;
    then a ``mass`` kg module's weight passes onto the tool over 5 s (the true
    plant's payload body inertia, a Context parameter) and, in the told run,
    the port follows it step by step; then another ``path_hold`` s.
    ``target``: the tool position aimed at (3,), m. Times in the result count
    from the end of the transfer.

    The port sets the pre-deflection and the payload's gravity feedforward
    (``payload_effort``); the controller's rigid-body model holds the module's
    inertia throughout: a computed-torque loop with integral action whose
    model inertia is under 1/9 of the truth's is unstable (its closed-loop
    polynomial fails Routh's test), and the 4.5 t module 0.8 m ahead of the
    tool multiplies the wrist joints' inertia about twentyfold.
    """
    t0 = 1.0 + float(config.path_hold)
    ends = {}
    for told in (True, False):
        t, p = _hold_with_pickup(config, models, q_link, mass, bandwidth, told)
        ends[told] = (t, p, np.linalg.norm(p - target, axis=1))
    t, p, error = ends[True]
    after = t > t0
    _, settle = _settling(t, p, after, t0 + _TRANSFER, config.settle_band)
    return PickupResult(
        before=float(error[~after][-1]),
        told=float(error[-1]),
        untold=float(ends[False][2][-1]),
        peak=float(error[after].max()),
        settling_time=settle,
    )


def insertion_program(nominal, q_start, X_BE, config):
    """The joint programme of a straight move of ``path_length`` along the
    tool's approach axis z_E from the tool pose ``X_BE``, planned on the
    nominal model."""
    R = X_BE[:3, :3]
    R_BP = np.column_stack([R[:, 2], R[:, 0], R[:, 1]])  # P's x = tool z
    path = PlanarPath("line", X_BE[:3, 3], R_BP, config.path_length)
    return plan_path_program(
        nominal, path, R, q_seed=q_start, speed=config.path_speed, samples=101
    )


def write_files(
    result, config: ComplianceStudyConfig, out: Path, q0: np.ndarray, q_comp: np.ndarray
) -> list[Path]:
    """Writes the study's PNGs, Meshcat page and ``results.yaml`` (module
    docstring of :mod:`rmdrake.studies.elastic_arm`); ``q0`` is a target's
    nominal configuration and ``q_comp`` the elastostatic variant's motor
    command for it."""
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
    # Meshcat: nominal target pose, the deflected arm (nominal commands) and the
    # compensated one, the deflection magnified so that it shows on an 8 m arm.
    true_m = with_payload_mass(result.true, heaviest)
    sag = link_angles(true_m, q0, heaviest) - q0
    comp = link_angles(true_m, q_comp, heaviest)
    scale = 20.0
    files.append(
        save_robot_states_html(
            true_m,
            {
                "nominal": (q0, 0.3),
                f"deflected_x{scale:g}": (q0 + scale * sag, 1.0),
                f"compensated_x{scale:g}": (q0 + scale * (comp - q0), 0.7),
            },
            out / "compliance.html",
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
