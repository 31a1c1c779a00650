"""Joint controllers as Drake systems: what a robot runs before calibration, and
what it runs with its calibrated kinematics and identified dynamics.

Both are computed-torque controllers (Drake ``InverseDynamicsController``) on a
plant of a robot model, with feedback gains in acceleration units
(1/s^2, 1/s, 1/s^3, so they do not depend on the robot's size), plus a friction
feedforward at the commanded velocity::

    tau = ID_model(q, v, a_c + kp (q_c - q) + kd (v_c - v) + ki int(q_c - q))
          + fv v_c + fc s(v_c)

where (q_c, v_c, a_c) is the commanded joint motion. They differ in what they
know:

* :class:`NominalController`: the nominal model everywhere; (q_c, v_c, a_c) is
  the desired (nominal) joint program as given.
* :class:`CalibratedCompensationController`: four layers, each of which can be
  switched off so a study can show what each buys:

  - kinematic correction: the desired joint program was planned on the nominal
    model; it is mapped to the joints that put the CALIBRATED model's tool where
    the nominal model said it would be, online by
    :class:`~rmdrake.systems.correction.JointTargetCorrection` inside the
    controller (its updates solved ahead by
    :class:`~rmdrake.systems.correction.PresolvedTargetCorrection` when the
    controller is given the program it is fed), or offline by
    :func:`corrected_program` (as an industrial robot filters a program)
    before it is fed in;
  - deflection compensation (elastic joints): the corrected (link-side) motion
    is pre-deflected by the identified compliance at the current payload,
    q_c = q_l - C tau(q_l)
    (:class:`~rmdrake.systems.deflection.DeflectionCompensation`), so the
    feedback and its integral act on the motor side the encoder reads;
  - identified dynamics: the inverse dynamics run on a plant of the IDENTIFIED
    robot (physically consistent standard parameters), not the nominal;
  - identified friction: fv, fc of the identified robot in the feedforward.

Both are Diagrams with the same ports (plus ``payload_mass`` with the deflection
layer), and each has an ``AddToBuilder`` that wires it into a user's diagram
and a ``from_config`` that builds it from the station's configuration
(:class:`~rmdrake.systems.station_config.InverseDynamicsControllerConfig`,
:class:`~rmdrake.systems.station_config.CompensationControllerConfig`)::

    config = CompensationControllerConfig(bandwidth=10.0, identified_friction=False)
    controller = builder.AddNamedSystem(
        "controller",
        CalibratedCompensationController.from_config(
            config, nominal=nominal, identified=identified, calibrated=calibrated
        ),
    )
    controller.ConnectInputs(
        builder, desired_state=source.get_output_port(), estimated_state=state
    )

The inverse dynamics always run on a rigid plant of their model (an elastic
model's compliance is dropped there). A controller that assumes rigid joints
refuses an elastic model (:func:`require_rigid`); an elastic TRUE robot under
it is the uncompensated case a study compares against.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import numpy as np
from pydrake.systems.controllers import InverseDynamics, InverseDynamicsController
from pydrake.systems.framework import Diagram, DiagramBuilder, InputPort, OutputPort
from pydrake.systems.primitives import Adder, DiscreteTimeIntegrator, Gain, MatrixGain
from pydrake.trajectories import PiecewisePolynomial, Trajectory

from rmdrake.arrays import per_joint
from rmdrake.compensation.correction import correct_joint_motion
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.model.dynamic_parameters import require_physical, standard_parameters
from rmdrake.model.plant import MakePlant, coupled_rotors_on_diagonal
from rmdrake.model.robot import RobotModel
from rmdrake.systems.correction import (
    JointTargetCorrection,
    PresolvedTargetCorrection,
    presolvable,
)
from rmdrake.systems.deflection import DeflectionCompensation, is_elastic, motor_motion
from rmdrake.systems.friction import AddFrictionFeedforward

__all__ = [
    "DEFAULT_BANDWIDTH",
    "AddSampledPid",
    "CalibratedCompensationController",
    "CompensationSettings",
    "ComputedTorqueSettings",
    "NominalController",
    "corrected_program",
    "default_gains",
    "deflection_model",
    "require_rigid",
]


DEFAULT_BANDWIDTH = 40.0
"""omega_c in rad/s of the default gains (triple closed-loop pole at -omega_c)."""


class ComputedTorqueSettings(Protocol):
    """What :meth:`NominalController.from_config` reads of a configuration:
    the fields of
    :class:`~rmdrake.systems.station_config.InverseDynamicsControllerConfig`
    (the station's configurations are defined where the station is; these
    controllers do not import them)."""

    bandwidth: float
    """rad/s of the gains not given (a triple closed-loop pole)."""
    kp: object
    """1/s^2, one value or n; None: from the bandwidth."""
    kd: object
    """1/s, likewise."""
    ki: object
    """1/s^3, likewise."""
    friction_feedforward: bool
    """Add the model's friction at the commanded velocity."""


