"""The true robot simulated in Drake: plant, friction, tracking controller, loggers.

This replaces the paper's SimMechanics model (§4): the MultibodyPlant of the TRUE
robot (perturbed parameters) follows a Fourier excitation trajectory under an
inverse-dynamics controller built on the NOMINAL model, and loggers record what
the joint sensors of a real arm would: encoder angles, velocities, accelerations
and joint torques.

Diagram of :func:`MakeStation`, as wiring (system names as in the Diagram,
``system.port``)::

    excitation ─state, vdot─► controller (ID on nominal) ─► actuation_sum ─┐
        │                        ▲ estimated_state                ▲        │
        └─state─► friction_feedforward ─► negate_friction ────────┘        │
                                 │                                         ▼
    plant.state ─────────────────┘                         plant.actuation
    plant.state ─► friction (true fv, fc) ─► plant.applied_generalized_force
    plant.state ─► demux ─┬─ q ─► encoder (quantiser) ─► log_q
                          └─ v ────────────────────────► log_qd
    plant.generalized_acceleration ────────────────────► log_qdd
    plant.net_actuation ─► [torque_sensor: + torque_noise] ─► log_tau

The diagram exports ``q``, ``qd``, ``qdd``, ``tau`` (the measured signals, as
logged) and ``state`` (the true plant state).

Choices and their reasons:

* **Continuous plant** (``time_step = 0``, the default) integrated with Drake's
  error-controlled Runge-Kutta 3 (see :func:`RunStation`). With a continuous
  plant the logged acceleration is the plant's
  ``generalized_acceleration`` output, computed from the same state and the
  same applied torque as the logged q, qd and tau, so at every logged sample
  ``tau = M(q) qdd + c(q, qd) - g(q) + fv qd + fc s(qd)`` holds to round-off,
  independently of the integrator's accuracy (which only decides how closely
  the simulated motion follows the exact solution). A discrete (SAP) plant is
  accepted (``time_step > 0``) but its logged acceleration is a finite
  difference over one step, so that identity then holds only to O(time_step).
* **Friction**: all of it in :class:`~rmdrake.systems.friction.JointFriction`
  (the plant's joint damping is zero), smooth sign of width ``v_eps``.
* **Controller**: Drake ``InverseDynamicsController`` on a plant of the nominal
  model (rotor inertia included, no friction), with desired state and
  acceleration from :class:`~rmdrake.systems.excitation.FourierExcitationSource`,
  plus (optional, default on) a friction feedforward with the *nominal* fv, fc
  at the desired velocity. The commanded acceleration is
  ``vdot_d + kp (q_d - q) + kd (v_d - v) + ki ∫(q_d - q)``, so the gains are in
  1/s^2, 1/s and 1/s^3, independent of the robot's size. Default: a triple
  closed-loop pole at -omega_c with omega_c = 40 rad/s (``kp = 3 w^2 = 4800``,
  ``kd = 3 w = 120``, ``ki = w^3 = 64000``), about 13x the 0.5 Hz top harmonic
  of the paper's excitation. On the RV-3SB with +-15 % inertial and +-20 %
  friction errors in the nominal model this tracks within 0.2 deg; 15 rad/s
  gave 1.2 deg and was not faster to integrate.
* **Logged torque** = the plant's ``net_actuation`` output = the actuator torque
  a joint-torque sensor reads (gear ratio 1, so it is the joint torque). It is
  what the regressor predicts: ``Y(q, qd, qdd) @ chi_true`` including rotor
  inertia and friction. The plant clamps the actuation to the model's effort
  limits (continuous mode too), and ``net_actuation`` reports the clamped
  torque, so the identity holds under saturation as well; a saturated joint
  shows as a logged torque at +-effort and a larger tracking error.
* **Sensor effects** apply to the logged measurements only (the servo loop sees
  the true state): encoder quantisation of q (resolution in rad), Gaussian
  torque noise (std in N m, a Drake ``RandomSource`` sampled at the log period,
  seeded through ``SetRandomContext`` with the station's seed). qd and qdd are
  logged exact; drop them from the log to make identification estimate them
  from the quantised q.

Speed (``bench/simulate.py``, 2-core machine under load): one 10 s period at
150 Hz takes about 5 s CPU on the RV-3SB (about 7900 RK3 steps) and 1.5 s on
demo_rh (about 2000 steps, the log period caps the step). The cost is the
Coulomb smoothing on light joints: while |v| < a few v_eps the friction acts as
a damper fc / v_eps on the joint inertia J, a time constant of J v_eps / fc
(about 1e-5 s on the RV-3SB wrist), which an explicit integrator must resolve;
the friction feedforward keeps these passages short (without it: 3x the steps).
A wider ``v_eps`` is cheaper (1e-2 rad/s: about 40 % fewer steps) but biases
identification with an exact-sign regressor on more samples. Implicit
integrators were slower (finite-difference Jacobians through Python systems).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from pydrake.common import RandomDistribution, RandomGenerator
from pydrake.geometry import Meshcat, MeshcatVisualizer
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import (
    ApplySimulatorConfig,
    Simulator,
    SimulatorConfig,
)
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, EventStatus
from pydrake.systems.primitives import (
    Adder,
    Demultiplexer,
    Gain,
    LogVectorOutput,
    RandomSource,
    VectorLogSink,
)

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics import require_physical, standard_parameters
from rmdrake.excitation import FourierTrajectory
from rmdrake.io import JointLog
from rmdrake.plant import MakePlant
from rmdrake.robot import DYNAMIC_KEYS, RobotModel
from rmdrake.systems.excitation import FourierExcitationSource
from rmdrake.systems.friction import DEFAULT_V_EPS, JointFriction
from rmdrake.systems.joint_sensors import EncoderQuantizer

__all__ = [
    "DEFAULT_BANDWIDTH",
    "DEFAULT_LOG_PERIOD",
    "Station",
    "MakeStation",
    "RunStation",
    "default_gains",
]

DEFAULT_BANDWIDTH = 40.0
"""omega_c in rad/s of the default gains (triple closed-loop pole at -omega_c)."""

DEFAULT_LOG_PERIOD = 1.0 / 150.0
"""Default logging period in s: the paper's 150 Hz."""

