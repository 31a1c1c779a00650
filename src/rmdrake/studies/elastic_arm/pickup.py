"""The compliance study's step 6: a module picked up mid-task.

The elastostatic controller holds a link-side target for ``path_hold`` s
after a 1 s move, its ``payload_mass`` at 0; then the module's weight passes
onto the tool over :data:`TRANSFER` s (the true plant's payload body inertia,
a Context parameter, in 25 steps); then another ``path_hold`` s. Where the
controller's payload mass comes from is the run's :class:`PickupSource`
(:data:`PICKUP_SOURCES`): ``told`` (its ``payload_mass`` source follows the
transfer step by step), ``not told`` (left at 0) and ``estimating`` (a
:class:`~rmdrake.systems.payload_estimator.PayloadEstimator` on the
station's measured q, qd, qdd and tau: mass and first moments every
:data:`PICKUP_ESTIMATOR_PERIOD` s, forgetting factor
:data:`PICKUP_FORGETTING`, with the elastostatic calibration's arm).

The payload mass sets the pre-deflection and the payload's gravity
feedforward (``payload_effort``); the controller's rigid-body model holds the
module's inertia throughout: a computed-torque loop with integral action
whose model inertia is under 1/9 of the truth's is unstable (its closed-loop
polynomial fails Routh's test), and the 4.5 t module 0.8 m ahead of the tool
multiplies the wrist joints' inertia about twentyfold.

Example, the three runs in this process and their figures::

    runs = {
        s.name: pickup_run(config, models, q_link, mass, bandwidth, s)
        for s in PICKUP_SOURCES
    }
    result = pickup_figures(config, runs, target=p_BE)
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from rmdrake.dynamics.compliance import with_payload_mass
from rmdrake.model.plant import payload_inertia
from rmdrake.studies.closed_loop import start_at_command
from rmdrake.studies.elastic_arm.results import PickupResult, PickupRun
from rmdrake.studies.elastic_arm.station_runs import (
    add_tool_tracker,
    settling,
    station_config,
)
from rmdrake.studies.elastic_arm.variants import ElasticModels
from rmdrake.studies.scenarios import ComplianceStudyConfig
from rmdrake.systems.payload_estimator import PayloadEstimator
from rmdrake.systems.station import MakeStation, simulation_progress
from rmdrake.systems.station_config import CompensationControllerConfig
from rmdrake.systems.station_sources import setpoint_trajectory

__all__ = [
    "ESTIMATING",
    "NOT_TOLD",
    "PICKUP_ESTIMATOR_PERIOD",
    "PICKUP_FORGETTING",
    "PICKUP_SOURCES",
    "TOLD",
    "TRANSFER",
    "PickupSource",
    "pickup_figures",
    "pickup_run",
]

TRANSFER = 5.0
"""s over which a picked-up module's weight passes onto the arm (a crane or a
support lowering it), in 25 steps."""
PICKUP_ESTIMATOR_PERIOD = 0.01
"""s between the pick-up's payload estimator updates (100 Hz)."""
PICKUP_FORGETTING = 0.99
"""Forgetting factor per update of the pick-up's payload estimator: a memory
of PICKUP_ESTIMATOR_PERIOD / (1 - PICKUP_FORGETTING) = 1 s."""


@dataclasses.dataclass(frozen=True)
class PickupSource:
    """Where a pick-up run's controller takes its payload mass from.

    Attributes:
      name: the run's key (``told``, ``not told``, ``estimating``).
      told: the controller's ``payload_mass`` source follows the transfer.
      estimating: a payload estimator feeds the controller's ``payload_mass``
        input (no source).
    """

    name: str
    told: bool
    estimating: bool


TOLD = PickupSource("told", told=True, estimating=False)
"""The controller is told the payload mass as it passes onto the tool."""
NOT_TOLD = PickupSource("not told", told=False, estimating=False)
"""The controller's payload mass stays at 0."""
ESTIMATING = PickupSource("estimating", told=False, estimating=True)
"""The controller's payload mass comes from the online payload estimator."""
PICKUP_SOURCES = (TOLD, NOT_TOLD, ESTIMATING)
"""The pick-up's runs."""


