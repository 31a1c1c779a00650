"""The true robot simulated in Drake: plant, friction, joint controller, loggers.

This replaces the paper's SimMechanics model (§4): the MultibodyPlant of the TRUE
robot (perturbed parameters) follows a Fourier excitation trajectory (or any
joint-space pydrake Trajectory, such as point-to-point setpoints) under a
joint controller built on the controller's (NOMINAL) model, and loggers record
what the joint sensors of a real arm would: encoder angles (or slide
positions), velocities, accelerations and joint torques (forces on prismatic
joints: every signal is per joint, in rad or m, N m or N). Everything but the
models and the trajectory is set by a
:class:`~rmdrake.systems.station_config.StationConfig`.

Diagram of :func:`MakeStation`, as wiring (system names as in the Diagram,
``system.port``)::

    source ─state, vdot─► [controller: see AddController] ─► plant.actuation
                                     ▲ joint state
    plant.state ─► [joint_state] ────┴─► demux ─┬─ q ─► encoder ─► log_q
                                                └─ v ────────────► log_qd
    plant.state ─► friction (true fv, fc) ─► plant.applied_generalized_force
    plant.generalized_acceleration ─► [joint_accelerations] ─────► log_qdd
    plant.net_actuation ─► [torque_sensor: + noise] ─────────────► log_tau

``joint_state`` is a ``MatrixGain`` S @ x with S =
``plant.MakeStateSelectorMatrix`` of the robot's joints ``joint1..n``
(:func:`joint_state_selector`): it picks each joint's angle and rate from the
plant state by the joint's position and velocity index, whatever else the plant
state holds; ``joint_accelerations`` does the same for the accelerations, and
the friction reads each joint's velocity by index too. Bracketed systems are
added only when needed: the two selectors not when S is the identity (a plant
of only the n joints, as :func:`rmdrake.model.plant.MakePlant` builds), the torque
noise not when its std is zero. ``source`` is the desired motion
(:mod:`~rmdrake.systems.station_sources`): the Fourier ``excitation`` or the
``desired_motion`` of a Trajectory. The diagram exports ``q``, ``qd``, ``qdd``,
``tau`` (the measured signals, as logged), ``q_link`` (the true link-side joint
positions) and ``state`` (the true plant state).

**Elastic joints** (a true robot with ``compliance``): the plant holds a
motor-side and a link-side joint per elastic joint (:mod:`rmdrake.model.plant`), so its
state is no longer [q; v] of size 2n; the encoders, friction, torque sensors and
the controller read the motor side, ``q_link`` (a MatrixGain ``link_positions``,
:mod:`~rmdrake.systems.elastic_joints`; logged as ``log_q_link``) the link side,
which on a rigid robot is the true q. A run starts with the link side at rest
(:meth:`Station.SetInitialState`). The controller's model defaults to the true
robot made rigid, and its bandwidth must stay below the arm's lowest structural
mode where the motion starts (``Station.structural_mode``, rad/s): a larger
``controller.bandwidth`` is refused (rule:
:func:`~rmdrake.systems.elastic_joints.check_controller_bandwidth`).

Choices and their reasons:

* **Continuous plant** (``time_step = 0``, the default) integrated with Drake's
  error-controlled Runge-Kutta 3 (``StationConfig.simulator``). With a
  continuous plant the logged acceleration is the plant's
  ``generalized_acceleration`` output, computed from the same state and the
  same applied torque as the logged q, qd and tau, so at every logged sample
  ``tau = M(q) qdd + c(q, qd) - g(q) + fv qd + fc s(qd)`` holds to round-off,
  independently of the integrator's accuracy (which only decides how closely
  the simulated motion follows the exact solution). A discrete (SAP) plant is
  accepted (``time_step > 0``) but its logged acceleration is a finite
  difference over one step, so that identity then holds only to O(time_step).
* **Friction**: on the continuous plant all of it in
  :class:`~rmdrake.systems.friction.JointFriction` (the plant's joint damping
  is zero), smooth sign tanh(v / ``v_eps``), evaluated by Drake's
  SymbolicVectorSystem (no Python in a step).
* **Discrete station** (``time_step > 0``, :data:`DEFAULT_TIME_STEP` = 1/1050
  s, 7 steps of each 150 Hz sample): the station steps as a real arm's
  controller does, with nothing to integrate (the one continuous state is
  the friction feedforward law's constant) and no Python system in the
  plant's friction or in the controller's feedback, so a step costs Drake's
  SAP solve and the one Python system (the encoders) once. The
  Coulomb friction is a PD-controlled actuator per joint (kp 0, kd fc /
  v_eps, effort limit fc) that SAP applies implicitly: clamp(-kd v, -fc,
  fc), the tanh of the continuous plant replaced by a linear transition of
  the same slope, and a joint at rest is held without
  the tiny steps an explicit integrator needs there (the viscous term, the
  asymmetry and the offset are an AffineSystem of the state:
  :func:`~rmdrake.systems.friction.AddDiscretePlantFriction`). The
  controller's integral is sampled at the step
  (:func:`~rmdrake.systems.controllers.AddSampledPid`). A logged sample k
  holds the state after step k and that step's torque and qdd = (v_k -
  v_(k-1)) / time_step (the plant's sampled outputs), so the log starts one
  log period after t0; the rigid-body identity then holds at the step's
  start, (q - h qd, qd - h qdd), wherever the Coulomb term is saturated
  (``tests/systems/test_discrete_station.py``), and the regressor at the
  logged (q, qd) differs from the logged torque by O(time_step) and, over
  |qd| < a few v_eps, by up to 0.24 fc (tanh against the linear clamp).
* **Controller** (default): Drake ``InverseDynamicsController`` on a plant of
  the nominal model with a triple closed-loop pole at -40 rad/s, about 13x the
  0.5 Hz top harmonic of the paper's excitation, plus the nominal friction at
  the desired velocity. On the RV-3SB with +-15 % inertial and +-20 % friction
  errors in the nominal model this tracks within 0.2 deg; 15 rad/s gave 1.2 deg
  and was not faster to integrate. The variants (an industrial PID servo with
  gravity compensation, ...) and how to add one:
  :func:`~rmdrake.systems.station_config.AddController`.
* **Logged torque** = the plant's ``net_actuation`` output = the actuator torque
  a joint-torque sensor reads (gear ratio 1, so it is the joint torque). It is
  what the regressor predicts: ``Y(q, qd, qdd) @ chi_true`` including rotor
  inertia and friction. The plant clamps the actuation to the model's effort
  limits (continuous mode too), and ``net_actuation`` reports the clamped
  torque, so the identity holds under saturation as well; a saturated joint
  shows as a logged torque at +-effort and a larger tracking error.
* **Sensor effects** apply to the logged measurements only (the servo loop sees
  the true state): encoder quantisation of q (resolution in rad or m), Gaussian
  torque noise (std in N m or N, sampled at the log period, seeded through
  ``SetRandomContext`` with ``sensors.seed``). qd and qdd are logged exact;
  drop them from the log to make identification estimate them from q.

Speed (``bench/simulate.py`` times each station against a Drake-only twin): no
Python system is evaluated in a step (friction, friction feedforward and the
Fourier excitation are Drake's SymbolicVectorSystem and Sine; the encoders run
at the log rate). The cost of the continuous station is the Coulomb smoothing on
light joints: while |v| < a few v_eps the friction acts as a damper fc / v_eps
on the joint inertia J, a time constant of J v_eps / fc (about 1e-5 s on the
RV-3SB wrist), which an explicit integrator must resolve, so a light arm
holding still costs it more than moving; the friction feedforward keeps these
passages short. A wider ``v_eps`` is cheaper but biases identification with an
exact-sign regressor on more samples. The discrete station's clamp law,
clip(v / v_eps, -1, 1), on the continuous plant is slower, not faster (the
error-controlled RK3 rejects steps at its kinks). A heavy arm's friction is
soft for its inertias, and its continuous station the faster. Implicit
integrators are slower on the moves (finite-difference Jacobians), and implicit
Euler, first order, moves the closed-loop tracking figures; but on a hold at
rest, where the friction is stiff, Radau3 steps over what RK3 resolves: runs
read at rest integrate their holds with it
(``StationConfig.hold_integration_scheme``).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
from collections.abc import Callable, Iterator

import numpy as np
from pydrake.common import RandomGenerator
from pydrake.geometry import Meshcat, MeshcatVisualizer, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import (
    Context,
    Diagram,
    DiagramBuilder,
    EventStatus,
    InputPort,
    OutputPort,
)
from pydrake.systems.primitives import Demultiplexer, LogVectorOutput, VectorLogSink

from rmdrake.arrays import per_joint
from rmdrake.dynamics.compliance import with_payload_mass
from rmdrake.dynamics.joint_log import JointLog
from rmdrake.model.dynamic_parameters import require_physical, standard_parameters
from rmdrake.model.plant import MakePlant, joint_name, set_coupled_motor_state
from rmdrake.model.robot import DYNAMIC_KEYS, RobotModel, require_dynamics
from rmdrake.progress import simulated_time_progress
from rmdrake.systems.elastic_joints import (
    check_controller_bandwidth,
    link_position_selector,
    set_link_rest,
)
from rmdrake.systems.excitation import FourierExcitationSource
from rmdrake.systems.friction import AddDiscretePlantFriction, JointFriction
from rmdrake.systems.joint_sensors import AddTorqueSensorNoise, EncoderQuantizer
from rmdrake.systems.joint_state import joint_state_selector
from rmdrake.systems.joint_state import map_port as _map_port
from rmdrake.systems.station_config import (
    DEFAULT_LOG_PERIOD,
    DEFAULT_TIME_STEP,
    AddController,
    CompensationControllerConfig,
    ControllerInputs,
    InverseDynamicsControllerConfig,
    PidControllerConfig,
    SensorConfig,
    StationConfig,
    check_times,
)
from rmdrake.systems.station_sources import (
    AddDesiredMotion,
    DesiredMotion,
    JointTrajectorySource,
    check_motion,
    motion_duration,
    motion_start,
)

__all__ = [
    "DEFAULT_LOG_PERIOD",
    "DEFAULT_TIME_STEP",
    "AddController",
    "CompensationControllerConfig",
    "ControllerInputs",
    "InverseDynamicsControllerConfig",
    "MakeStation",
    "PidControllerConfig",
    "RunStation",
    "SensorConfig",
    "Station",
    "StationConfig",
    "joint_state_selector",
    "simulation_progress",
]

_FV, _FC = DYNAMIC_KEYS.index("fv"), DYNAMIC_KEYS.index("fc")

AddSystems = Callable[[DiagramBuilder, MultibodyPlant, dict[str, OutputPort]], object]
"""``add_systems(builder, plant, signals)`` of :func:`MakeStation`."""


# ---- the station --------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Station:
    """A built station: the Diagram and handles to its named subsystems.

    Everything that changes during or between runs (plant state, controller
    integral, trajectory coefficients, friction and sensor parameters, random
    state) lives in the Context; create one with :meth:`CreateDefaultContext`.

    Attributes:
      diagram: the Diagram (output ports ``q``, ``qd``, ``qdd``, ``tau``: the
        measured signals, and ``state``: the true plant state).
      plant: the true robot's MultibodyPlant (continuous when time_step = 0).
      source: the desired motion: a FourierExcitationSource, or a
        JointTrajectorySource for a pydrake Trajectory (both with output
        ports ``state`` and ``vdot``).
      friction: the true robot's joint friction (None on a discrete plant,
        whose friction is Drake's own systems: see the module docstring).
      encoder: the joint encoders.
      joint_selector: the (2n, nq + nv) matrix S of
        :func:`joint_state_selector` for joint1..n: joint state = S @ plant
        state.
      joint_state: output port of the joint state [q; v] (2n; rad or m,
        rad/s or m/s):
        the MatrixGain ``joint_state`` (S @ plant state), or the plant's state
        port itself when S is the identity (a plant of only the n joints).
      loggers: ``{"q", "qd", "qdd", "tau"}`` -> VectorLogSink, and ``q_link``
        for an elastic robot; empty when built with ``joint_logs=False``.
      n_joints: n.
      extras: what ``MakeStation``'s ``add_systems`` returned (else None).
      true_model: the simulated robot given to ``MakeStation``.
      structural_mode: lowest structural mode (rad/s) of an elastic true robot
        where the motion starts, at its payload; None when rigid.
      config: a copy of the configuration the station was built with. Only
        ``config.simulator`` and ``config.hold_integration_scheme`` are read
        after the build (by :func:`RunStation` and
        :func:`~rmdrake.systems.measurement_runs.SimulateReadings`), so
        changing them changes the next run's integrator; the rest describes
        the built Diagram and must not be changed.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.systems import MakeStation, StationConfig
    >>> robot = load_robot("rv3sb")
    >>> trajectory = random_fourier_trajectory(robot, seed=0)
    >>> station = MakeStation(StationConfig(), true_model=robot, trajectory=trajectory)
    >>> context = station.CreateDefaultContext()
    >>> station.plant.num_positions(), round(1 / station.log_period)
    (6, 150)
    """

    diagram: Diagram
    plant: MultibodyPlant
    source: FourierExcitationSource | JointTrajectorySource
    friction: JointFriction | None
    encoder: EncoderQuantizer
    joint_selector: np.ndarray
    joint_state: OutputPort
    loggers: dict[str, VectorLogSink]
    n_joints: int
    config: StationConfig
    extras: object = None
    true_model: RobotModel | None = None
    structural_mode: float | None = None

    @property
    def log_period(self) -> float:
        """Logging period in s."""
        return float(self.config.log_period)

    @property
    def seed(self) -> int:
        """Seed of the torque noise (used by :meth:`CreateDefaultContext`)."""
        return int(self.config.sensors.seed)

    def CreateDefaultContext(self) -> Context:
        """A root Context at time ``config.simulator.start_time``: noise seeded
        with ``seed``, the plant at the desired state of the trajectory at that
        time (so tracking starts with zero error), controller integral zero."""
        context = self.diagram.CreateDefaultContext()
        context.SetTime(self.config.simulator.start_time)
        self.diagram.SetRandomContext(context, RandomGenerator(self.seed))
        self.SetInitialState(context)
        return context

    def SetInitialState(
        self,
        context: Context,
        x: np.ndarray | None = None,
        *,
        payload_mass: float | None = None,
    ) -> None:
        """Puts the joints at [q; v] = ``x`` (2n; default the trajectory's
        desired state at context time) by each joint's position and velocity
        index (other coordinates of the plant state are left as they are), on
        an elastic robot the motor side, with the link side at rest there
        (deflection = :func:`rmdrake.dynamics.compliance.link_angles` - q at the true
        payload, or ``payload_mass`` kg of it; deflection rate 0), so a run
        starts without a transient."""
        if x is None:
            x = self.source.GetOutputPort("state").Eval(
                self.source.GetMyContextFromRoot(context)
            )
        n = self.n_joints
        S = self.joint_selector
        nq = self.plant.num_positions()
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        q = self.plant.GetPositions(plant_context).copy()
        v = self.plant.GetVelocities(plant_context).copy()
        q[np.argmax(S[:n, :nq], axis=1)] = x[:n]
        v[np.argmax(S[n:, nq:], axis=1)] = x[n:]
        self.plant.SetPositions(plant_context, q)
        self.plant.SetVelocities(plant_context, v)
        if self.true_model is not None:
            set_coupled_motor_state(self.plant, plant_context, self.true_model)
        if self.structural_mode is not None:
            model = self.true_model
            if payload_mass is not None:
                model = with_payload_mass(model, payload_mass)
            set_link_rest(self.plant, plant_context, model)


# ---- the build steps of MakeStation, in order -------------------------------------
def _model_check(model: RobotModel, what: str) -> None:
    """The true robot needs its dynamics and its effort limits (the plant
    clamps the actuation there), the controller's its dynamics, physical."""
    true = what == "true"
    require_dynamics(model, "the station", effort=true, role=f"{what} robot")
    require_physical(standard_parameters(model), f"{what} robot '{model.name}'")