_FV, _FC = DYNAMIC_KEYS.index("fv"), DYNAMIC_KEYS.index("fc")


def default_gains(
    n: int, bandwidth: float = DEFAULT_BANDWIDTH
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kp, kd, ki) placing a triple closed-loop pole at -bandwidth (rad/s).

    Units 1/s^2, 1/s, 1/s^3 (the gains act on accelerations; see the module
    docstring), each an (n,) array.
    """
    w = float(bandwidth)
    if not math.isfinite(w) or w <= 0:
        raise ValueError(f"bandwidth: expected a positive value in rad/s, found {w}")
    one = np.ones(n)
    return 3.0 * w * w * one, 3.0 * w * one, w**3 * one


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
      source: the Fourier excitation source.
      friction: the true robot's joint friction.
      loggers: ``{"q", "qd", "qdd", "tau"}`` -> VectorLogSink.
      n_joints: n.
      log_period: logging period in s.
      seed: seed of the torque noise (used by :meth:`CreateDefaultContext`).
    """

    diagram: Diagram
    plant: MultibodyPlant
    source: FourierExcitationSource
    friction: JointFriction
    loggers: dict[str, VectorLogSink]
    n_joints: int
    log_period: float
    seed: int

    def CreateDefaultContext(self) -> Context:
        """A root Context: noise seeded with ``seed``, the plant at the desired
        state of the trajectory at t = 0 (so tracking starts with zero error),
        controller integral zero."""
        context = self.diagram.CreateDefaultContext()
        self.diagram.SetRandomContext(context, RandomGenerator(self.seed))
        self.SetInitialState(context)
        return context

    def SetInitialState(self, context: Context) -> None:
        """Puts the plant at the trajectory's desired [q; v] at context time."""
        x_d = self.source.GetOutputPort("state").Eval(
            self.source.GetMyContextFromRoot(context)
        )
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        self.plant.SetPositionsAndVelocities(plant_context, x_d)


def _model_check(model: RobotModel, what: str) -> None:
    if model.dynamics is None:
        raise ValueError(
            f"{what} robot '{model.name}': expected a 'dynamics' section with 13 "
            "standard parameters per link, found none"
        )
    require_physical(standard_parameters(model), f"{what} robot '{model.name}'")


def _per_joint(value: object, n: int, what: str, unit: str) -> np.ndarray:
    arr = as_finite_array(value, what)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    arr = as_finite_array(arr, what, (n,))
    if np.any(arr < 0):
        j = int(np.flatnonzero(arr < 0)[0])
        raise ValueError(
            f"{what}: expected >= 0 {unit}, found {arr[j]} (joint {j + 1})"
        )
    return arr


