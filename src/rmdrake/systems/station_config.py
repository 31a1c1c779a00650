"""Typed, YAML-loadable configuration of the true-robot station, and the
builders of the configured controller.

:class:`StationConfig` and its parts are plain dataclasses (every field has a
default), so Drake's YAML functions read and write them::

    from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
    config = yaml_load_typed(schema=StationConfig, data=text)
    text = yaml_dump_typed(config, defaults=StationConfig())  # only what differs

A key that is not a field fails to load (``RuntimeError: The fields ['kpp'] were
unknown to the schema``); a missing key keeps its default. ``controller`` is a
tagged choice: an untagged mapping is an :class:`InverseDynamicsControllerConfig`
(the first alternative), other variants are selected by their class name as YAML
tag, for example ``controller: !PidControllerConfig {bandwidth: 20.0}``.
Per-joint values (``PerJoint``) are one number for all joints or a list of n
(Drake's dumper tags a number, ``torque_noise: !!float '0.05'``, which loads
back unchanged). Values are checked when the station is built
(:func:`rmdrake.systems.station.MakeStation`), naming the field
(``sensors.torque_noise: expected finite numbers``).

A controller variant is local to this module: a dataclass (fields defaulted,
units stated) in the ``ControllerConfig`` union and a builder ``(builder,
config, inputs: ControllerInputs) -> actuation port`` in ``_CONTROLLER_BUILDERS``.
No ``from __future__ import annotations``: Drake's loader needs the field types.

A station config pickles (a study's task sends it to a worker,
:mod:`rmdrake.execution`): Drake's ``SimulatorConfig`` does not by itself, so
this module registers (:mod:`copyreg`) a reducer that sends it by its fields.
"""

import copyreg
import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from pydrake.systems.analysis import GetIntegrationSchemes, SimulatorConfig
from pydrake.systems.controllers import InverseDynamics, PidController
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import Adder
from pydrake.trajectories import Trajectory

from rmdrake.arrays import per_joint
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.model.plant import MakePlant, coupled_rotors_on_diagonal
from rmdrake.model.robot import RobotModel
from rmdrake.systems.controllers import (
    DEFAULT_BANDWIDTH,
    AddSampledPid,
    CalibratedCompensationController,
    NominalController,
    default_gains,
    deflection_model,
    require_rigid,
)
from rmdrake.systems.deflection import AddPayloadMassSource
from rmdrake.systems.friction import AddFrictionFeedforward
from rmdrake.systems.station_sources import motion_start

__all__ = [
    "CONTROL_RATE",
    "DEFAULT_LOG_PERIOD",
    "DEFAULT_TIME_STEP",
    "AddController",
    "CompensationControllerConfig",
    "ControllerConfig",
    "ControllerInputs",
    "InverseDynamicsControllerConfig",
    "PerJoint",
    "PidControllerConfig",
    "SensorConfig",
    "StationConfig",
    "default_simulator_config",
    "discrete_time_step",
]


DEFAULT_LOG_PERIOD = 1.0 / 150.0
"""Default logging period in s: the paper's 150 Hz."""

CONTROL_RATE = 1000.0
"""Hz: the rate of a real arm's joint controller, the least rate of a discrete
station's step (:func:`discrete_time_step`)."""

COUPLED_RATE = 4000.0
"""Hz: the least step rate of a discrete station whose true robot has coupled
motors (``discrete_time_step(log_period, COUPLED_RATE)``). Drake's SAP solver
holds a coupler constraint near-rigidly (its regularisation is fixed inside
Drake), with an error that falls fast with the step: on the shipped
``rv3sb_geared``, the least-squares residual of a noise-free motor-side log
held out, over each joint's effort RMS, was up to 3e-3 (joint 5) at 1 kHz,
2e-6 at 2 kHz, 2e-7 at 4 kHz and 3e-8 at 8 kHz (one 10 s period,
bench/transmissions.py)."""