class CompensationSettings(ComputedTorqueSettings, Protocol):
    """What :meth:`CalibratedCompensationController.from_config` reads of a
    configuration: the fields of
    :class:`~rmdrake.systems.station_config.CompensationControllerConfig`
    that shape the controller (its layers and the correction's period)."""

    kinematic_correction: bool
    deflection_compensation: bool
    correction_period: float
    """s between the online correction's exact solves."""
    correction_ahead: bool
    """Solve the online correction's updates ahead, given a pydrake program."""
    identified_dynamics: bool
    identified_friction: bool


def default_gains(
    n: int, bandwidth: float = DEFAULT_BANDWIDTH
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kp, kd, ki) = (3 w^2, 3 w, w^3) for w = bandwidth in rad/s, each (n,).

    They place a triple closed-loop pole at -w on a unit double integrator:
    the gains of the computed-torque controllers in 1/s^2, 1/s, 1/s^3
    (multiply by an inertia for torque gains).

    Example:

    >>> from rmdrake.systems import default_gains
    >>> kp, kd, ki = default_gains(6, bandwidth=20.0)
    >>> kp.shape, float(kp[0]), float(kd[0])
    ((6,), 1200.0, 60.0)
    """
    w = float(bandwidth)
    if not math.isfinite(w) or w <= 0:
        raise ValueError(f"bandwidth: expected a positive value in rad/s, found {w}")
    one = np.ones(n)
    return 3.0 * w * w * one, 3.0 * w * one, w**3 * one


_PORT_BLOCK = """
    .. pydrake_system::

        name: {name}
        input_ports:
        - desired_state
        - desired_acceleration
        - estimated_state
        - payload_mass (deflection layer only)
        output_ports:
        - actuation
        - commanded_state

    ``desired_state`` [q_d; v_d] (2n; rad or m, rad/s or m/s) and
    ``desired_acceleration`` (n; rad/s^2 or m/s^2): the joint program as
    planned on the nominal model;
    ``estimated_state`` [q; v] (2n): the measured joint state (motor side of
    an elastic joint); ``payload_mass`` (1; kg at the tool): the payload the
    deflection layer pre-deflects for; ``actuation`` (n; N m or N): the joint
    efforts; ``commanded_state`` [q_c; v_c] (2n): what the feedback tracks after
    the kinematic correction and the pre-deflection (= desired without them).