def MakeStation(
    true_model: RobotModel,
    *,
    trajectory: FourierTrajectory,
    nominal_model: RobotModel | None = None,
    time_step: float = 0.0,
    kp: object = None,
    kd: object = None,
    ki: object = None,
    log_period: float = DEFAULT_LOG_PERIOD,
    torque_noise: object = 0.0,
    encoder_resolution: object = 0.0,
    seed: int = 0,
    v_eps: float = DEFAULT_V_EPS,
    exact_sign: bool = False,
    friction_feedforward: bool = True,
    meshcat: Meshcat | None = None,
) -> Station:
    """Builds the true-robot station Diagram (see the module docstring).

    Args:
      true_model: the simulated robot (its "true", perturbed parameters).
      trajectory: the reference Fourier trajectory (same joint count).
      nominal_model: the model the controller uses; default ``true_model``
        (perfect model knowledge, then only friction model error remains when
        ``friction_feedforward`` is off).
      time_step: 0 for a continuous plant (recommended), > 0 s for a discrete
        (SAP) plant (logged qdd is then a one-step difference).
      kp, kd, ki: controller gains (scalar or (n,)) in 1/s^2, 1/s, 1/s^3;
        default :func:`default_gains`.
      log_period: logging period in s (the paper's 1/150).
      torque_noise: std of the Gaussian torque-sensor noise, N m (scalar or (n,)).
      encoder_resolution: encoder resolution, rad per count (scalar or (n,));
        0 = no quantisation.
      seed: seed of the torque noise.
      v_eps: smooth-sign width of the friction, rad/s.
      exact_sign: use sign(v) in the simulated friction (chatters; tests only).
      friction_feedforward: add the nominal friction at the desired velocity to
        the controller torque.
      meshcat: if given, the robot is drawn there while simulating.

    Raises:
      ValueError: joint counts that differ, NaN or negative options, a model
        without dynamics, or physically invalid parameters (naming the link and
        the failed check).
    """
    nominal_model = true_model if nominal_model is None else nominal_model
    n = true_model.n_joints
    if nominal_model.n_joints != n:
        raise ValueError(
            f"nominal robot '{nominal_model.name}' has {nominal_model.n_joints} "
            f"joints but the true robot '{true_model.name}' has {n}"
        )
    trajectory.check_joint_count(true_model)
    _model_check(true_model, "true")
    if nominal_model is not true_model:
        _model_check(nominal_model, "nominal")
    defaults = default_gains(n)
    gains = [
        _per_joint(g if g is not None else d, n, name, unit)
        for g, d, name, unit in zip(
            (kp, kd, ki), defaults, ("kp", "kd", "ki"), ("1/s^2", "1/s", "1/s^3"),
            strict=True,
        )
    ]  # fmt: skip
    sigma = _per_joint(torque_noise, n, "torque noise", "N m")
    resolution = _per_joint(encoder_resolution, n, "encoder resolution", "rad")
    for name, value in (("log_period", log_period), ("time_step", time_step)):
        if (
            not math.isfinite(value)
            or value < 0
            or (name == "log_period" and not value)
        ):
            raise ValueError(f"{name}: expected a positive time in s, found {value}")

    builder = DiagramBuilder()
    plant, scene_graph = MakePlant(
        true_model, builder=builder, time_step=time_step, visual=meshcat is not None
    )
    plant.set_name("plant")
    dyn = true_model.dynamics
    friction = builder.AddNamedSystem(
        "friction",
        JointFriction(
            fv=dyn[:, _FV], fc=dyn[:, _FC], v_eps=v_eps, exact_sign=exact_sign
        ),
    )
    builder.Connect(plant.get_state_output_port(), friction.get_input_port())
    builder.Connect(
        friction.get_output_port(), plant.get_applied_generalized_force_input_port()
    )

    source = builder.AddNamedSystem(
        "excitation", FourierExcitationSource(trajectory=trajectory)
    )
    nominal_plant, _ = MakePlant(nominal_model, visual=False)
    controller = builder.AddNamedSystem(
        "controller",
        InverseDynamicsController(
            nominal_plant, gains[0], gains[2], gains[1], has_reference_acceleration=True
        ),
    )
    # The controller holds a non-owning pointer to the nominal plant; keep the
    # plant alive as long as the controller (and so the diagram).
    controller._rmdrake_nominal_plant = nominal_plant
    builder.Connect(
        plant.get_state_output_port(), controller.get_input_port_estimated_state()
    )
    builder.Connect(
        source.GetOutputPort("state"), controller.get_input_port_desired_state()
    )
    builder.Connect(
        source.GetOutputPort("vdot"), controller.get_input_port_desired_acceleration()
    )
    actuation = controller.get_output_port_control()
    if friction_feedforward:
        nom = nominal_model.dynamics
        ff = builder.AddNamedSystem(
            "friction_feedforward",
            JointFriction(fv=nom[:, _FV], fc=nom[:, _FC], v_eps=v_eps),
        )
        builder.Connect(source.GetOutputPort("state"), ff.get_input_port())
        negate = builder.AddNamedSystem("negate_friction", Gain(-1.0, n))
        builder.Connect(ff.get_output_port(), negate.get_input_port())
        total = builder.AddNamedSystem("actuation_sum", Adder(2, n))
        builder.Connect(actuation, total.get_input_port(0))
        builder.Connect(negate.get_output_port(), total.get_input_port(1))
        actuation = total.get_output_port()
    builder.Connect(actuation, plant.get_actuation_input_port())

    # Measurements.
    demux = builder.AddNamedSystem("demux", Demultiplexer([n, n]))
    builder.Connect(plant.get_state_output_port(), demux.get_input_port())
    encoder = builder.AddNamedSystem("encoder", EncoderQuantizer(resolution=resolution))
    builder.Connect(demux.get_output_port(0), encoder.get_input_port())
    tau = plant.get_net_actuation_output_port()
    if np.any(sigma > 0):
        noise = builder.AddNamedSystem(
            "torque_noise",
            RandomSource(RandomDistribution.kGaussian, n, log_period),
        )
        scale = builder.AddNamedSystem("torque_noise_std", Gain(sigma))
        builder.Connect(noise.get_output_port(), scale.get_input_port())
        noisy = builder.AddNamedSystem("torque_sensor", Adder(2, n))
        builder.Connect(tau, noisy.get_input_port(0))
        builder.Connect(scale.get_output_port(), noisy.get_input_port(1))
        tau = noisy.get_output_port()
    signals = {
        "q": encoder.get_output_port(),
        "qd": demux.get_output_port(1),
        "qdd": plant.get_generalized_acceleration_output_port(),
        "tau": tau,
    }
    loggers = {}
    for name, port in signals.items():
        loggers[name] = LogVectorOutput(port, builder, log_period)
        loggers[name].set_name(f"log_{name}")
        builder.ExportOutput(port, name)
    builder.ExportOutput(plant.get_state_output_port(), "state")
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    diagram.set_name(f"station_{true_model.name}")
    return Station(
        diagram=diagram,
        plant=plant,
        source=source,
        friction=friction,
        loggers=loggers,
        n_joints=n,
        log_period=float(log_period),
        seed=int(seed),
    )