def discrete_time_step(log_period: float, rate: float = CONTROL_RATE) -> float:
    """The discrete station's step for a log period: the longest step of at
    most 1 / ``rate`` s (``rate`` in Hz) that divides ``log_period`` (s) into
    whole steps, so that every logged sample is a state the plant stepped to,
    with the torque and acceleration of that step (1/1050 s for the default
    150 Hz log: 7 steps a sample)."""
    return log_period / math.ceil(log_period * rate - 1e-9)


DEFAULT_TIME_STEP = discrete_time_step(DEFAULT_LOG_PERIOD)
"""A discrete station's step for the default log, in s: 1/1050 s, about the
1 kHz of a real arm's joint controller and 7 steps of each 150 Hz sample."""


PerJoint = list[float] | float | int
"""One number for every joint, or a list of n numbers (one per joint)."""


def _simulator_config(fields: dict[str, Any]) -> SimulatorConfig:
    """The ``SimulatorConfig`` of its fields (what its pickle holds)."""
    return SimulatorConfig(**fields)


def _reduce_simulator_config(config: SimulatorConfig) -> tuple:
    """Pickles a ``SimulatorConfig`` as :func:`_simulator_config` of its fields."""
    fields = {f.name: getattr(config, f.name) for f in SimulatorConfig.__fields__}
    return _simulator_config, (fields,)


copyreg.pickle(SimulatorConfig, _reduce_simulator_config)


def default_simulator_config() -> SimulatorConfig:
    """The station's integrator: Drake's error-controlled Runge-Kutta 3, target
    accuracy 1e-4 (Drake's weighted relative error), maximum step the default
    log period 1/150 s, start time 0, no real-time pacing."""
    return SimulatorConfig(
        integration_scheme="runge_kutta3",
        max_step_size=DEFAULT_LOG_PERIOD,
        accuracy=1e-4,
        use_error_control=True,
    )


@dataclasses.dataclass(kw_only=True)
class SensorConfig:
    """Joint sensors of the simulated arm (they act on the logged signals only;
    the servo loop sees the true joint state).

    Attributes:
      torque_noise: standard deviation of the Gaussian noise added to each
        joint-torque measurement, N m or N (one value or n); 0 = exact.
      encoder_resolution: rad or m per count (one or n); 0 = no quantisation.
      seed: seed of the torque noise (the same seed gives the same noise).

    Example:

    >>> from rmdrake.systems import SensorConfig, StationConfig
    >>> config = StationConfig(sensors=SensorConfig(torque_noise=0.05, seed=3))
    >>> config.sensors.torque_noise, config.sensors.seed
    (0.05, 3)
    """

    torque_noise: PerJoint = 0.0
    encoder_resolution: PerJoint = 0.0
    seed: int = 0


@dataclasses.dataclass(kw_only=True)
class InverseDynamicsControllerConfig:
    """Drake ``InverseDynamicsController`` on a plant of the controller's model.

    Commanded acceleration ``vdot_d + kp (q_d - q) + kd (v_d - v) + ki *
    integral(q_d - q)``, turned into torque by the model's inverse dynamics
    (rotor inertia, no friction): gains in 1/s^2, 1/s, 1/s^3, size-independent.

    Attributes:
      bandwidth: omega_c in rad/s of the gains not given explicitly: a triple
        closed-loop pole at -omega_c (:func:`default_gains`).
      kp: position gain in 1/s^2 (one value or n); None = from ``bandwidth``.
      kd: velocity gain in 1/s; None = from ``bandwidth``.
      ki: integral gain in 1/s^3; None = from ``bandwidth``.
      friction_feedforward: add the model's friction (its fv, fc, with the
        station's smooth sign) at the desired velocity to the torque.

    Example:

    >>> from rmdrake.systems import InverseDynamicsControllerConfig, StationConfig
    >>> controller = InverseDynamicsControllerConfig(bandwidth=30.0)
    >>> config = StationConfig(controller=controller)
    >>> config.controller.bandwidth, config.controller.friction_feedforward
    (30.0, True)
    """

    bandwidth: float = DEFAULT_BANDWIDTH
    kp: PerJoint | None = None
    kd: PerJoint | None = None
    ki: PerJoint | None = None
    friction_feedforward: bool = True


