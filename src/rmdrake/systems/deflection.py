"""Deflection compensation of elastic joints, as a Drake system.

An elastic joint's encoder reads the motor side q_m; the link side q_l, which
puts the tool, sits at q_l = q_m + C tau(q_l) at rest under gravity and the
payload (:mod:`rmdrake.dynamics.compliance`). To move the link side along a desired
motion (q_l, v_l, a_l), the motor side is commanded the explicit
pre-deflection of that motion::

    q_m = q_l - C tau(q_l)
    v_m = v_l - C J v_l                     J = d tau / d q_l
    a_m = a_l - C (J a_l + dJ/dt v_l)

the time derivatives of q_m along the motion (quasi-static: the rate terms of
the spring's own dynamics are left to the feedback). The directional
derivatives are central differences of tau along the curve
``q(s) = q_l + s v_l + s^2/2 a_l`` at s = -h, 0, h, one vectorised call of
:func:`rmdrake.dynamics.compliance.gravity_torques`: ``(tau(h) - tau(-h)) / 2h = J v_l``
and ``(tau(h) - 2 tau(0) + tau(-h)) / h^2 = J a_l + d2tau[v_l, v_l]``, exact up
to O(h^2), with h chosen so that the curve moves ``_STEP`` = 1e-3 rad (or m)
at most: a relative truncation error of about 1e-7 on terms that are
themselves C J ~ 1e-3 of the motion. :func:`motor_motion` is the same map on
arrays of poses.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    InputPort,
    LeafSystem,
    OutputPort,
    ValueProducer,
)
from pydrake.systems.primitives import ConstantVectorSource

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.compliance import (
    GravityModel,
    gravity_torques,
    joint_compliances,
    payload_masses,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "AddPayloadMassSource",
    "DeflectionCompensation",
    "is_elastic",
    "motor_motion",
]

_STEP = 1e-3  # rad or m: the largest move of the finite-difference curve


def is_elastic(model: RobotModel | None) -> bool:
    """True when ``model`` has at least one elastic joint (stiffness > 0)."""
    return model is not None and bool(np.any(joint_compliances(model) > 0))


def motor_motion(
    model: RobotModel | GravityModel,
    q_l: object,
    v_l: object,
    a_l: object,
    payload_mass: object = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor-side motion (q_m, v_m, a_m) that holds the link side on the motion
    (q_l, v_l, a_l), see the module docstring.

    Args:
      model: the elastic robot (its ``dynamics`` and, for a payload > 0, its
        ``payload`` centre of mass are used).
      q_l, v_l, a_l: (N, n) link-side positions (rad or m), rates (rad/s or
        m/s), accelerations (rad/s^2 or m/s^2); or (n,) each.
      payload_mass: kg at the tool, as
      :func:`rmdrake.dynamics.compliance.gravity_torques`.

    Returns:
      (q_m, v_m, a_m), each of the shape of ``q_l``; equal to the inputs on a
      rigid robot.
    """
    q = as_finite_array(q_l, "q_l")
    single = q.ndim == 1
    q = np.atleast_2d(q)
    v = as_finite_array(v_l, "v_l", q.shape if not single else (q.shape[1],))
    a = as_finite_array(a_l, "a_l", v.shape)
    v, a = np.atleast_2d(v), np.atleast_2d(a)
    robot = model.model if isinstance(model, GravityModel) else model
    c = joint_compliances(robot)
    if not np.any(c):
        out = (q.copy(), v.copy(), a.copy())
    else:
        N = q.shape[0]
        m = payload_masses(robot, payload_mass, N)
        speed = np.maximum(np.abs(v).max(axis=1), np.sqrt(np.abs(a).max(axis=1)))
        h = (_STEP / np.maximum(speed, 1e-12))[:, None]  # s, per pose
        curve = [q - h * v + 0.5 * h * h * a, q, q + h * v + 0.5 * h * h * a]
        tau = gravity_torques(model, np.vstack(curve), np.tile(m, 3))
        lo, mid, hi = tau[:N], tau[N : 2 * N], tau[2 * N :]
        out = (
            q - c * mid,
            v - c * (hi - lo) / (2 * h),
            a - c * (hi - 2 * mid + lo) / (h * h),
        )
    return tuple(x[0] for x in out) if single else out