@dataclasses.dataclass(frozen=True)
class _TrueRobot:
    """The true robot's systems in the builder (from :func:`_AddTrueRobot`).

    Attributes:
      plant: the MultibodyPlant ``plant``.
      scene_graph: its SceneGraph.
      joint_selector: the (2n, nq + nv) matrix S of :func:`joint_state_selector`
        for joint1..n.
      joint_state: output port of the joint state [q; v] = S @ plant state
        (2n; rad or m, rad/s or m/s).
      friction: the true joint friction ``friction`` (None on a discrete
        plant, whose friction is Drake's own systems).
      actuation: the input port of the joints' actuator efforts (n, N m or N).
      net_actuation: the output port of the efforts the joints' actuators
        apply (n, N m or N; what a joint-torque sensor reads).
    """

    plant: MultibodyPlant
    scene_graph: SceneGraph
    joint_selector: np.ndarray
    joint_state: OutputPort
    friction: JointFriction | None
    actuation: InputPort
    net_actuation: OutputPort

    @property
    def n_joints(self) -> int:
        """n."""
        return self.joint_selector.shape[0] // 2


def _CheckModels(
    true_model: RobotModel,
    trajectory: DesiredMotion,
    *,
    nominal_model: RobotModel,
    calibrated_model: RobotModel | None,
    identified_model: RobotModel | None,
) -> None:
    """Checks the robots and the motion given to :func:`MakeStation`, before
    anything is built: the same joint count n everywhere, a trajectory of the
    true robot's n joints, and physically valid dynamics of the true and (when
    another model) the nominal robot.

    Raises:
      TypeError, ValueError: as listed by :func:`MakeStation`.
    """
    n = true_model.n_joints
    if nominal_model.n_joints != n:
        raise ValueError(
            f"nominal robot '{nominal_model.name}' has {nominal_model.n_joints} "
            f"joints but the true robot '{true_model.name}' has {n}"
        )
    for what, other in (
        ("calibrated", calibrated_model),
        ("identified", identified_model),
    ):
        if other is not None and other.n_joints != n:
            raise ValueError(
                f"{what} robot '{other.name}' has {other.n_joints} joints but the "
                f"true robot '{true_model.name}' has {n}"
            )
    check_motion(trajectory, true_model)
    _model_check(true_model, "true")
    if nominal_model is not true_model:
        _model_check(nominal_model, "nominal")