@dataclasses.dataclass(kw_only=True)
class PidControllerConfig:
    """Industrial joint servo: independent PID per joint on the joint angles,
    plus gravity compensation from a plant of the controller's model.

    Torque ``kp (q_d - q) + kd (v_d - v) + ki * integral(q_d - q) + g(q)``
    with g(q) the model's gravity torque. The gains are torques: from a
    bandwidth w, joint j gets ``(3 w^2, 3 w, w^3) J_j`` with J_j the model's
    mass-matrix diagonal (link plus rotor inertia, kg m^2) where the trajectory
    starts: a triple pole at -w for that inertia; each loop stays stable while
    the actual inertia about its joint is below 9 J_j.

    Attributes:
      bandwidth: w in rad/s of the gains not given explicitly.
      kp: position gain in N m/rad or N/m (one value or n); None = from
        ``bandwidth`` (times the mass matrix diagonal, kg m^2 or kg).
      kd: velocity gain in N m s/rad or N s/m; None = from ``bandwidth``.
      ki: integral gain in N m/(rad s) or N/(m s); None = from ``bandwidth``.
      gravity_compensation: add g(q) at the measured joint angles.
      friction_feedforward: add the model's friction at the desired velocity
        (as in :class:`InverseDynamicsControllerConfig`).

    Example:

    >>> from rmdrake.systems import PidControllerConfig, StationConfig
    >>> config = StationConfig(controller=PidControllerConfig(bandwidth=20.0))
    >>> type(config.controller).__name__, config.controller.gravity_compensation
    ('PidControllerConfig', True)
    """

    bandwidth: float = DEFAULT_BANDWIDTH
    kp: PerJoint | None = None
    kd: PerJoint | None = None
    ki: PerJoint | None = None
    gravity_compensation: bool = True
    friction_feedforward: bool = False


@dataclasses.dataclass(kw_only=True)
class CompensationControllerConfig:
    """A :class:`~rmdrake.systems.controllers.CalibratedCompensationController`:
    computed torque as :class:`InverseDynamicsControllerConfig`, with the
    calibrated kinematics and the identified dynamics that ``MakeStation`` is
    given (``calibrated_model``, ``identified_model``). Each layer can be
    switched off to show what it buys.

    Attributes:
      bandwidth, kp, kd, ki: as :class:`InverseDynamicsControllerConfig`.
      kinematic_correction: map the desired (nominal) joint program online to
        the calibrated model's joints (needs ``calibrated_model``).
      correction_period: period of the exact online correction, s.
      correction_ahead: with a program given as a pydrake Trajectory (a
        station's ``JointTrajectorySource``), solve the online correction's
        updates ahead
        (:class:`~rmdrake.systems.correction.PresolvedTargetCorrection`: the
        same motion to the IK tolerance, no Python in the simulation's steps,
        about twice as fast a corrected run); False: solve them in the
        simulation, as for a program streamed live.
      identified_dynamics: inverse dynamics on the identified model (else the
        controller's nominal model).
      identified_friction: the identified (if given) fv, fc in the friction
        feedforward.
      friction_feedforward: add a friction feedforward at all.
      deflection_compensation: pre-deflect the command by the compliance of an
        elastic calibrated (else identified, nominal) model; False with an
        elastic model is refused (a rigid-joint controller).
      payload_mass: kg at the tool for the pre-deflection; None = that model's
        payload mass (0 without one). A Context parameter of the system
        ``payload_mass``, changeable mid-task (:func:`AddPayloadMassSource`).
      payload_mass_input: leave the controller's ``payload_mass`` input
        unconnected (no ``payload_mass`` source; ``payload_mass`` above
        unused) for ``MakeStation``'s ``add_systems`` to feed, e.g. from a
        :class:`~rmdrake.systems.payload_estimator.PayloadEstimator` on the
        measured signals (the controller is the system ``controller``).

    Example:

    >>> from rmdrake.systems import CompensationControllerConfig, StationConfig
    >>> layers = CompensationControllerConfig(deflection_compensation=False)
    >>> config = StationConfig(controller=layers)
    >>> layers.kinematic_correction, layers.deflection_compensation
    (True, False)
    """

    bandwidth: float = DEFAULT_BANDWIDTH
    kp: PerJoint | None = None
    kd: PerJoint | None = None
    ki: PerJoint | None = None
    kinematic_correction: bool = True
    deflection_compensation: bool = True
    payload_mass: float | None = None
    payload_mass_input: bool = False
    correction_period: float = 0.01
    correction_ahead: bool = True
    identified_dynamics: bool = True
    identified_friction: bool = True
    friction_feedforward: bool = True