def RunStation(
    station: Station,
    *,
    periods: float = 1.0,
    context: Context | None = None,
    accuracy: float = 1e-4,
    progress: Callable[[float, float], None] | None = None,
) -> JointLog:
    """Simulates ``periods`` periods of the station's trajectory; returns the log.

    Args:
      station: from :func:`MakeStation`.
      periods: number of trajectory periods to run (the duration is
        periods / base_frequency of the trajectory in the context).
      context: the initial root context (default
        :meth:`Station.CreateDefaultContext`), for example with other
        parameters; it is copied, not modified, and its logs must be empty.
      accuracy: target accuracy of the error-controlled RK3 integrator
        (continuous plant; relative, Drake's weighted error norm).
      progress: called as ``progress(t, t_final)`` (s) as the simulation goes.

    Returns:
      The samples at t = 0, log_period, ... strictly below the end time
      (periods * rate / base_frequency samples, 1500 for one period of the
      paper's trajectory): measured q, qd, qdd and tau.
    """
    if not math.isfinite(periods) or periods <= 0:
        raise ValueError(f"periods: expected > 0, found {periods}")
    if context is None:
        context = station.CreateDefaultContext()
    else:
        context = context.Clone()  # the Simulator takes ownership of its context
    traj = station.source.GetTrajectory(station.source.GetMyContextFromRoot(context))
    t_final = context.get_time() + periods * traj.period
    simulator = Simulator(station.diagram, context)
    if station.plant.time_step() == 0.0:
        config = SimulatorConfig(
            integration_scheme="runge_kutta3",
            max_step_size=station.log_period,
            accuracy=accuracy,
            use_error_control=True,
        )
        ApplySimulatorConfig(config, simulator)
    if progress is not None:

        def monitor(root: Context) -> EventStatus:
            progress(root.get_time(), t_final)
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
    simulator.Initialize()
    # Stop just before the end so the log holds the samples in [t0, t_final).
    simulator.AdvanceTo(t_final - 0.5 * station.log_period)
    logs = {k: v.FindLog(context) for k, v in station.loggers.items()}
    t = logs["q"].sample_times()
    keep = t < t_final - 0.5 * station.log_period
    data = {k: v.data()[:, keep].T for k, v in logs.items()}
    return JointLog(
        t=t[keep], q=data["q"], tau=data["tau"], qd=data["qd"], qdd=data["qdd"]
    )