MAX_RESOLUTION_SHARE = 1e-3
"""The coarsest encoder count allowed, as a share of each joint's position
range: a coarser one reads a still joint wherever the motion goes (a count of
10 rad read q1 = 0 throughout)."""


def _SensorArrays(
    sensors: SensorConfig, model: RobotModel
) -> tuple[np.ndarray, np.ndarray]:
    """(torque_noise, encoder_resolution) of ``sensors`` per joint of ``model``:
    (n,) std in N m or N and (n,) resolution in rad or m per count (a scalar
    applies to every joint).

    Raises:
      ValueError: a wrong length, NaN or negative value (naming the field), or
        a count over :data:`MAX_RESOLUTION_SHARE` of the joint's range.
    """
    n = model.n_joints
    sigma = per_joint(sensors.torque_noise, n, "sensors.torque_noise", "N m or N")
    resolution = per_joint(
        sensors.encoder_resolution, n, "sensors.encoder_resolution", "rad or m"
    )
    span = np.asarray(model.limits.upper) - np.asarray(model.limits.lower)
    coarse = np.flatnonzero(resolution > MAX_RESOLUTION_SHARE * span)
    if coarse.size:
        j = int(coarse[0])
        raise ValueError(
            f"sensors.encoder_resolution: {resolution[j]:g} per count on joint "
            f"{j + 1} is over {MAX_RESOLUTION_SHARE:g} of its range "
            f"({span[j]:.4g} rad or m): the encoder would not see the motion; "
            "give rad (m on a slide) per count"
        )
    return sigma, resolution