class DeflectionCompensation(LeafSystem):
    """Pre-deflects a desired link-side joint motion for elastic joints.

    .. pydrake_system::

        name: DeflectionCompensation
        input_ports:
        - desired_state
        - desired_acceleration
        - payload_mass
        output_ports:
        - commanded_state
        - commanded_acceleration
        - payload_effort

    ``desired_state`` [q_l; v_l] (2n; rad, rad/s, or m, m/s on a prismatic
    joint) and ``desired_acceleration`` a_l (n; rad/s^2 or m/s^2): the
    link-side motion to achieve; ``payload_mass`` (1; kg at the tool, centre of
    mass at the model's ``payload.com``; >= 0, and 0 on a robot without a
    payload entry); ``commanded_state`` [q_m; v_m] (2n) and
    ``commanded_acceleration`` a_m (n): the motor-side motion to command (see
    the module docstring), computed together into a cache entry (one call of
    the gravity model per context change); ``payload_effort`` (n; N m or N):
    the effort that holds the payload mass beyond ``reference_mass`` at q_l,
    for a controller whose rigid-body model holds ``reference_mass`` (so a
    module picked up mid-task is fed forward as well as pre-deflected). Direct
    feedthrough from every input; no state.

    Args:
      model: the robot with ``compliance`` (at least one elastic joint) and
        ``dynamics`` (its gravity model).
      reference_mass: payload mass (kg) the controller's inverse dynamics
        already holds.

    Raises:
      ValueError: a rigid model or one without dynamics. At evaluation, a
        negative payload mass, or a mass > 0 on a model without a payload.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import DeflectionCompensation
    >>> robot = load_robot("demo_rh_elastic")
    >>> compensation = DeflectionCompensation(model=robot)
    >>> context = compensation.CreateDefaultContext()
    >>> q = np.array([0.0, 0.5, 0.5, 0.0, 0.5, 0.0])
    >>> ports = ("desired_state", "desired_acceleration", "payload_mass")
    >>> values = (np.concatenate([q, np.zeros(6)]), np.zeros(6), [0.0])
    >>> for name, value in zip(ports, values, strict=True):
    ...     _ = compensation.GetInputPort(name).FixValue(context, value)
    ...
    >>> q_m = compensation.GetOutputPort("commanded_state").Eval(context)[:6]
    >>> bool(np.abs(q_m - q).max() > 0)  # the motors lead the links by the sag
    True
    """

    def __init__(self, *, model: RobotModel, reference_mass: float = 0.0) -> None:
        super().__init__()
        if not is_elastic(model):
            raise ValueError(
                f"model: robot '{model.name}' has no elastic joint (compliance "
                "stiffness > 0): nothing to compensate"
            )
        if model.dynamics is None:
            raise ValueError(
                f"model: robot '{model.name}' has no 'dynamics' section: the "
                "deflection needs its gravity model"
            )
        n = model.n_joints
        self._gravity, self._n = GravityModel(model), n  # mass: the port's value
        self._x = self.DeclareVectorInputPort("desired_state", 2 * n)
        self._a = self.DeclareVectorInputPort("desired_acceleration", n)
        self._m = self.DeclareVectorInputPort("payload_mass", 1)
        self._cache = self.DeclareCacheEntry(
            "motor motion [q_m; v_m; a_m]",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(BasicVector(3 * n)),
                calc=self._calc_motion,
            ),
            {self.all_input_ports_ticket()},
        )
        ticket = {self._cache.ticket()}
        self.DeclareVectorOutputPort("commanded_state", 2 * n, self._calc_state, ticket)
        self.DeclareVectorOutputPort(
            "commanded_acceleration", n, self._calc_acceleration, ticket
        )
        self._reference = float(reference_mass)
        self.DeclareVectorOutputPort(
            "payload_effort",
            n,
            self._calc_payload_effort,
            {self.all_input_ports_ticket()},
        )

    def _calc_motion(self, context: Context, value: AbstractValue) -> None:
        n = self._n
        x = self._x.Eval(context)
        mass = float(self._m.Eval(context)[0])
        q, v, a = motor_motion(self._gravity, x[:n], x[n:], self._a.Eval(context), mass)
        value.get_mutable_value().SetFromVector(np.concatenate([q, v, a]))

    def _calc_payload_effort(self, context: Context, output: BasicVector) -> None:
        q = self._x.Eval(context)[: self._n]
        extra = float(self._m.Eval(context)[0]) - self._reference
        if extra == 0.0:
            output.SetFromVector(np.zeros(self._n))
            return
        tau = self._gravity(np.vstack([q, q]), np.array([1.0, 0.0]))
        output.SetFromVector(-extra * (tau[0] - tau[1]))  # holding, per kg x kg

    def _calc_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._cache.Eval(context).get_value()[: 2 * self._n])

    def _calc_acceleration(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._cache.Eval(context).get_value()[2 * self._n :])

    @classmethod
    def AddToBuilder(
        cls,
        builder: DiagramBuilder,
        *,
        model: RobotModel,
        desired_state: OutputPort | None = None,
        desired_acceleration: OutputPort | None = None,
        payload_mass: OutputPort | None = None,
        name: str = "deflection_compensation",
    ) -> DeflectionCompensation:
        """Adds the system to ``builder`` under ``name``, connects the given
        ports to its inputs of the same names, and returns it."""
        system = builder.AddNamedSystem(name, cls(model=model))
        for port_name, port in (
            ("desired_state", desired_state),
            ("desired_acceleration", desired_acceleration),
            ("payload_mass", payload_mass),
        ):
            if port is not None:
                builder.Connect(port, system.GetInputPort(port_name))
        return system


