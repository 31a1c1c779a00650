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
exact solve (0.2-0.45 ms on six joints: one or two Gauss-Newton steps from
the prediction) runs once per period; an output evaluation is one matrix
product. Joints may be revolute (rad, rad/s, rad/s^2) or prismatic (m, m/s,
m/s^2), as the models' ``sigma`` says
(``tests/systems/test_correction.py`` checks a robot with both against its
Drake plants).
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)

from rmdrake.compensation.correction import point_motion_map
from rmdrake.model.robot import RobotModel

__all__ = ["JointTargetCorrection"]


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
    """

    def __init__(
        self, *, nominal: RobotModel, calibrated: RobotModel, period: float = 0.01
    ) -> None:
        super().__init__()
        n = nominal.n_joints
        if calibrated.n_joints != n:
            raise ValueError(
                f"calibrated robot has {calibrated.n_joints} joints, the nominal "
                f"one {n}: expected the same robot"
            )
        if not np.array_equal(calibrated.sigma, nominal.sigma):
            raise ValueError(
                f"calibrated robot sigma: joint types {calibrated.sigma.tolist()}, "
                f"the nominal one's {nominal.sigma.tolist()}: expected the same robot"
            )
        if not np.isfinite(period) or period <= 0:
            raise ValueError(f"period: expected > 0 s, found {period}")
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