def _AddTrueRobot(
    builder: DiagramBuilder, config: StationConfig, model: RobotModel, *, visual: bool
) -> _TrueRobot:
    """Adds the true robot: the MultibodyPlant ``plant`` of ``model`` (with its
    SceneGraph, the geometry drawn when ``visual``; continuous or discrete by
    ``config.time_step``, s), the MatrixGain ``joint_state`` (S @
    plant.state; not added when S is the identity, then the joint state is
    plant.state itself) and the true joint friction (``model``'s fv, fc, fcn,
    tau0; ``config.v_eps`` in rad/s or m/s):

    * continuous plant: the system ``friction`` (:class:`JointFriction`),
      plant.state -> friction -> plant.applied_generalized_force;
    * discrete plant: :func:`~rmdrake.systems.friction.AddDiscretePlantFriction`
      (Drake's own systems, no Python one).

    plant.actuation is left for :func:`_AddController` (through
    ``robot.actuation``).
    """
    n = model.n_joints
    discrete = config.time_step > 0
    if model.coupled_motors and not discrete:
        raise ValueError(
            f"true robot '{model.name}' has coupled motor(s) "
            f"{', '.join(str(m + 1) for m in model.coupled_motors)} (its "
            "transmission's coupling): Drake models them with coupler "
            "constraints, which need a discrete plant (time_step > 0)"
        )
    plant, scene_graph = MakePlant(
        model,
        builder=builder,
        time_step=config.time_step,
        visual=visual,
        coulomb_width=config.v_eps if discrete else None,
    )
    plant.set_name("plant")
    joints = [joint_name(j) for j in range(1, n + 1)]
    S = joint_state_selector(plant, joints)
    joint_state = _map_port(builder, plant.get_state_output_port(), S, "joint_state")
    if discrete:
        actuation, net_actuation = AddDiscretePlantFriction(builder, plant, model, S)
        return _TrueRobot(
            plant=plant,
            scene_graph=scene_graph,
            joint_selector=S,
            joint_state=joint_state,
            friction=None,
            actuation=actuation,
            net_actuation=net_actuation,
        )
    dyn = model.dynamics
    friction = JointFriction.AddToBuilder(
        builder,
        plant,
        fv=dyn[:, _FV],
        fc=dyn[:, _FC],
        v_eps=config.v_eps,
        exact_sign=config.exact_sign,
        fcn=model.fcn,
        tau0=model.tau0,
        name="friction",
        joints=joints,
    )
    return _TrueRobot(
        plant=plant,
        scene_graph=scene_graph,
        joint_selector=S,
        joint_state=joint_state,
        friction=friction,
        actuation=plant.get_actuation_input_port(),
        net_actuation=plant.get_net_actuation_output_port(),
    )