"""


def require_rigid(model: RobotModel, what: str, instead: str) -> None:
    """One-line ValueError when ``model`` has an elastic joint: ``what`` names
    the field and the controller that assumes rigid joints, ``instead`` what to
    use."""
    if is_elastic(model):
        raise ValueError(
            f"{what}: robot '{model.name}' is elastic (compliance stiffness > 0), "
            f"but this controller assumes rigid joints; {instead}"
        )


def _checked(model: RobotModel, what: str) -> RobotModel:
    if model.dynamics is None:
        raise ValueError(
            f"{what} robot '{model.name}': expected a 'dynamics' section with 13 "
            "standard parameters per link, found none"
        )
    require_physical(standard_parameters(model), f"{what} robot '{model.name}'")
    return model


def AddSampledPid(
    builder: DiagramBuilder,
    *,
    kp: np.ndarray,
    kd: np.ndarray,
    ki: np.ndarray,
    time_step: float,
    name: str = "pid",
) -> tuple[InputPort, InputPort, OutputPort]:
    """A joint PID sampled every ``time_step`` s, as a real arm's controller
    computes it, in Drake's own systems (no continuous state, unlike Drake's
    ``PidController``): with e = q_c - q and its rate v_c - v,

        u_k = kp e_k + kd (v_c - v)_k + z_k,   z_(k+1) = z_k + time_step ki e_k

    (each gain (n,); u in the units the gains give it: 1/s^2, 1/s, 1/s^3 for a
    reference acceleration, N m/rad, N m s/rad, N m/(rad s) for a joint
    effort). Systems ``<name>_error`` ([q_c; v_c] - [q; v]), ``<name>_pd``,
    ``<name>_integral_gain``, the DiscreteTimeIntegrator ``<name>_integral``
    and ``<name>_sum``.

    Returns:
      The input ports of the commanded state [q_c; v_c] (2n) and the measured
      state [q; v] (2n), and the output port of u (n).
    """
    n = kp.size
    negate = builder.AddNamedSystem(f"{name}_negate_state", Gain(-1.0, 2 * n))
    error = builder.AddNamedSystem(f"{name}_error", Adder(2, 2 * n))
    builder.Connect(negate.get_output_port(), error.get_input_port(1))
    pd = builder.AddNamedSystem(
        f"{name}_pd", MatrixGain(np.hstack([np.diag(kp), np.diag(kd)]))
    )
    gain = builder.AddNamedSystem(
        f"{name}_integral_gain", MatrixGain(np.hstack([np.diag(ki), np.zeros((n, n))]))
    )
    integral = builder.AddNamedSystem(
        f"{name}_integral", DiscreteTimeIntegrator(n, time_step)
    )
    total = builder.AddNamedSystem(f"{name}_sum", Adder(2, n))
    for a, b in (
        (error.get_output_port(), pd.get_input_port()),
        (error.get_output_port(), gain.get_input_port()),
        (gain.get_output_port(), integral.get_input_port()),
        (pd.get_output_port(), total.get_input_port(0)),
        (integral.get_output_port(), total.get_input_port(1)),
    ):
        builder.Connect(a, b)
    return error.get_input_port(0), negate.get_input_port(), total.get_output_port()


class _ComputedTorqueController(Diagram):
    """The diagram both controllers share (see the module docstring)."""

    def __init__(
        self,
        *,
        dynamics: RobotModel,
        friction: RobotModel | None,
        correction: Diagram | None,
        deflection: DeflectionCompensation | None,
        bandwidth: float,
        kp: object,
        kd: object,
        ki: object,
        v_eps: float,
        time_step: float,
    ) -> None:
        Diagram.__init__(self)
        n = dynamics.n_joints
        defaults = default_gains(n, bandwidth)
        gains = [
            per_joint(d if g is None else g, n, name, unit)
            for g, d, name, unit in zip(
                (kp, kd, ki), defaults, ("kp", "kd", "ki"),
                ("1/s^2", "1/s", "1/s^3"), strict=True,
            )
        ]  # fmt: skip
        if not (math.isfinite(time_step) and time_step >= 0):
            raise ValueError(f"time_step: expected >= 0 s, found {time_step}")
        builder = DiagramBuilder()
        # A continuous plant has no coupled motor: its inertia's diagonal.
        rigid = coupled_rotors_on_diagonal(
            dataclasses.replace(dynamics, compliance=None)
        )
        plant, _ = MakePlant(rigid, visual=False)
        if time_step > 0:  # a sampled PID on the reference acceleration
            feedback_in, measured, feedback = AddSampledPid(
                builder, kp=gains[0], kd=gains[1], ki=gains[2], time_step=time_step,
                name="feedback",
            )  # fmt: skip
            servo = builder.AddNamedSystem(
                "inverse_dynamics",
                InverseDynamics(
                    plant, InverseDynamics.InverseDynamicsMode.kInverseDynamics
                ),
            )
            total = builder.AddNamedSystem("reference_acceleration", Adder(2, n))
            builder.Connect(feedback, total.get_input_port(1))
            builder.Connect(
                total.get_output_port(), servo.get_input_port_desired_acceleration()
            )
            states = [feedback_in]
            reference = total.get_input_port(0)
            estimated = [servo.get_input_port_estimated_state(), measured]
            control = servo.get_output_port_generalized_force()
        else:
            servo = builder.AddNamedSystem(
                "inverse_dynamics",
                InverseDynamicsController(
                    plant, gains[0], gains[2], gains[1], has_reference_acceleration=True
                ),
            )
            states = [servo.get_input_port_desired_state()]
            reference = servo.get_input_port_desired_acceleration()
            estimated = [servo.get_input_port_estimated_state()]
            control = servo.get_output_port_control()
        self._plant = plant  # the controller holds a non-owning pointer to it
        state = acceleration = None  # the commanded motion so far (None: input)
        for name, stage, outs in (
            ("kinematic_correction", correction, "corrected"),
            ("deflection_compensation", deflection, "commanded"),
        ):
            if stage is None:
                continue
            builder.AddNamedSystem(name, stage)
            ins = (stage.GetInputPort("desired_state"),
                   stage.GetInputPort("desired_acceleration"))  # fmt: skip
            if state is None:
                builder.ExportInput(ins[0], "desired_state")
                builder.ExportInput(ins[1], "desired_acceleration")
            else:
                builder.Connect(state, ins[0])
                builder.Connect(acceleration, ins[1])
            state = stage.GetOutputPort(f"{outs}_state")
            acceleration = stage.GetOutputPort(f"{outs}_acceleration")
        for i, port in enumerate(states):
            if state is not None:
                builder.Connect(state, port)
            elif i == 0:
                builder.ExportInput(port, "desired_state")
            else:
                builder.ConnectInput("desired_state", port)
        if state is None:
            builder.ExportInput(reference, "desired_acceleration")
        else:
            builder.Connect(acceleration, reference)
        builder.ExportInput(estimated[0], "estimated_state")
        for port in estimated[1:]:
            builder.ConnectInput("estimated_state", port)
        if deflection is not None:
            builder.ExportInput(deflection.GetInputPort("payload_mass"), "payload_mass")
        torques: list[OutputPort] = [control]
        if friction is not None:
            ff_state, ff_effort = AddFrictionFeedforward(builder, friction, v_eps=v_eps)
            if state is None:
                builder.ConnectInput("desired_state", ff_state)
            else:
                builder.Connect(state, ff_state)
            torques.append(ff_effort)
        if deflection is not None:  # the payload beyond the rigid-body model's
            torques.append(deflection.GetOutputPort("payload_effort"))
        if len(torques) > 1:
            total = builder.AddNamedSystem("actuation_sum", Adder(len(torques), n))
            for i, port in enumerate(torques):
                builder.Connect(port, total.get_input_port(i))
            torques = [total.get_output_port()]
        builder.ExportOutput(torques[0], "actuation")
        if state is None:
            passthrough = builder.AddNamedSystem("commanded", Gain(1.0, 2 * n))
            builder.ConnectInput("desired_state", passthrough.get_input_port())
            state = passthrough.get_output_port()
        builder.ExportOutput(state, "commanded_state")
        builder.BuildInto(self)

    @classmethod
    def AddToBuilder(
        cls,
        builder: DiagramBuilder,
        *,
        desired_state: OutputPort | None = None,
        desired_acceleration: OutputPort | None = None,
        estimated_state: OutputPort | None = None,
        payload_mass: OutputPort | None = None,
        name: str = "controller",
        **options: object,
    ) -> _ComputedTorqueController:
        """Adds the controller (``options`` as its constructor) to ``builder``
        under ``name`` and connects the given ports to its inputs of the same
        names (``payload_mass`` only to a controller with the deflection
        layer); returns it."""
        controller = builder.AddNamedSystem(name, cls(**options))
        controller.ConnectInputs(
            builder,
            desired_state=desired_state,
            desired_acceleration=desired_acceleration,
            estimated_state=estimated_state,
            payload_mass=payload_mass,
        )
        return controller

    def ConnectInputs(
        self,
        builder: DiagramBuilder,
        *,
        desired_state: OutputPort | None = None,
        desired_acceleration: OutputPort | None = None,
        estimated_state: OutputPort | None = None,
        payload_mass: OutputPort | None = None,
    ) -> None:
        """Connects the given output ports of ``builder``'s systems to this
        controller's inputs of the same names (the controller already added
        to ``builder``; ``payload_mass`` only with the deflection layer)."""
        ports = {
            "desired_state": desired_state,
            "desired_acceleration": desired_acceleration,
            "estimated_state": estimated_state,
            "payload_mass": payload_mass,
        }
        for port_name, port in ports.items():
            if port is not None:
                builder.Connect(port, self.GetInputPort(port_name))


class NominalController(_ComputedTorqueController):
    __doc__ = """Computed-torque joint control on the nominal model: what a robot runs
    before calibration and identification.

    The inverse dynamics and the friction feedforward use ``nominal``'s
    parameters; the desired joint program is tracked as given. Gains: kp, kd,
    ki in 1/s^2, 1/s, 1/s^3 (scalars or (n,)); default a triple closed-loop
    pole at -``bandwidth`` rad/s (3 w^2, 3 w, w^3).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import NominalController
    >>> controller = NominalController(nominal=load_robot("rv3sb"), bandwidth=20.0)
    >>> controller.num_input_ports() > 0, controller.num_output_ports() > 0
    (True, True)