def pickup_run(
    config: ComplianceStudyConfig,
    models: ElasticModels,
    q_link: np.ndarray,
    mass: float,
    bandwidth: float,
    source: PickupSource,
) -> PickupRun:
    """One pick-up run (module docstring), as a task: the elastostatic
    controller at ``bandwidth`` rad/s holds the link-side target ``q_link``
    (n,), rad, while ``mass`` kg pass onto the tool, its payload mass from
    ``source``; the tool tracker's log and the estimator's final mass."""
    hold = float(config.path_hold)
    true_m = with_payload_mass(models.true, mass)
    # The rigid-body model holds the module's inertia; the payload_mass port
    # sets the gravity feedforward and the pre-deflection (module docstring).
    loaded = with_payload_mass(models.nominal, mass)
    controller = CompensationControllerConfig(
        bandwidth=bandwidth,
        kinematic_correction=False,
        payload_mass=0.0,
        payload_mass_input=source.estimating,
    )
    setup = station_config(config, bandwidth, controller)
    setup.simulator.start_time = 0.0
    end = 1.0 + 2 * hold + TRANSFER
    add_systems = add_tool_tracker
    if source.estimating:
        arm = dataclasses.replace(models.elastic, payload=None)
        noise = np.asarray(setup.sensors.torque_noise, dtype=np.float64)
        std = noise if np.all(noise > 0) else None

        def add_systems(builder, plant, signals):
            log = add_tool_tracker(builder, plant, signals)
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
        calibrated_model=with_payload_mass(models.elastic, mass),
        identified_model=loaded,
        add_systems=add_systems,
        joint_logs=False,
    )
    context = station.CreateDefaultContext()
    plant = station.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    body = plant.GetBodyByName("payload")
    if not source.estimating:
        mass_source = station.diagram.GetSubsystemByName("payload_mass")
        source_value = mass_source.get_mutable_source_value(
            mass_source.GetMyMutableContextFromRoot(context)
        )
    body.SetSpatialInertiaInBodyFrame(plant_context, payload_inertia(true_m.payload, 0))
    start_at_command(station, context, payload_mass=0.0)
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(setup.simulator, simulator)
    with simulation_progress(simulator, end):
        simulator.Initialize()
        simulator.AdvanceTo(1.0 + hold)
        for k in range(1, 26):
            m = mass * k / 25
            body.SetSpatialInertiaInBodyFrame(
                plant_context, payload_inertia(true_m.payload, m)
            )
            if source.told:
                source_value.SetFromVector([m])
            simulator.AdvanceTo(1.0 + hold + TRANSFER * k / 25)
        simulator.AdvanceTo(end)
    log = station.extras.FindLog(context)
    estimated = None
    if source.estimating:
        estimator = station.diagram.GetSubsystemByName("payload_estimator")
        port = estimator.GetOutputPort("payload_mass")
        estimated = float(port.Eval(estimator.GetMyContextFromRoot(context))[0])
    return PickupRun(log.sample_times(), log.data().T, estimated)


def pickup_figures(
    config: ComplianceStudyConfig, runs: dict[str, PickupRun], target: np.ndarray
) -> PickupResult:
    """The :class:`~rmdrake.studies.elastic_arm.results.PickupResult` of the
    pick-up ``runs`` by source name (every one of :data:`PICKUP_SOURCES`)
    against the tool position aimed at, ``target`` (3,), m, in the base frame;
    times count from the end of the transfer, s."""
    t0 = 1.0 + float(config.path_hold)
    ends, figures, estimated = {}, {}, float("nan")
    for source in PICKUP_SOURCES:
        run = runs[source.name]
        t, p, m = run.t, run.p_WM, run.estimated_mass
        ends[source.name] = (t, p, np.linalg.norm(p - target, axis=1))
        after = t > t0
        _, settle = settling(t, p, after, t0 + TRANSFER, config.settle_band)
        figures[source.name] = (float(ends[source.name][2][after].max()), settle)
        if m is not None:
            estimated = m
    t, p, error = ends[TOLD.name]
    after = t > t0
    return PickupResult(
        before=float(error[~after][-1]),
        told=float(error[-1]),
        untold=float(ends[NOT_TOLD.name][2][-1]),
        peak=figures[TOLD.name][0],
        settling_time=figures[TOLD.name][1],
        estimating=float(ends[ESTIMATING.name][2][-1]),
        estimating_peak=figures[ESTIMATING.name][0],
        estimating_settling_time=figures[ESTIMATING.name][1],
        estimated_mass=estimated,
    )