def _AddController(
    builder: DiagramBuilder,
    config: StationConfig,
    robot: _TrueRobot,
    source: FourierExcitationSource | JointTrajectorySource,
    *,
    model: RobotModel,
    trajectory: DesiredMotion,
    calibrated: RobotModel | None,
    identified: RobotModel | None,
) -> None:
    """Adds the controller of ``config.controller`` (:func:`AddController`, on
    the controller's ``model`` and the ``calibrated`` and ``identified``
    robots) and connects it: robot.joint_state (measured [q; v]),
    source.state ([q_d; v_d]) and source.vdot (vdot_d) in, its joint efforts
    (n, N m or N) out to plant.actuation."""
    actuation = AddController(
        builder,
        config.controller,
        ControllerInputs(
            model=model,
            trajectory=trajectory,
            joint_state=robot.joint_state,
            desired_state=source.GetOutputPort("state"),
            desired_acceleration=source.GetOutputPort("vdot"),
            v_eps=float(config.v_eps),
            calibrated=calibrated,
            identified=identified,
            time_step=float(config.time_step),
        ),
    )
    builder.Connect(actuation, robot.actuation)


def _AddSensors(
    builder: DiagramBuilder,
    robot: _TrueRobot,
    *,
    torque_noise: np.ndarray,
    encoder_resolution: np.ndarray,
    log_period: float,
    elastic: bool,
) -> tuple[EncoderQuantizer, dict[str, OutputPort], OutputPort]:
    """Adds the joint sensors of a real arm, reading the true robot.

    Systems and connections: ``demux`` splits robot.joint_state into q and v;
    ``encoder`` quantises q (``encoder_resolution``, (n,) rad or m per count);
    the torque sensor adds Gaussian noise (``torque_noise``, (n,) std in N m
    or N, sampled every ``log_period`` s) to plant.net_actuation, and is left
    out when every std is zero; ``joint_accelerations`` selects the joints'
    accelerations from plant.generalized_acceleration (left out when S is the
    identity); and, when ``elastic``, ``link_positions`` selects the true
    link-side positions from plant.state.

    Returns:
      (encoder, signals, q_link): signals is ``{"q", "qd", "qdd", "tau"}`` ->
      output port of the measured signal (rad or m, rad/s or m/s, rad/s^2 or
      m/s^2, N m or N), q_link the port of the true link-side positions (the
      demux's q on a rigid robot).
    """
    plant, n = robot.plant, robot.n_joints
    S_v = robot.joint_selector[n:, plant.num_positions() :]  # joint velocities
    demux = builder.AddNamedSystem("demux", Demultiplexer([n, n]))
    builder.Connect(robot.joint_state, demux.get_input_port())
    encoder = EncoderQuantizer.AddToBuilder(
        builder,
        demux.get_output_port(0),
        resolution=encoder_resolution,
        name="encoder",
    )
    tau = robot.net_actuation
    if np.any(torque_noise > 0):
        tau = AddTorqueSensorNoise(
            builder, tau, std=torque_noise, sample_period=log_period
        )
    q_link = demux.get_output_port(0)
    if elastic:
        L = link_position_selector(plant, n)
        q_link = _map_port(builder, plant.get_state_output_port(), L, "link_positions")
    signals = {
        "q": encoder.get_output_port(),
        "qd": demux.get_output_port(1),
        "qdd": _map_port(
            builder,
            plant.get_generalized_acceleration_output_port(),
            S_v,
            "joint_accelerations",
        ),
        "tau": tau,
    }
    return encoder, signals, q_link