ControllerConfig = (
    InverseDynamicsControllerConfig | PidControllerConfig | CompensationControllerConfig
)
"""The controller variants; the first is the default (YAML without a tag)."""


@dataclasses.dataclass(kw_only=True)
class StationConfig:
    """Everything that shapes the station Diagram and its simulation, except the
    robot models and the trajectory (which
    :func:`rmdrake.systems.station.MakeStation` takes).

    Attributes:
      simulator: Drake's integrator settings of
        :func:`rmdrake.systems.station.RunStation` (default
        :func:`default_simulator_config`; its ``max_step_size`` does not follow
        ``log_period``; ``start_time`` is the default Context's time).
      hold_integration_scheme: Drake's integration scheme for the holds of a
        run read at rest (:func:`~rmdrake.systems.measurement_runs.
        SimulateReadings` with a ``settle_time``: plate readings, targets
        driven to), with ``simulator``'s step and accuracy; the moves keep
        ``simulator.integration_scheme``; "" for that scheme throughout.
        Default ``"radau3"``: at rest the smooth Coulomb friction acts as a
        stiff damper (time constant J v_eps / fc), which an explicit
        integrator resolves in tiny steps and the L-stable implicit Radau3
        steps over: a light arm's drives to targets and plate readings run
        faster with the same readings (to 2e-8 rad and 1e-10 m); a heavy arm
        gains nothing, the largest step bounding its steps
        (``bench/simulate.py``).
      move_accuracy: Drake's target accuracy for the moves of a run read at
        rest (as above), in (0, 1); 0 for ``simulator.accuracy``. The holds
        keep ``simulator.accuracy`` and a reading is taken at a hold's end, so
        the hold absorbs a move's integration error: on drives to targets with
        2 s holds a looser move accuracy reads the same encoder angles (to
        4e-8 rad) in less time on a light arm (``bench/simulate.py``).
      time_step: 0 (the default) for a continuous plant integrated by
        ``simulator``: the logged torques equal the regressor's to round-off
        (the oracle); or > 0 s for a discrete station that steps like a real
        arm's controller (:data:`DEFAULT_TIME_STEP`, about 1 kHz; the log
        period must be a whole number of steps, :func:`discrete_time_step`):
        nothing to integrate and no Python system in the plant's friction or
        the controller's feedback (the Coulomb friction is applied implicitly
        by Drake's SAP solver, as clamp(-v fc / v_eps, -fc, fc), a linear
        rather than tanh transition), so a light arm holding still is
        simulated much faster (a heavy arm's friction is soft and its
        continuous plant the faster: ``bench/simulate.py``); a
        logged sample then holds the step's qdd = (v_k - v_(k-1)) /
        time_step and torque.
      log_period: sampling period of the loggers and of the torque noise, s.
      v_eps: smooth-sign width of the true robot's Coulomb friction,
        ``tanh(v / v_eps)``, rad/s or m/s (also used by friction feedforward).
      exact_sign: use sign(v) in the true robot's friction (chatters under an
        error-controlled integrator; tests only; continuous plant only).
      sensors: the joint sensors.
      controller: the joint controller, one of ``ControllerConfig``.

    Example:

    >>> from rmdrake.systems import StationConfig
    >>> config = StationConfig()
    >>> type(config.controller).__name__, config.time_step, round(1 / config.log_period)
    ('InverseDynamicsControllerConfig', 0.0, 150)
    """

    simulator: SimulatorConfig = dataclasses.field(
        default_factory=default_simulator_config
    )
    hold_integration_scheme: str = "radau3"
    move_accuracy: float = 1e-3
    time_step: float = 0.0
    log_period: float = DEFAULT_LOG_PERIOD
    v_eps: float = DEFAULT_V_EPS
    exact_sign: bool = False
    sensors: SensorConfig = dataclasses.field(default_factory=SensorConfig)
    controller: ControllerConfig = dataclasses.field(
        default_factory=InverseDynamicsControllerConfig
    )