def AddPayloadMassSource(
    builder: DiagramBuilder,
    payload_mass: InputPort,
    *,
    model: RobotModel,
    mass: float | None = None,
    field: str = "payload_mass",
    name: str = "payload_mass",
) -> ConstantVectorSource:
    """Adds a ``ConstantVectorSource`` named ``name`` holding the payload mass
    (kg) and connects it to the ``payload_mass`` input port (of a
    :class:`DeflectionCompensation` or a controller exporting one).

    The value is a numeric parameter of the source's Context, so a user or an
    event can change it mid-task (picking up or putting down a load)::

        source.get_mutable_source_value(
            source.GetMyMutableContextFromRoot(root_context)
        ).SetFromVector([mass])

    Args:
      model: the robot being compensated (its payload entry is needed for a
        mass > 0).
      mass: kg; None = ``model``'s payload mass (0 without one).
      field: the name the error message gives the mass.

    Raises:
      ValueError: a negative or non-finite mass, or a mass > 0 on a robot
        without a payload entry (naming ``field``).

    Example:

    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import AddPayloadMassSource, DeflectionCompensation
    >>> robot = load_robot("demo_rh_elastic")
    >>> builder = DiagramBuilder()
    >>> compensation = builder.AddSystem(DeflectionCompensation(model=robot))
    >>> port = compensation.GetInputPort("payload_mass")
    >>> source = AddPayloadMassSource(builder, port, model=robot, mass=5.0)
    >>> context = source.CreateDefaultContext()
    >>> source.get_name(), source.get_source_value(context).get_value().tolist()
    ('payload_mass', [5.0])
    """
    if mass is None:
        mass = 0.0 if model.payload is None else model.payload.mass
    mass = float(mass)
    if not np.isfinite(mass) or mass < 0:
        raise ValueError(f"{field}: expected a finite mass >= 0 kg, found {mass:g}")
    if mass > 0 and model.payload is None:
        raise ValueError(
            f"{field}: {mass:g} kg given, but robot '{model.name}' has no payload "
            "entry (its centre of mass on the tool)"
        )
    source = builder.AddNamedSystem(name, ConstantVectorSource([mass]))
    builder.Connect(source.get_output_port(), payload_mass)
    return source