def _AddLoggers(
    builder: DiagramBuilder,
    robot: _TrueRobot,
    signals: dict[str, OutputPort],
    q_link: OutputPort,
    *,
    log_period: float,
    elastic: bool,
    logged: bool,
) -> dict[str, VectorLogSink]:
    """Logs and exports the station's outputs.

    Each of ``signals`` (``q``, ``qd``, ``qdd``, ``tau``, from
    :func:`_AddSensors`) goes to a VectorLogSink ``log_<name>`` (a sample every
    ``log_period`` s; none unless ``logged``) and is exported as the diagram
    output ``<name>``; then ``q_link`` is exported as ``q_link`` (and logged
    by ``log_q_link`` when ``elastic`` and ``logged``) and plant.state as
    ``state``.

    Returns:
      ``{"q", "qd", "qdd", "tau"}`` (and ``"q_link"`` when ``elastic``) ->
      VectorLogSink; empty unless ``logged``.
    """
    loggers = {}
    for name, port in signals.items():
        if logged:
            loggers[name] = LogVectorOutput(port, builder, log_period)
            loggers[name].set_name(f"log_{name}")
        builder.ExportOutput(port, name)
    builder.ExportOutput(q_link, "q_link")
    if elastic and logged:
        loggers["q_link"] = LogVectorOutput(q_link, builder, log_period)
        loggers["q_link"].set_name("log_q_link")
    builder.ExportOutput(robot.plant.get_state_output_port(), "state")
    return loggers