def check_times(config: StationConfig) -> None:
    """ValueError unless log_period > 0, time_step >= 0, v_eps > 0 (finite),
    a discrete step divides the log period into whole steps and comes
    without ``exact_sign``, ``hold_integration_scheme`` is "" or one of
    Drake's schemes, and ``move_accuracy`` is 0 or in (0, 1)."""
    schemes = GetIntegrationSchemes()
    if config.hold_integration_scheme not in ("", *schemes):
        raise ValueError(
            f"hold_integration_scheme: expected '' or one of {', '.join(schemes)}, "
            f"found '{config.hold_integration_scheme}'"
        )
    accuracy = float(config.move_accuracy)
    if not (math.isfinite(accuracy) and 0 <= accuracy < 1):
        raise ValueError(
            f"move_accuracy: expected 0 (the simulator's accuracy) or a value in "
            f"(0, 1), found {config.move_accuracy}"
        )
    for name, value, zero_ok in (
        ("log_period", config.log_period, False),
        ("time_step", config.time_step, True),
        ("v_eps", config.v_eps, False),
    ):
        unit = "rad/s or m/s" if name == "v_eps" else "s"
        value = float(value)
        if not math.isfinite(value) or value < 0 or (value == 0 and not zero_ok):
            sign = ">= 0" if zero_ok else "> 0"
            raise ValueError(
                f"{name}: expected a finite value {sign} {unit}, found {value}"
            )
    if config.time_step > 0 and config.exact_sign:
        raise ValueError(
            "exact_sign: expected the continuous plant (time_step 0); a discrete "
            "station's Coulomb friction is the plant's own, linear over v_eps"
        )
    if config.time_step > 0:
        steps = config.log_period / config.time_step
        if abs(steps - round(steps)) > 1e-6 * steps:
            raise ValueError(
                f"time_step: expected a whole number of steps in the log period "
                f"{config.log_period:g} s, found {steps:.4g} steps of "
                f"{config.time_step:g} s (discrete_time_step(log_period) = "
                f"{discrete_time_step(config.log_period):g} s fits)"
            )


# ---- controllers --------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ControllerInputs:
    """What a controller builder may use (see :func:`AddController`).

    Attributes:
      model: the controller's robot model (what the controller knows).
      trajectory: the trajectory given to ``MakeStation`` (a FourierTrajectory
        or a pydrake Trajectory; its values at build time), the one
        ``desired_state`` streams from t = 0.
      joint_state, desired_state, desired_acceleration: output ports of the
        measured [q; v] (2n; rad, m), the desired [q_d; v_d] and vdot_d (n).
      v_eps: the station's smooth-sign width in rad/s or m/s (friction ff).
      calibrated, identified: the robots the station was given, if any.
      time_step: the station's discrete step in s: a controller's integral
        action is then sampled at that step (:func:`AddSampledPid`);
        0 (continuous station): integrated with the plant.
    """

    model: RobotModel
    trajectory: FourierTrajectory | Trajectory
    joint_state: OutputPort
    desired_state: OutputPort
    desired_acceleration: OutputPort
    v_eps: float
    calibrated: RobotModel | None = None
    identified: RobotModel | None = None
    time_step: float = 0.0