""" + _PORT_BLOCK.format(name="NominalController")

    def __init__(
        self,
        *,
        nominal: RobotModel,
        bandwidth: float = DEFAULT_BANDWIDTH,
        kp: object = None,
        kd: object = None,
        ki: object = None,
        friction_feedforward: bool = True,
        v_eps: float = DEFAULT_V_EPS,
        time_step: float = 0.0,
    ) -> None:
        require_rigid(
            nominal,
            "NominalController nominal",
            "use CalibratedCompensationController (deflection_compensation=True) or "
            "a rigid nominal model",
        )
        _checked(nominal, "nominal")
        super().__init__(
            dynamics=nominal,
            friction=nominal if friction_feedforward else None,
            correction=None,
            deflection=None,
            bandwidth=bandwidth,
            kp=kp,
            kd=kd,
            ki=ki,
            v_eps=v_eps,
            time_step=time_step,
        )

    @classmethod
    def from_config(
        cls,
        config: ComputedTorqueSettings,
        *,
        nominal: RobotModel,
        v_eps: float = DEFAULT_V_EPS,
        time_step: float = 0.0,
    ) -> NominalController:
        """The controller of ``config`` (bandwidth in rad/s, gains in 1/s^2,
        1/s, 1/s^3, friction feedforward) on the ``nominal`` model, with the
        smooth-sign width ``v_eps`` (rad/s or m/s) and ``time_step`` s (0: a
        continuous controller; else its integral action sampled at that
        step).

        Example::

            NominalController.from_config(
                InverseDynamicsControllerConfig(bandwidth=10.0), nominal=robot
            )
        """
        return cls(
            nominal=nominal,
            bandwidth=config.bandwidth,
            kp=config.kp,
            kd=config.kd,
            ki=config.ki,
            friction_feedforward=config.friction_feedforward,
            v_eps=v_eps,
            time_step=time_step,
        )


class CalibratedCompensationController(_ComputedTorqueController):
    __doc__ = """Computed-torque joint control with the identified dynamics: the
    inverse dynamics on a plant of ``identified`` (physically consistent
    standard parameters) and its identified fv, fc in the friction feedforward.

    Layers (each can be switched off to show what it buys): the kinematic
    correction when ``calibrated`` is given and ``kinematic_correction``
    (online, updated every ``correction_period`` s; with the ``program`` the
    ``desired_state`` input streams, known when built, the updates are solved
    ahead, unless it has more than ``MAX_PRESOLVED_UPDATES``; leave
    ``calibrated`` None to feed a program corrected offline by
    :func:`corrected_program`), the
    ``deflection_compensation`` when a model has elastic joints (the compliance
    of ``calibrated``, else ``identified``, else ``nominal``, with that model's
    gravity model and payload centre of mass, its dynamics taken from
    ``identified`` if it has none; the pre-deflection follows the
    ``payload_mass`` input), ``identified_dynamics`` (else the nominal model's
    inertial parameters), ``identified_friction`` (else the nominal fv, fc),
    ``friction_feedforward`` (none at all, else at the commanded motor-side
    velocity). Gains as :class:`NominalController`.

    Raises:
      ValueError: models of different joint counts, without dynamics or not
        physical; an elastic model with ``deflection_compensation=False`` (the
        controller would assume rigid joints).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import CalibratedCompensationController
    >>> robot = load_robot("rv3sb")
    >>> controller = CalibratedCompensationController(
    ...     nominal=robot, identified=robot, calibrated=robot)
    >>> controller.num_output_ports() > 0
    True
