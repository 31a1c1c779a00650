"""Joint friction (viscous + Coulomb) of the simulated true robot.

MultibodyPlant has no Coulomb friction (URDF ``<dynamics friction>`` is ignored),
and in a discrete (SAP) plant its joint damping acts implicitly at the next
step's velocity, which biases identified rotor inertias by about time_step * fv.
So the plant's joint damping stays zero (see
:func:`rmdrake.model.plant.MakePlant`) and the friction is applied through the
plant's ``applied_generalized_force`` input:

* on a continuous plant by :class:`JointFriction`, the law fv v + fc s(v) with
  the exact or smooth sign s of :mod:`rmdrake.dynamics.friction`, and its two
  optional terms: an asymmetric Coulomb level fcn for negative velocity and a
  constant offset tau0 per joint;
* on a discrete plant by :func:`AddDiscretePlantFriction`, Drake's own
  systems: the Coulomb level as PD-controlled actuators the SAP solver applies
  implicitly (a linear transition of width v_eps instead of the tanh), the
  viscous term, asymmetry and offset explicitly from the step's state.

The offset is an effort the joint loses whatever its motion, so the logged
actuation exceeds the rigid-body effort by tau0, as the biased joint-torque
sensor or current loop of a real robot reports it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JointIndex
from pydrake.symbolic import Expression, MakeVectorVariable, if_then_else, tanh
from pydrake.systems.framework import (
    Context,
    Diagram,
    DiagramBuilder,
    InputPort,
    OutputPort,
)
from pydrake.systems.primitives import (
    AffineSystem,
    ConstantVectorSource,
    Gain,
    MatrixGain,
    Multiplexer,
    SymbolicVectorSystem,
)

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.model.robot import DYNAMIC_KEYS, RobotModel
from rmdrake.systems.joint_state import add_selector

_FV, _FC = DYNAMIC_KEYS.index("fv"), DYNAMIC_KEYS.index("fc")

__all__ = ["AddDiscretePlantFriction", "AddFrictionFeedforward", "JointFriction"]


class JointFriction(Diagram):
    """Viscous + Coulomb joint friction, as a generalized force on the plant.

    .. pydrake_system::

        name: JointFriction
        input_ports:
        - state
        output_ports:
        - generalized_force

    ::

                   ┌───────────────┐
        state ────►│ JointFriction │────► generalized_force
                   └───────────────┘

    The input is the plant state x = [q; v] (nq + nv), or, with ``input="v"``,
    the generalized velocities v alone (nv; the port is then named ``v``). The n
    friction joints' velocities are v_j = v[velocity_indices] (rad/s, or m/s
    for a prismatic joint). The output (nv, N m or N) is -(fv * v_j + fc *
    s(v_j)) (with ``fcn``: fc max(s, 0) + fcn min(s, 0) for the Coulomb part;
    plus ``tau0``) at ``velocity_indices`` and zero elsewhere, ready for the plant's
    ``applied_generalized_force`` input;
    s is sign(v) with ``exact_sign``, else tanh(v / v_eps) (the law of
    :func:`rmdrake.dynamics.friction.friction_torque`). The defaults nq = nv = n and
    ``velocity_indices`` = 0..n-1 fit a plant whose only joints are the n
    friction joints; :meth:`AddToBuilder` reads them from the plant.

    Parameters in the Context: one numeric parameter vector
    ``[fv (n, N m s/rad or N s/m); fc (n, N m or N); v_eps (1, rad/s or
    m/s); fcn (n, N m or N); tau0 (n, N m or N)]``, set and read with
    :meth:`SetFriction` and :meth:`GetFriction` (fv, fc, v_eps) and
    :meth:`GetExtraTerms` (fcn, tau0). ``exact_sign`` is structural
    (a constructor option).

    Inside, Drake's own systems: the parameters are a ConstantVectorSource
    (``parameters``), and the law a SymbolicVectorSystem (``law``) of [input;
    parameters], so a step of a simulation evaluates no Python. Drake 1.51's
    SymbolicVectorSystem aborts when a diagram with continuous state asks a
    stateless one for its derivatives, so the law carries one continuous state
    of derivative 0 (it costs the error-controlled integrator nothing).

    Example:

    >>> import numpy as np
    >>> from rmdrake.systems import JointFriction
    >>> friction = JointFriction(fv=np.array([1.0, 2.0]), fc=np.array([0.5, 0.5]))
    >>> context = friction.CreateDefaultContext()
    >>> _ = friction.get_input_port().FixValue(context, [0.0, 0.0, 1.0, -1.0])  # [q; v]
    >>> friction.get_output_port().Eval(context).round(3).tolist()  # -(fv v + fc s(v))
    [-1.5, 2.5]
    """

    def __init__(
        self,
        *,
        fv: np.ndarray,
        fc: np.ndarray,
        v_eps: float = DEFAULT_V_EPS,
        exact_sign: bool = False,
        fcn: np.ndarray | None = None,
        tau0: np.ndarray | None = None,
        input: str = "state",
        velocity_indices: Sequence[int] | None = None,
        num_positions: int | None = None,
        num_velocities: int | None = None,
    ) -> None:
        """Args:
        fv: (n,) viscous coefficients, N m s/rad or N s/m, >= 0.
        fc: (n,) Coulomb coefficients, N m or N, >= 0.
        v_eps: smooth-sign width, rad/s or m/s (> 0; unused with
          ``exact_sign``).
        exact_sign: use sign(v) instead of tanh(v / v_eps).
        fcn: (n,) Coulomb levels for negative velocity, N m or N, >= 0
          (default fc: symmetric).
        tau0: (n,) constant offsets, N m or N (default 0).
        input: ``"state"`` (x = [q; v]) or ``"v"``.
        velocity_indices: (n,) indices of the friction joints in v.
        num_positions, num_velocities: nq and nv of the plant (default n).
        """
        super().__init__()
        fv = as_finite_array(fv, "fv", (None,))
        n = fv.shape[0]
        fc = as_finite_array(fc, "fc", (n,))
        fcn = fc if fcn is None else as_finite_array(fcn, "fcn", (n,))
        tau0 = np.zeros(n) if tau0 is None else as_finite_array(tau0, "tau0", (n,))
        _check_friction(fv, fc, v_eps, fcn)
        if input not in ("state", "v"):
            raise ValueError(f"input: expected 'state' or 'v', found {input!r}")
        nq = n if num_positions is None else int(num_positions)
        nv = n if num_velocities is None else int(num_velocities)
        idx = np.arange(n) if velocity_indices is None else np.array(velocity_indices)
        if (
            idx.shape != (n,)
            or not np.issubdtype(idx.dtype, np.integer)
            or np.unique(idx).size != n
            or (n and (idx.min() < 0 or idx.max() >= nv))
        ):
            raise ValueError(
                f"velocity_indices: expected {n} distinct indices in 0..{nv - 1}, "
                f"found {idx.tolist()}"
            )
        self._n = n
        self._exact = bool(exact_sign)
        self._velocity_indices = idx
        first = nq if input == "state" else 0
        size = nq + nv if input == "state" else nv
        u = MakeVectorVariable(size, input)
        p = MakeVectorVariable(4 * n + 1, "friction")
        zero = Expression(0.0)
        out = [zero] * nv
        for j, i in enumerate(idx):
            v = u[first + i]
            if self._exact:  # sign(v), 0 at rest
                s = if_then_else(v > 0, 1.0, if_then_else(v < 0, -1.0, 0.0))
            else:
                s = tanh(v / p[2 * n])
            level = if_then_else(s > 0, p[n + j], p[2 * n + 1 + j])  # fc or fcn
            out[i] = -(p[j] * v + level * s + p[3 * n + 1 + j])
        constant = MakeVectorVariable(1, "constant")
        builder = DiagramBuilder()
        law = builder.AddNamedSystem(
            "law",
            SymbolicVectorSystem(
                state=constant,
                input=np.concatenate([u, p]),
                dynamics=[zero],
                output=out,
            ),
        )
        self._parameters = builder.AddNamedSystem(
            "parameters",
            ConstantVectorSource(np.concatenate([fv, fc, [float(v_eps)], fcn, tau0])),
        )
        inputs = builder.AddNamedSystem("inputs", Multiplexer([size, 4 * n + 1]))
        builder.ExportInput(inputs.get_input_port(0), input)
        builder.Connect(self._parameters.get_output_port(), inputs.get_input_port(1))
        builder.Connect(inputs.get_output_port(), law.get_input_port())
        builder.ExportOutput(law.get_output_port(), "generalized_force")
        builder.BuildInto(self)

    @staticmethod
    def AddToBuilder(
        builder: DiagramBuilder,
        plant: MultibodyPlant,
        *,
        fv: np.ndarray,
        fc: np.ndarray,
        v_eps: float = DEFAULT_V_EPS,
        exact_sign: bool = False,
        fcn: np.ndarray | None = None,
        tau0: np.ndarray | None = None,
        name: str = "friction",
        joints: Sequence[str | JointIndex] | None = None,
    ) -> JointFriction:
        """Adds a JointFriction named ``name`` to ``builder`` and connects
        plant.state -> friction -> plant.applied_generalized_force.

        Args:
          builder: the diagram builder holding the (finalized) ``plant``.
          plant: the MultibodyPlant whose joints have the friction.
          fv, fc, v_eps, exact_sign, fcn, tau0: as in the constructor (per
            joint, in the order of ``joints``).
          name: the system's name in the diagram.
          joints: the friction joints (names or JointIndex), one per entry of
            ``fv``; default every single-dof joint of the plant, in JointIndex
            order (for :func:`rmdrake.model.plant.MakePlant`: joint1 .. jointn).

        Returns:
          The added system.

        Raises:
          ValueError: joint count mismatch, or a joint with other than 1 dof.
        """
        if joints is None:
            chosen = [
                plant.get_joint(i)
                for i in plant.GetJointIndices()
                if plant.get_joint(i).num_velocities() == 1
            ]
        else:
            chosen = [
                plant.GetJointByName(j) if isinstance(j, str) else plant.get_joint(j)
                for j in joints
            ]
        n = np.size(fv)
        if len(chosen) != n:
            raise ValueError(
                f"joints: expected {n} friction joints (one per fv entry), found "
                f"{len(chosen)}: {[j.name() for j in chosen]}"
            )
        for joint in chosen:
            if joint.num_velocities() != 1:
                raise ValueError(
                    f"joints: expected single-dof joints, found '{joint.name()}' "
                    f"with {joint.num_velocities()} velocities"
                )
        friction = builder.AddNamedSystem(
            name,
            JointFriction(
                fv=fv,
                fc=fc,
                v_eps=v_eps,
                exact_sign=exact_sign,
                fcn=fcn,
                tau0=tau0,
                velocity_indices=[j.velocity_start() for j in chosen],
                num_positions=plant.num_positions(),
                num_velocities=plant.num_velocities(),
            ),
        )
        builder.Connect(plant.get_state_output_port(), friction.get_input_port())
        builder.Connect(
            friction.get_output_port(),
            plant.get_applied_generalized_force_input_port(),
        )
        return friction

    @property
    def n_joints(self) -> int:
        """Number of friction joints n."""
        return self._n

    @property
    def velocity_indices(self) -> np.ndarray:
        """(n,) indices of the friction joints in the generalized velocities."""
        return self._velocity_indices.copy()

    @property
    def exact_sign(self) -> bool:
        """True when the Coulomb term uses sign(v) instead of tanh(v / v_eps)."""
        return self._exact

    def SetFriction(
        self,
        context: Context,
        *,
        fv: np.ndarray | None = None,
        fc: np.ndarray | None = None,
        v_eps: float | None = None,
        fcn: np.ndarray | None = None,
        tau0: np.ndarray | None = None,
    ) -> None:
        """Sets any of the friction parameters in ``context`` (units as above;
        without ``fcn``, a symmetric law (fcn = fc) stays symmetric and an
        asymmetric one keeps its fcn)."""
        old_fv, old_fc, old_eps = self.GetFriction(context)
        old_fcn, old_tau0 = self.GetExtraTerms(context)
        n = self._n
        fv = old_fv if fv is None else as_finite_array(fv, "fv", (n,))
        fc = old_fc if fc is None else as_finite_array(fc, "fc", (n,))
        v_eps = old_eps if v_eps is None else float(v_eps)
        if fcn is None:  # a symmetric law stays symmetric
            fcn = fc if np.array_equal(old_fcn, old_fc) else old_fcn
        fcn = as_finite_array(fcn, "fcn", (n,))
        tau0 = old_tau0 if tau0 is None else as_finite_array(tau0, "tau0", (n,))
        _check_friction(fv, fc, v_eps, fcn)
        self._parameters.get_mutable_source_value(
            self.GetMutableSubsystemContext(self._parameters, context)
        ).SetFromVector(np.concatenate([fv, fc, [v_eps], fcn, tau0]))

    def GetFriction(self, context: Context) -> tuple[np.ndarray, np.ndarray, float]:
        """(fv, fc, v_eps) from ``context`` (this system's)."""
        p = self._values(context)
        n = self._n
        return p[:n].copy(), p[n : 2 * n].copy(), float(p[2 * n])

    def GetExtraTerms(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        """(fcn, tau0) from ``context`` (this system's), N m or N."""
        p = self._values(context)
        n = self._n
        return p[2 * n + 1 : 3 * n + 1].copy(), p[3 * n + 1 :].copy()

    def _values(self, context: Context) -> np.ndarray:
        """The parameter vector [fv; fc; v_eps; fcn; tau0] in ``context``."""
        sub = self.GetSubsystemContext(self._parameters, context)
        return self._parameters.get_source_value(sub).get_value()


def _check_friction(
    fv: np.ndarray, fc: np.ndarray, v_eps: float, fcn: np.ndarray
) -> None:
    for name, value in (("fv", fv), ("fc", fc), ("fcn", fcn)):
        if np.any(value < 0):
            j = int(np.flatnonzero(value < 0)[0])
            raise ValueError(
                f"{name}: expected >= 0 for every joint, found {value[j]} for "
                f"joint {j + 1}"
            )
    if not np.isfinite(v_eps) or v_eps <= 0:
        raise ValueError(
            f"v_eps: expected a positive width in rad/s or m/s, found {v_eps}"
        )


def AddFrictionFeedforward(
    builder: DiagramBuilder, model: RobotModel, *, v_eps: float
) -> tuple[InputPort, OutputPort]:
    """Adds the friction feedforward of a joint controller: ``model``'s
    friction law (fv, fc, and fcn and tau0 where it has them; smooth sign of
    width ``v_eps``) at a commanded state [q_c; v_c], as the effort the
    actuators must add (N m or N). Systems ``friction_feedforward``
    (:class:`JointFriction`) and ``negate_friction``.

    Returns:
      (the state input to connect, the effort output to add to the actuation).

    Example:

    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import AddFrictionFeedforward
    >>> builder = DiagramBuilder()
    >>> robot = load_robot("rv3sb")
    >>> state_in, effort_out = AddFrictionFeedforward(builder, robot, v_eps=1e-3)
    >>> state_in.size(), effort_out.size()
    (12, 6)
    """
    n = model.n_joints
    dyn = model.dynamics
    friction = builder.AddNamedSystem(
        "friction_feedforward",
        JointFriction(
            fv=dyn[:, _FV],
            fc=dyn[:, _FC],
            v_eps=v_eps,
            input="state",
            fcn=model.fcn,
            tau0=model.tau0,
        ),
    )
    negate = builder.AddNamedSystem("negate_friction", Gain(-1.0, n))
    builder.Connect(friction.get_output_port(), negate.get_input_port())
    return friction.get_input_port(), negate.get_output_port()


def AddDiscretePlantFriction(
    builder: DiagramBuilder, plant: MultibodyPlant, model: RobotModel, S: np.ndarray
) -> tuple[InputPort, OutputPort]:
    """The joint friction of a discrete ``plant`` of ``model`` built by
    :func:`rmdrake.model.plant.MakePlant` with ``coulomb_width``, in Drake's
    own systems (no Python system is evaluated at each step):

    * the Coulomb level (fc + fcn) / 2: the plant's ``joint<j>_coulomb``
      actuators, applied implicitly by SAP; their desired state is the
      ConstantVectorSource ``coulomb_desired_state`` (zero);
    * the viscous term, the asymmetry and the offset: the stateless
      AffineSystem ``viscous_friction``, -fv v + (fcn - fc) / 2 - tau0 at each
      joint's velocity index, into plant.applied_generalized_force (explicit:
      the logged velocity is the one it used);
    * the motor actuators 0..n-1 take the controller's effort through the
      MatrixGain ``motor_actuation`` (zero to the Coulomb actuators), and
      ``motor_torque`` picks their net actuation, the torque a joint-torque
      sensor reads;
    * coupled motors (the plant's ``motor<m>_joint<j>`` stages,
      :mod:`rmdrake.model.plant`): their viscous friction -fvm s on every
      stage (s the rotor's speed, the sum of its stages' rates) in
      ``viscous_friction``, and their Coulomb actuators' desired velocity,
      minus the other stages' rates at the step's state (the MatrixGain
      ``motor_coulomb_desired_state``), so each applies clamp(-kd s, -fcm,
      fcm) with this step's own rate (implicit) and the others' last.

    Args:
      builder: the builder holding the finalized ``plant``.
      plant: the discrete MultibodyPlant.
      model: the robot it was built from (fv, fc, fcn, tau0).
      S: the (2n, nq + nv) joint state selector of its joints joint1..n
        (:func:`rmdrake.systems.joint_state.joint_state_selector`).

    Returns:
      (the motor actuation input (n), the motor torque output (n)): connect
      the controller's efforts to the first and read the joint torques from
      the second.
    """
    n = S.shape[0] // 2
    nq, nv = plant.num_positions(), plant.num_velocities()
    dyn = model.dynamics
    fc = dyn[:, _FC]
    fcn = fc if model.fcn is None else model.fcn
    tau0 = np.zeros(n) if model.tau0 is None else model.tau0
    rows = np.argmax(S[n:, nq:], axis=1)  # each joint's velocity index
    D = np.zeros((nv, nq + nv))
    D[rows, nq + rows] = -dyn[:, _FV]
    stages = _coupled_stages(plant, model)
    for m, vs in stages:  # the rotor's viscous friction on each of its stages
        fvm = model.motor_terms[model.coupled_motors.index(m), 1]
        D[np.ix_(vs, nq + vs)] -= fvm
    y0 = np.zeros(nv)
    y0[rows] = 0.5 * (fcn - fc) - tau0
    viscous = builder.AddNamedSystem(
        "viscous_friction",
        AffineSystem(
            np.zeros((0, 0)),
            np.zeros((0, nq + nv)),
            np.zeros(0),
            np.zeros((nv, 0)),
            D,
            y0,
        ),
    )
    builder.Connect(plant.get_state_output_port(), viscous.get_input_port())
    builder.Connect(
        viscous.get_output_port(), plant.get_applied_generalized_force_input_port()
    )
    m = plant.num_actuators() - n
    if m == 0:
        return plant.get_actuation_input_port(), plant.get_net_actuation_output_port()
    _connect_motor_coulomb(builder, plant, model, stages)
    instance = plant.GetModelInstanceByName(model.name)
    desired = plant.get_desired_state_input_port(instance)
    zero = builder.AddNamedSystem(
        "coulomb_desired_state", ConstantVectorSource(np.zeros(desired.size()))
    )
    builder.Connect(zero.get_output_port(), desired)
    to_motors = builder.AddNamedSystem("motor_actuation", MatrixGain(np.eye(n + m, n)))
    builder.Connect(to_motors.get_output_port(), plant.get_actuation_input_port())
    motor_torque = add_selector(
        builder, plant.get_net_actuation_output_port(), np.eye(n, n + m), "motor_torque"
    )
    return to_motors.get_input_port(), motor_torque


def _coupled_stages(
    plant: MultibodyPlant, model: RobotModel
) -> list[tuple[int, np.ndarray]]:
    """Per coupled motor m (0-based) built in ``plant``: (m, the velocity
    indices of its stages ``motor<m>_joint<j>``, in joint order)."""
    from rmdrake.model.plant import motor_joint_name

    out = []
    for m in model.coupled_motors:
        c = model.transmission.coupling[m]
        names = [motor_joint_name(m + 1, int(j) + 1) for j in np.flatnonzero(c)]
        if not plant.HasJointNamed(names[0]):
            continue  # a continuous plant has no coupled motors
        vs = [plant.GetJointByName(x).velocity_start() for x in names]
        out.append((m, np.array(vs)))
    return out


def _connect_motor_coulomb(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model: RobotModel,
    stages: list[tuple[int, np.ndarray]],
) -> None:
    """Connects the desired state of the coupled motors' Coulomb actuators
    (the ``<name>_motors`` instance): q_d = 0 (kp is 0), v_d of a stage =
    minus the other stages' rates of the same motor (docstring of
    :func:`AddDiscretePlantFriction`)."""
    name = f"{model.name}_motors"
    if not stages or not plant.HasModelInstanceNamed(name):
        return
    instance = plant.GetModelInstanceByName(name)
    port = plant.get_desired_state_input_port(instance)
    k = port.size() // 2
    if k == 0:
        return
    nq, nv = plant.num_positions(), plant.num_velocities()
    # The instance's PD actuators in actuator order: their joints' velocities.
    joints = [
        plant.get_joint_actuator(a).joint()
        for a in plant.GetJointActuatorIndices(instance)
    ]
    own = [j.velocity_start() for j in joints]
    G = np.zeros((2 * k, nq + nv))
    for r, v in enumerate(own):
        group = next(vs for _, vs in stages if v in vs)
        for other in group:
            if other != v:
                G[k + r, nq + other] = -1.0
    gain = builder.AddNamedSystem("motor_coulomb_desired_state", MatrixGain(G))
    builder.Connect(plant.get_state_output_port(), gain.get_input_port())
    builder.Connect(gain.get_output_port(), port)
