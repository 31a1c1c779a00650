"""Online kinematic correction of a streamed joint program, as a Drake system.

The program is planned on the nominal model; the system outputs the joint
motion that moves the CALIBRATED model's tool as the nominal tool moves. The
exact map q_c(q) and its rate map
(:func:`rmdrake.compensation.correction.point_motion_map`, motion_map for one
point) is solved at a fixed ``period`` (a periodic discrete update,
warm-started from the first-order model's prediction), and between updates
that first-order model around the last solution is used::

    G_k   = A(q_k)           (A = J_c(q_c,k)^+ J_n(q_k), motion_map's rate map)
    q_c   = G_k q + c_k,     c_k = q_c,k - G_k q_k
    v_c   = G_k v,   a_c = G_k a                 (equal tool twists)

where q_k is the program's position at the update and q_c,k its exact
correction (so q_c = q_c,k + G_k (q - q_k)). The
model's error grows with the program's motion since the update: on the RV-3SB
with mm-sized errors, a program at up to 0.7 rad/s and a 10 ms period, q_c is
within 5e-7 rad of the exact map (0.2 um at the tool), v_c within 1e-4 rad/s
and a_c within 2e-4 rad/s^2 (``tests/systems/test_controllers.py``). The
exact solve (one or two Gauss-Newton steps from the prediction) runs once
per period; an output evaluation is one matrix
product. Joints may be revolute (rad, rad/s, rad/s^2) or prismatic (m, m/s,
m/s^2), as the models' ``sigma`` says
(``tests/systems/test_correction.py`` checks a robot with both against its
Drake plants).

When the program is known as the diagram is built (a pydrake Trajectory, as a
station's :class:`~rmdrake.systems.station_sources.JointTrajectorySource`
streams it), :class:`PresolvedTargetCorrection` applies the same rule with
every update solved ahead in one vectorised solve, inside Drake's
``TrajectoryAffineSystem``: no Python callback in a simulation step, and the
same tool errors to 1 nm (``tests/systems/test_correction.py``).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)
from pydrake.systems.primitives import (
    Demultiplexer,
    Multiplexer,
    TrajectoryAffineSystem,
)
from pydrake.trajectories import PiecewisePolynomial, Trajectory

from rmdrake.compensation.correction import (
    motion_map,
    point_motion_map,
    require_same_robot,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "MAX_PRESOLVED_UPDATES",
    "JointTargetCorrection",
    "PresolvedTargetCorrection",
    "presolvable",
    "presolve_times",
]

MAX_PRESOLVED_UPDATES = 10_000
"""The most updates a :class:`PresolvedTargetCorrection` holds (100 s of
program at the default 10 ms period): Drake's trajectories of its maps take
some 8 kB an update on six joints."""


def _check_pair(nominal: RobotModel, calibrated: RobotModel, period: float) -> None:
    """ValueError unless the two robots have the same joints and period > 0."""
    require_same_robot(nominal, calibrated)
    if not np.isfinite(period) or period <= 0:
        raise ValueError(f"period: expected > 0 s, found {period}")


def presolve_times(program: Trajectory, period: float) -> np.ndarray:
    """(K + 1,) the update times k * ``period`` (s), k = 0..K, of a correction
    of ``program`` from t = 0: K the first at or after the program's end (it
    holds its last value beyond)."""
    K = max(0, math.ceil(program.end_time() / period - 1e-9))
    return period * np.arange(K + 1)


def presolvable(program: Trajectory, period: float) -> bool:
    """True when ``program``'s correction every ``period`` s has at most
    :data:`MAX_PRESOLVED_UPDATES` updates, so that
    :class:`PresolvedTargetCorrection` can solve them ahead."""
    return presolve_times(program, period).size <= MAX_PRESOLVED_UPDATES


class JointTargetCorrection(LeafSystem):
    """Corrects a nominal joint program for the calibrated kinematics.

    .. pydrake_system::

        name: JointTargetCorrection
        input_ports:
        - desired_state
        - desired_acceleration
        output_ports:
        - corrected_state
        - corrected_acceleration

    ``desired_state`` [q; v] (2n; rad, rad/s, or m, m/s for a prismatic
    joint) and ``desired_acceleration`` (n; rad/s^2 or m/s^2): the program on
    the nominal model; ``corrected_state`` [q_c; v_c]
    and ``corrected_acceleration`` a_c: the same tool motion on the calibrated
    model (see the module docstring for the rule). Context: numeric parameters
    the nominal and the calibrated MDH tables ((n+1) x 5 each, row-major);
    discrete state [c_k; G_k (n x n, row-major)] (c_k = 0 and G_k = I, no
    correction, before the first update), updated every
    ``period`` s from t = 0, at initialization, and on a forced discrete update
    (re-solve after changing the calibrated table, for instance).

    Args:
      nominal: the robot the program was planned on.
      calibrated: the calibrated robot (same joint count, types and limits).
      period: update period of the exact correction, s.

    Example:

    >>> from rmdrake import apply_deltas, load_robot
    >>> from rmdrake.systems import JointTargetCorrection
    >>> nominal = load_robot("rv3sb")
    >>> calibrated = apply_deltas(nominal, ["dd2"], [0.001])
    >>> correction = JointTargetCorrection(nominal=nominal, calibrated=calibrated)
    >>> correction.num_input_ports(), correction.get_output_port(0).size()
    (2, 12)
    """

    def __init__(
        self, *, nominal: RobotModel, calibrated: RobotModel, period: float = 0.01
    ) -> None:
        super().__init__()
        n = nominal.n_joints
        _check_pair(nominal, calibrated, period)
        # The tables come from the Context; the models lend their joint limits.
        self._n, self._nominal, self._calibrated = n, nominal, calibrated
        self._cache: tuple | None = None  # (tables' bytes, models)
        self._tables = [
            self.DeclareNumericParameter(BasicVector(m.table.ravel()))
            for m in (nominal, calibrated)
        ]
        self._x = self.DeclareVectorInputPort("desired_state", 2 * n)
        self._a = self.DeclareVectorInputPort("desired_acceleration", n)
        self._state = self.DeclareDiscreteState(np.r_[np.zeros(n), np.eye(n).ravel()])
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._update)
        self.DeclareForcedDiscreteUpdateEvent(self._update)
        self.DeclareVectorOutputPort(
            "corrected_state", 2 * n, self._calc_state, {self.all_sources_ticket()}
        )
        self.DeclareVectorOutputPort(
            "corrected_acceleration", n, self._calc_acceleration,
            {self.all_sources_ticket()},
        )  # fmt: skip

    def _models(
        self, T_n: np.ndarray, T_c: np.ndarray
    ) -> tuple[RobotModel, RobotModel]:
        """The nominal and calibrated models with the Context's tables, built
        again only when a table changed (an update runs every period)."""
        key = (T_n.tobytes(), T_c.tobytes())
        if self._cache is None or self._cache[0] != key:
            models = (self._nominal.with_table(T_n), self._calibrated.with_table(T_c))
            self._cache = (key, models)
        return self._cache[1]

    def _tables_of(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        return tuple(
            context.get_numeric_parameter(i).get_value().reshape(-1, 5)
            for i in self._tables
        )

    def _update(self, context: Context, state: DiscreteValues) -> EventStatus:
        n = self._n
        q = self._x.Eval(context)[:n]
        s = context.get_discrete_state(self._state).get_value()
        seed = s[n:].reshape(n, n) @ q + s[:n]  # warm start (q before the first)
        models = self._models(*self._tables_of(context))
        q_c, G = point_motion_map(*models, q, seed)
        state.get_mutable_vector(self._state).SetFromVector(
            np.concatenate([q_c - G @ q, G.ravel()])
        )
        return EventStatus.Succeeded()

    def _calc_state(self, context: Context, output: BasicVector) -> None:
        n = self._n
        s = context.get_discrete_state(self._state).get_value()
        x = self._x.Eval(context).reshape(2, n) @ s[n:].reshape(n, n).T
        x[0] += s[:n]
        output.set_value(x.ravel())

    def _calc_acceleration(self, context: Context, output: BasicVector) -> None:
        n = self._n
        s = context.get_discrete_state(self._state).get_value()
        output.set_value(s[n:].reshape(n, n) @ self._a.Eval(context))


class PresolvedTargetCorrection(Diagram):
    """:class:`JointTargetCorrection` of a program known when the diagram is
    built: every update solved ahead, the outputs computed in Drake's C++.

    .. pydrake_system::

        name: PresolvedTargetCorrection
        input_ports:
        - desired_state
        - desired_acceleration
        output_ports:
        - corrected_state
        - corrected_acceleration

    Ports and rule as :class:`JointTargetCorrection`'s (module docstring):
    the exact map (q_c,k, G_k) at the update times t_k = k ``period`` from
    t = 0 (:func:`presolve_times`), the first-order model around it until the
    next. The maps are solved at the program's positions q(t_k) in one
    :func:`~rmdrake.compensation.correction.motion_map` (the online updates'
    solution to the IK tolerance, 1e-10 m: seeded with the program rather than
    each with its prediction). Inside: a ``Demultiplexer`` splits [q; v];
    three stateless ``TrajectoryAffineSystem`` give G(t) q + c(t), G(t) v and
    G(t) a, with G and c = q_c,k - G_k q_k zero-order holds of the maps; a
    ``Multiplexer`` joins [q_c; v_c].

    Unlike :class:`JointTargetCorrection`, the tables are fixed when built (no
    Context parameters, nothing to update), and the outputs are right only
    while ``desired_state`` streams ``program`` at the simulation's time
    from t = 0 (a station's ``JointTrajectorySource`` does; the program holds
    its end value beyond its end, and so do the maps).

    Args:
      nominal: the robot the program was planned on.
      calibrated: the calibrated robot (same joint count, types and limits).
      program: the (n, 1) joint positions (rad or m) over time (s) from t = 0.
      period: update period of the exact correction, s.

    Raises:
      ValueError: as :class:`JointTargetCorrection`; a program of another
        shape; more than :data:`MAX_PRESOLVED_UPDATES` updates (correct a
        longer program online).

    Example:

    >>> import numpy as np
    >>> from rmdrake import apply_deltas, load_robot
    >>> from rmdrake.systems import PresolvedTargetCorrection, setpoint_trajectory
    >>> nominal = load_robot("rv3sb")
    >>> calibrated = apply_deltas(nominal, ["dd2"], [0.001])
    >>> q = np.array([[0.0, 0.3, 1.2, 0.0, 0.5, 0.0]])
    >>> program = setpoint_trajectory(q, move_time=0.5, settle_time=0.1, q_start=q[0])
    >>> correction = PresolvedTargetCorrection(
    ...     nominal=nominal, calibrated=calibrated, program=program
    ... )
    >>> correction.num_input_ports()
    2
    """

    def __init__(
        self,
        *,
        nominal: RobotModel,
        calibrated: RobotModel,
        program: Trajectory,
        period: float = 0.01,
    ) -> None:
        super().__init__()
        n = nominal.n_joints
        _check_pair(nominal, calibrated, period)
        if (program.rows(), program.cols()) != (n, 1):
            raise ValueError(
                f"program: expected ({n}, 1) joint positions, found "
                f"({program.rows()}, {program.cols()})"
            )
        t = presolve_times(program, period)
        if not presolvable(program, period):
            raise ValueError(
                f"program: {t.size} updates of {period:g} s, more than "
                f"{MAX_PRESOLVED_UPDATES} to solve ahead; correct it online "
                "(JointTargetCorrection)"
            )
        q = program.vector_values(t).T
        filtered, G = motion_map(nominal, calibrated, q)
        c = filtered.q - np.einsum("kij,kj->ki", G, q)
        # One more segment holding the last map: a hold beyond its end takes
        # its last segment's value.
        breaks = np.append(t, t[-1] + period).tolist()
        G_t = PiecewisePolynomial.ZeroOrderHold(breaks, [*G, G[-1]])
        c_t = PiecewisePolynomial.ZeroOrderHold(
            breaks, [*c[:, :, None], c[-1, :, None]]
        )

        def constant(rows: int, cols: int) -> PiecewisePolynomial:
            return PiecewisePolynomial(np.zeros((rows, cols)))

        def affine(offset: PiecewisePolynomial) -> TrajectoryAffineSystem:
            return TrajectoryAffineSystem(
                constant(0, 0), constant(0, n), constant(0, 1), constant(n, 0),
                G_t, offset, 0.0,
            )  # fmt: skip

        builder = DiagramBuilder()
        split = builder.AddNamedSystem("split", Demultiplexer([n, n]))
        join = builder.AddNamedSystem("join", Multiplexer([n, n]))
        maps = [
            builder.AddNamedSystem(name, affine(offset))
            for name, offset in (
                ("position_map", c_t),
                ("velocity_map", constant(n, 1)),
                ("acceleration_map", constant(n, 1)),
            )
        ]
        builder.ExportInput(split.get_input_port(), "desired_state")
        builder.ExportInput(maps[2].get_input_port(), "desired_acceleration")
        for i in range(2):
            builder.Connect(split.get_output_port(i), maps[i].get_input_port())
            builder.Connect(maps[i].get_output_port(), join.get_input_port(i))
        builder.ExportOutput(join.get_output_port(), "corrected_state")
        builder.ExportOutput(maps[2].get_output_port(), "corrected_acceleration")
        builder.BuildInto(self)