def MakeStation(
    config: StationConfig,
    *,
    true_model: RobotModel,
    trajectory: DesiredMotion,
    nominal_model: RobotModel | None = None,
    calibrated_model: RobotModel | None = None,
    identified_model: RobotModel | None = None,
    meshcat: Meshcat | None = None,
    add_systems: AddSystems | None = None,
    joint_logs: bool = True,
) -> Station:
    """Builds the true-robot station Diagram (see the module docstring).

    Args:
      config: diagram and simulation options (``StationConfig()`` for the
        defaults); copied.
      true_model: the simulated robot (its "true", perturbed parameters).
      trajectory: the desired motion (same joint count): a FourierTrajectory,
        or a pydrake Trajectory of the n joint positions (rad or m) over time
        in s
        with derivatives, e.g. from
        :func:`~rmdrake.systems.station_sources.setpoint_trajectory`.
      nominal_model: the model the controller uses; default ``true_model``
        (perfect model knowledge; made rigid when it has elastic joints).
      calibrated_model, identified_model: the calibrated kinematics and the
        identified dynamics, for a ``CompensationControllerConfig``
        controller (same joint count).
      meshcat: if given, the robot is drawn there while simulating.
      add_systems: if given, called as ``add_systems(builder, plant, signals)``
        before the build, after everything else, to add systems that read the
        plant or the measured signals (``signals``: ``{"q", "qd", "qdd",
        "tau"}`` -> output port, as logged), e.g. sensors with their
        ``AddToBuilder``; its return value is kept as ``Station.extras``.
      joint_logs: log the measured signals every ``config.log_period`` s
        (``Station.loggers``, what :func:`RunStation` returns). False for a
        run read only at chosen instants by loggers of ``add_systems`` (forced
        publish): the 150 Hz publish events bound the integrator's steps and
        evaluate the accelerations and torques at each, a third of the
        simulation's time on a hold; the motion is the same to the
        integrator's accuracy (its steps differ).

    Raises:
      TypeError: ``config`` not a StationConfig, an unknown controller, or a
        trajectory of another type.
      ValueError: joint counts that differ, NaN or negative options (naming the
        field), a model without dynamics or a true model without effort limits
        (a kinematic-only model: :func:`~rmdrake.model.robot.require_dynamics`),
        physically invalid parameters
        (naming the link and the failed check), or a ``controller.bandwidth``
        at or above an elastic true robot's lowest structural mode.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.systems import MakeStation, StationConfig
    >>> robot = load_robot("rv3sb")
    >>> trajectory = random_fourier_trajectory(robot, seed=0)
    >>> station = MakeStation(StationConfig(), true_model=robot, trajectory=trajectory)
    >>> station.n_joints, sorted(station.loggers)[:3]
    (6, ['q', 'qd', 'qdd'])
    """
    if not isinstance(config, StationConfig):
        raise TypeError(
            f"config: expected a StationConfig, found {type(config).__name__}"
        )
    config = copy.deepcopy(config)
    if nominal_model is None:
        nominal_model = true_model
        if true_model.compliance is not None:
            nominal_model = dataclasses.replace(true_model, compliance=None)
    _CheckModels(
        true_model,
        trajectory,
        nominal_model=nominal_model,
        calibrated_model=calibrated_model,
        identified_model=identified_model,
    )
    check_times(config)
    mode = check_controller_bandwidth(
        true_model,
        motion_start(trajectory),
        getattr(config.controller, "bandwidth", None),
    )
    sigma, resolution = _SensorArrays(config.sensors, true_model)

    builder = DiagramBuilder()
    robot = _AddTrueRobot(builder, config, true_model, visual=meshcat is not None)
    source = AddDesiredMotion(builder, trajectory)
    _AddController(
        builder,
        config,
        robot,
        source,
        model=nominal_model,
        trajectory=trajectory,
        calibrated=calibrated_model,
        identified=identified_model,
    )
    encoder, signals, q_link = _AddSensors(
        builder,
        robot,
        torque_noise=sigma,
        encoder_resolution=resolution,
        log_period=config.log_period,
        elastic=mode is not None,
    )
    loggers = _AddLoggers(
        builder,
        robot,
        signals,
        q_link,
        log_period=config.log_period,
        elastic=mode is not None,
        logged=joint_logs,
    )
    extras = None if add_systems is None else add_systems(builder, robot.plant, signals)
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, robot.scene_graph, meshcat)
    diagram = builder.Build()
    diagram.set_name(f"station_{true_model.name}")
    return Station(
        diagram=diagram,
        plant=robot.plant,
        source=source,
        friction=robot.friction,
        encoder=encoder,
        joint_selector=robot.joint_selector,
        joint_state=robot.joint_state,
        loggers=loggers,
        n_joints=true_model.n_joints,
        config=config,
        extras=extras,
        true_model=true_model,
        structural_mode=mode,
    )


_JOINT_LOG = ("q", "qd", "qdd", "tau")