""" + _PORT_BLOCK.format(name="CalibratedCompensationController")

    def __init__(
        self,
        *,
        nominal: RobotModel,
        identified: RobotModel,
        calibrated: RobotModel | None = None,
        kinematic_correction: bool = True,
        deflection_compensation: bool = True,
        correction_period: float = 0.01,
        program: Trajectory | None = None,
        identified_dynamics: bool = True,
        identified_friction: bool = True,
        friction_feedforward: bool = True,
        bandwidth: float = DEFAULT_BANDWIDTH,
        kp: object = None,
        kd: object = None,
        ki: object = None,
        v_eps: float = DEFAULT_V_EPS,
        time_step: float = 0.0,
    ) -> None:
        if identified.n_joints != nominal.n_joints:
            raise ValueError(
                f"identified robot '{identified.name}' has {identified.n_joints} "
                f"joints, the nominal '{nominal.name}' {nominal.n_joints}"
            )
        _checked(nominal, "nominal")
        _checked(identified, "identified")
        friction = identified if identified_friction else nominal
        correction = None
        if calibrated is not None and kinematic_correction:
            pair = {"nominal": nominal, "calibrated": calibrated}
            if program is not None and presolvable(program, correction_period):
                correction = PresolvedTargetCorrection(
                    **pair, program=program, period=correction_period
                )
            else:
                correction = JointTargetCorrection(**pair, period=correction_period)
        deflection = None
        elastic = deflection_model(nominal, identified, calibrated)
        if elastic is not None and not deflection_compensation:
            what = next(
                w
                for w, m in zip(
                    ("calibrated", "identified", "nominal"),
                    (calibrated, identified, nominal),
                    strict=True,
                )
                if is_elastic(m)
            )
            require_rigid(
                elastic,
                f"CalibratedCompensationController {what} with "
                "deflection_compensation=False",
                "set deflection_compensation=True",
            )
        dynamics = identified if identified_dynamics else nominal
        if elastic is not None:
            held = 0.0 if dynamics.payload is None else dynamics.payload.mass
            deflection = DeflectionCompensation(model=elastic, reference_mass=held)
        super().__init__(
            dynamics=dynamics,
            friction=friction if friction_feedforward else None,
            correction=correction,
            deflection=deflection,
            bandwidth=bandwidth,
            kp=kp,
            kd=kd,
            ki=ki,
            v_eps=v_eps,
            time_step=time_step,
        )

    @classmethod
    def from_config(
        cls,
        config: CompensationSettings,
        *,
        nominal: RobotModel,
        identified: RobotModel,
        calibrated: RobotModel | None = None,
        program: object = None,
        v_eps: float = DEFAULT_V_EPS,
        time_step: float = 0.0,
    ) -> CalibratedCompensationController:
        """The controller of ``config`` (its layers, bandwidth in rad/s,
        gains in 1/s^2, 1/s, 1/s^3, correction period in s) on the ``nominal``,
        ``identified`` and ``calibrated`` models, with the smooth-sign width
        ``v_eps`` (rad/s or m/s) and ``time_step`` s as the constructor.
        ``program``: what the ``desired_state`` input streams; a pydrake
        Trajectory lets the online correction be solved ahead when
        ``config.correction_ahead`` (anything else, e.g. a Fourier excitation,
        is not passed on). ``config.payload_mass`` and
        ``config.payload_mass_input`` concern what feeds the ``payload_mass``
        input, not the controller: the station's
        :func:`~rmdrake.systems.deflection.AddPayloadMassSource` reads them.

        Example::

            CalibratedCompensationController.from_config(
                CompensationControllerConfig(deflection_compensation=False),
                nominal=nominal,
                identified=identified,
                calibrated=calibrated,
                program=trajectory,
            )
        """
        ahead = config.correction_ahead and isinstance(program, Trajectory)
        return cls(
            nominal=nominal,
            identified=identified,
            calibrated=calibrated,
            kinematic_correction=config.kinematic_correction,
            deflection_compensation=config.deflection_compensation,
            correction_period=config.correction_period,
            program=program if ahead else None,
            identified_dynamics=config.identified_dynamics,
            identified_friction=config.identified_friction,
            friction_feedforward=config.friction_feedforward,
            bandwidth=config.bandwidth,
            kp=config.kp,
            kd=config.kd,
            ki=config.ki,
            v_eps=v_eps,
            time_step=time_step,
        )


def deflection_model(
    nominal: RobotModel,
    identified: RobotModel | None = None,
    calibrated: RobotModel | None = None,
) -> RobotModel | None:
    """The model whose compliance and gravity a deflection compensation uses:
    the first elastic one of ``calibrated``, ``identified``, ``nominal`` (with
    the dynamics of ``identified``, else ``nominal``, when it has none); None
    when all are rigid."""
    for model in (calibrated, identified, nominal):
        if is_elastic(model):
            if model.dynamics is None:
                donor = identified if identified is not None else nominal
                model = dataclasses.replace(model, dynamics=donor.dynamics)
            return model
    return None


def corrected_program(
    nominal: RobotModel,
    calibrated: RobotModel,
    program: Trajectory,
    *,
    sample_period: float = 0.01,
    payload_mass: float | None = None,
) -> PiecewisePolynomial:
    """A joint program planned on ``nominal``, filtered for ``calibrated``.

    The program (an (n, 1) pydrake Trajectory of joint positions in rad or m, at least
    twice differentiable) is sampled every ``sample_period`` s from its start to
    its end; each sample is corrected by
    :func:`rmdrake.compensation.correction.correct_joint_motion` (the calibrated tool
    at the
    corrected joints is where the nominal tool was, with the same twist), and the
    result is the cubic Hermite spline through the corrected angles and rates.
    When ``calibrated`` has elastic joints, the corrected (link-side) motion is
    then pre-deflected for a payload of ``payload_mass`` kg (None: the
    calibrated model's payload mass, 0 without one) by
    :func:`~rmdrake.systems.deflection.motor_motion` (its gravity model, else
    the nominal model's dynamics): the spline is then the motor-side motion,
    for a controller that does not pre-deflect again (rigid models). Feed it
    to a ``TrajectorySource`` (``output_derivative_order=2``) for the
    controller's desired state and acceleration.

    Raises:
      ValueError: a non-positive period, an unbounded program, or what
        :func:`~rmdrake.compensation.correction.correct_joint_motion` refuses.

    Example:

    >>> import numpy as np
    >>> from pydrake.trajectories import PiecewisePolynomial
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import corrected_program
    >>> robot = load_robot("rv3sb")
    >>> q = np.full((6, 2), 0.3)
    >>> program = PiecewisePolynomial.FirstOrderHold([0.0, 0.1], q)
    >>> corrected = corrected_program(robot, robot, program)
    >>> corrected.rows(), round(corrected.end_time(), 3)
    (6, 0.1)
    >>> bool(np.abs(corrected.value(0.05) - 0.3).max() < 1e-6)
    True
    """
    if not np.isfinite(sample_period) or sample_period <= 0:
        raise ValueError(f"sample_period: expected > 0 s, found {sample_period}")
    t0, t1 = program.start_time(), program.end_time()
    if not np.isfinite(t1):
        raise ValueError("program: expected a finite end time")
    count = max(2, int(np.ceil((t1 - t0) / sample_period)) + 1)
    t = np.linspace(t0, t1, count)
    q = np.array([program.value(ti).ravel() for ti in t])
    qd = np.array([program.EvalDerivative(ti, 1).ravel() for ti in t])
    qdd = np.array([program.EvalDerivative(ti, 2).ravel() for ti in t])
    filtered, qd_c, qdd_c = correct_joint_motion(nominal, calibrated, q, qd, qdd)
    q_c = filtered.q
    if is_elastic(calibrated):
        elastic = deflection_model(nominal, None, calibrated)
        q_c, qd_c, _ = motor_motion(elastic, q_c, qd_c, qdd_c, payload_mass)
    return PiecewisePolynomial.CubicHermite(t, q_c.T, qd_c.T)