def _gains(config: ControllerConfig, n: int, units: tuple, scale: np.ndarray) -> list:
    """(kp, kd, ki): the configured ones, else scale * default_gains(bandwidth)."""
    if not math.isfinite(w := float(config.bandwidth)) or w <= 0:
        raise ValueError(f"controller.bandwidth: expected a positive rad/s, found {w}")
    defaults = default_gains(n, w)
    return [
        per_joint(d * scale if g is None else g, n, f"controller.{name}", unit)
        for g, d, name, unit in zip(
            (config.kp, config.kd, config.ki), defaults, ("kp", "kd", "ki"), units,
            strict=True,
        )
    ]  # fmt: skip


def _sum(builder: DiagramBuilder, ports: list[OutputPort], name: str) -> OutputPort:
    if len(ports) == 1:
        return ports[0]
    total = builder.AddNamedSystem(name, Adder(len(ports), ports[0].size()))
    for i, port in enumerate(ports):
        builder.Connect(port, total.get_input_port(i))
    return total.get_output_port()


def _computed_torque(
    builder: DiagramBuilder, controller_class: type, config, inputs, **models
) -> OutputPort:
    """Adds a computed-torque ``controller_class`` built ``from_config`` on
    ``inputs.model`` (and ``models``) with the configured gains, wired to the
    joint state and desired motion."""
    n = inputs.model.n_joints
    kp, kd, ki = _gains(config, n, ("1/s^2", "1/s", "1/s^3"), np.ones(n))
    controller = builder.AddNamedSystem(
        "controller",
        controller_class.from_config(
            dataclasses.replace(config, kp=kp, kd=kd, ki=ki),
            nominal=inputs.model,
            v_eps=inputs.v_eps,
            time_step=inputs.time_step,
            **models,
        ),
    )
    controller.ConnectInputs(
        builder,
        desired_state=inputs.desired_state,
        desired_acceleration=inputs.desired_acceleration,
        estimated_state=inputs.joint_state,
    )
    return controller.GetOutputPort("actuation")


def _add_inverse_dynamics(
    builder: DiagramBuilder,
    config: InverseDynamicsControllerConfig,
    inputs: ControllerInputs,
) -> OutputPort:
    return _computed_torque(builder, NominalController, config, inputs)


def _add_pid(
    builder: DiagramBuilder, config: PidControllerConfig, inputs: ControllerInputs
) -> OutputPort:
    n = inputs.model.n_joints
    plant, _ = MakePlant(coupled_rotors_on_diagonal(inputs.model), visual=False)
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, motion_start(inputs.trajectory))
    inertia = np.diag(plant.CalcMassMatrix(plant_context)).copy()
    units = ("N m/rad or N/m", "N m s/rad or N s/m", "N m/(rad s) or N/(m s)")
    kp, kd, ki = _gains(config, n, units, inertia)
    if inputs.time_step > 0:  # sampled every step, as the real servo
        commanded, measured, effort = AddSampledPid(
            builder, kp=kp, kd=kd, ki=ki, time_step=inputs.time_step,
            name="controller",
        )  # fmt: skip
    else:
        pid = builder.AddNamedSystem("controller", PidController(kp, ki, kd))
        commanded = pid.get_input_port_desired_state()
        measured = pid.get_input_port_estimated_state()
        effort = pid.get_output_port_control()
    builder.Connect(inputs.joint_state, measured)
    builder.Connect(inputs.desired_state, commanded)
    torques = [effort]
    if config.gravity_compensation:
        gravity = builder.AddNamedSystem(
            "gravity_compensation",
            InverseDynamics(
                plant, InverseDynamics.InverseDynamicsMode.kGravityCompensation
            ),
        )
        gravity._rmdrake_plant = plant  # keep alive (non-owning pointer in C++)
        builder.Connect(inputs.joint_state, gravity.get_input_port_estimated_state())
        torques.append(gravity.get_output_port_generalized_force())
    if config.friction_feedforward:
        ff_state, ff_effort = AddFrictionFeedforward(
            builder, inputs.model, v_eps=inputs.v_eps
        )
        builder.Connect(inputs.desired_state, ff_state)
        torques.append(ff_effort)
    return _sum(builder, torques, "actuation_sum")