@contextlib.contextmanager
def simulation_progress(
    simulator: Simulator,
    t_final: float,
    *,
    desc: str = "simulated s",
    disable: bool = False,
    lazy: bool = True,
) -> Iterator[None]:
    """While the block runs, ``simulator``'s monitor drives a progress bar
    over the simulated seconds from its context's time at entry to
    ``t_final`` (s) (:func:`rmdrake.progress.simulated_time_progress`: lines
    in batch use, with the time left; ``lazy``, the default for the many
    short runs of a study: only once the process has been silent for the
    progress interval); the monitor is cleared at the end. For a run that
    calls ``AdvanceTo`` itself (:func:`RunStation` takes a ``progress``
    callback instead)."""
    t0 = simulator.get_context().get_time()
    span = max(t_final - t0, 0.0)
    with simulated_time_progress(
        span, desc=desc, disable=disable, lazy=lazy
    ) as progress:

        def monitor(root: Context) -> EventStatus:
            progress(min(root.get_time() - t0, span), span)
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
        try:
            yield
        finally:
            simulator.clear_monitor()


def RunStation(
    station: Station,
    *,
    periods: float | None = None,
    duration: float | None = None,
    context: Context | None = None,
    progress: Callable[[float, float], None] | None = None,
    other_logs: dict[str, np.ndarray] | None = None,
) -> JointLog:
    """Simulates the station from its context's time; returns the log.

    The integrator is ``station.config.simulator`` (applied with Drake's
    ``ApplySimulatorConfig``); the run starts at the context's time.

    Args:
      station: from :func:`MakeStation`.
      periods: number of periods of a Fourier trajectory to run (the duration
        is periods / base_frequency of the trajectory in the context); default
        1. Not for a Trajectory (no period).
      duration: or the run's length in s; default, for a Trajectory, up to
        its end time (ValueError for both, or for periods with a Trajectory).
      context: the initial root context (default
        :meth:`Station.CreateDefaultContext`), for example with other
        parameters; it is copied, not modified, and its logs must be empty.
      progress: called as ``progress(t, t_final)`` (s) as the simulation goes.
      other_logs: if given, filled with the samples (M, size) of the loggers
        that are not in the JointLog (``q_link`` of an elastic robot).

    Returns:
      The samples at t0, t0 + log_period, ... strictly below the end time
      (periods * rate / base_frequency samples, 1500 for one period of the
      paper's trajectory): measured q, qd, qdd and tau. On a discrete
      station the samples are one log period later (t0 + log_period up to
      the end time), so that each holds the torque and acceleration of the
      step that reached it (the plant's sampled outputs; at t0 no step has
      been taken).

    Raises:
      ValueError: a station built without joint logs (``joint_logs=False``),
        or a bad ``periods`` or ``duration`` (see above).

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.systems import MakeStation, RunStation, StationConfig
    >>> robot = load_robot("rv3sb")
    >>> trajectory = random_fourier_trajectory(robot, seed=0)
    >>> station = MakeStation(StationConfig(), true_model=robot, trajectory=trajectory)
    >>> log = RunStation(station, duration=0.2)  # s of simulated time
    >>> log.q.shape[1], bool(log.t[-1] <= 0.2 + 1e-9)
    (6, True)
    """
    if not station.loggers:
        raise ValueError(
            "RunStation returns the station's joint log, and this station was "
            "built without one (MakeStation(..., joint_logs=False))"
        )
    if context is None:
        context = station.CreateDefaultContext()
    else:
        context = context.Clone()  # the Simulator takes ownership of its context
    t0 = context.get_time()
    t_final = t0 + motion_duration(station.source, context, periods, duration)
    # A discrete plant's sampled torque and acceleration exist from its first
    # step on: its log starts one period later and ends one period later.
    shift = station.log_period if station.config.time_step > 0 else 0.0
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(station.config.simulator, simulator)
    context.SetTime(t0)  # ApplySimulatorConfig sets the time to start_time
    if progress is not None:

        def monitor(root: Context) -> EventStatus:
            progress(root.get_time(), t_final)
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
    simulator.Initialize()
    # Stop just before the end so the log holds the samples in [t0, t_final).
    half = 0.5 * station.log_period
    simulator.AdvanceTo(t_final + shift - half)
    logs = {k: v.FindLog(context) for k, v in station.loggers.items()}
    t = logs["q"].sample_times()
    keep = (t > t0 + shift - half) & (t < t_final + shift - half)
    data = {k: v.data()[:, keep].T for k, v in logs.items()}
    if other_logs is not None:
        other_logs.update({k: v for k, v in data.items() if k not in _JOINT_LOG})
    return JointLog(
        t=t[keep], q=data["q"], tau=data["tau"], qd=data["qd"], qdd=data["qdd"]
    )