def _add_compensation(
    builder: DiagramBuilder,
    config: CompensationControllerConfig,
    inputs: ControllerInputs,
) -> OutputPort:
    for name, needed, model in (
        ("calibrated_model", config.kinematic_correction, inputs.calibrated),
        ("identified_model", config.identified_dynamics, inputs.identified),
    ):
        if needed and model is None:
            raise ValueError(
                f"controller: CompensationControllerConfig needs MakeStation's "
                f"{name} for the layers it switches on"
            )
    identified = inputs.identified or inputs.model
    actuation = _computed_torque(
        builder,
        CalibratedCompensationController,
        config,
        inputs,
        identified=identified,
        calibrated=inputs.calibrated,
        program=inputs.trajectory,
    )
    controller = actuation.get_system()
    if controller.HasInputPort("payload_mass") and not config.payload_mass_input:
        model = deflection_model(inputs.model, identified, inputs.calibrated)
        port, field = controller.GetInputPort("payload_mass"), "controller.payload_mass"
        AddPayloadMassSource(
            builder, port, model=model, mass=config.payload_mass, field=field
        )
    return actuation


_CONTROLLER_BUILDERS: dict[type, Callable[..., OutputPort]] = {
    InverseDynamicsControllerConfig: _add_inverse_dynamics,
    PidControllerConfig: _add_pid,
    CompensationControllerConfig: _add_compensation,
}
"""One builder per variant of ``ControllerConfig``: add a variant here."""


def AddController(
    builder: DiagramBuilder,
    config: ControllerConfig,
    inputs: ControllerInputs,
) -> OutputPort:
    """Adds the controller chosen by ``config`` to ``builder``; returns its
    actuation output port (n joint efforts in N m or N, in joint order).

    Variants (main system named ``controller``):

    * :class:`InverseDynamicsControllerConfig`: a
      :class:`~rmdrake.systems.controllers.NominalController` on the
      controller's model (estimated state = joint state, desired state and
      acceleration from the trajectory).
    * :class:`PidControllerConfig`: Drake ``PidController`` on the joint state,
      plus ``gravity_compensation`` (Drake ``InverseDynamics``) and the optional
      friction feedforward, summed by ``actuation_sum``.
    * :class:`CompensationControllerConfig`: a
      :class:`~rmdrake.systems.controllers.CalibratedCompensationController`
      on the models of ``inputs``, and with its deflection layer a
      ``ConstantVectorSource`` ``payload_mass`` (kg) feeding it (none with
      ``payload_mass_input``: the caller connects that input).

    Raises:
      TypeError: a config that is not one of the variants.
      ValueError: gains or bandwidth not finite, negative, or of the wrong
        length (naming the field, ``controller.kp`` ...); an elastic
        controller model under a variant that assumes rigid joints.
    """
    build = _CONTROLLER_BUILDERS.get(type(config))
    if build is None:
        names = ", ".join(cls.__name__ for cls in _CONTROLLER_BUILDERS)
        raise TypeError(
            f"controller: expected one of {names}, found {type(config).__name__}"
        )
    if not isinstance(config, CompensationControllerConfig):
        require_rigid(
            inputs.model,
            f"controller: {type(config).__name__} model",
            "use CompensationControllerConfig or give MakeStation a rigid "
            "nominal_model",
        )
    return build(builder, config, inputs)
