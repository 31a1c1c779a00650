"""The tool payload estimated online: recursive least squares on the measured
joint efforts, as a Drake system.

The model is the offline one of :mod:`rmdrake.dynamics.payload`: the payload's
inertial parameters phi_E (``XX..ZZ MX MY MZ M`` about the tool origin Eo in
E axes: kg m^2, kg m, kg) enter the joint efforts through link n's 10
inertial regressor columns moved to the tool frame E
(:class:`~rmdrake.dynamics.payload.PayloadColumns`)::

    y = tau - tau_arm(q, qd, qdd) = H(q, qd, qdd) theta

with tau the measured joint efforts (N m or N), tau_arm what the identified
arm predicts without a payload (rigid body, rotor inertia, friction, offsets;
the effort :func:`rmdrake.dynamics.validation.predict_torques` gives) and
theta either the 4 parameters ``MX MY MZ M`` (``inertia=False``, the default:
under gravity alone, when the arm holds still, the 6 inertia terms have no
effect) or all 10. On an elastic model the regressor is evaluated at the
link side q - (tau - Ia qdd - f(qd)) / k
(:func:`~rmdrake.dynamics.payload.link_side_positions`): the encoder reads the
motor side and the joint spring holds the measured effort less the rotor's.

Rule, every ``period`` s (a periodic discrete update; between updates the
state holds): with the parameters scaled by their prior standard deviations
s (theta = s * x) and each joint's equation by its noise standard deviation
sigma_j (H_s = diag(1/sigma) H diag(s), y_s = y / sigma), forgetting factor
lambda::

    K = P H_s^T (lambda I + H_s P H_s^T)^-1
    x <- x + K (y_s - H_s x)
    P <- (P - K H_s P) / lambda,   then every eigenvalue of P clipped at 1

P starts at I (the prior) and x at the initial parameters. Forgetting makes
the estimate follow a change (a payload picked up or put down) with a memory
of about period / (1 - lambda) s; the eigenvalue bound (trace(P) <= the
parameter count) keeps the directions the motion does not excite (under a
still hold: the first moment along gravity) from winding up. With lambda = 1
the estimate is the joint-weighted least-squares solution of all samples with
a weak prior (an identity in the scaled parameters): the offline fit's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    InputPort,
    LeafSystem,
    OutputPort,
)

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.chain import SerialChain
from rmdrake.dynamics.compliance import joint_compliances
from rmdrake.dynamics.payload import PayloadColumns, link_side_positions
from rmdrake.dynamics.regressor import regressor
from rmdrake.model.dynamic_parameters import (
    INERTIAL_KEYS,
    extended_parameters,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "DEFAULT_FORGETTING",
    "DEFAULT_PERIOD",
    "PayloadEstimator",
]

DEFAULT_PERIOD = 0.01
"""s between two updates of :class:`PayloadEstimator` (100 Hz)."""

DEFAULT_FORGETTING = 0.99
"""Forgetting factor per update of :class:`PayloadEstimator`: a memory of
period / (1 - lambda) = 1 s at the default period."""

_MOMENTS = np.arange(6, 10)  # MX MY MZ M in INERTIAL_KEYS


class PayloadEstimator(LeafSystem):
    """Recursive least squares on a tool payload's inertial parameters from the
    measured joint signals (module docstring).

    .. pydrake_system::

        name: PayloadEstimator
        input_ports:
        - q
        - qd
        - qdd
        - tau
        output_ports:
        - payload_mass
        - payload_com
        - parameters

    ``q``, ``qd``, ``qdd`` (n each; rad, rad/s, rad/s^2, or m, m/s, m/s^2 on a
    prismatic joint): the measured joint motion (motor side of an elastic
    joint), ``tau`` (n; N m or N): the measured joint efforts (joint torque
    sensors, or motor currents times the drive gains), as
    :func:`~rmdrake.systems.station.MakeStation` exports them;
    ``payload_mass`` (1; kg, clipped at 0, the value a controller's
    ``payload_mass`` input takes); ``payload_com`` (3; m): p_EPcm, the centre
    of mass in the tool frame E, (MX, MY, MZ) / M (zero while M is under
    ``mass_floor``); ``parameters`` (10; kg m^2, kg m, kg): the estimate of
    ``XX..ZZ MX MY MZ M`` about Eo in E axes (the inertia terms zero with
    ``inertia=False``). The outputs depend on the discrete state only (no
    direct feedthrough), so the estimator may close a loop through the
    controller and the plant.

    State (one discrete group, in the Context): [x (p); P (p x p, row-major)]
    with p = 4 or 10, the scaled parameters and covariance of the module
    docstring, updated every ``period`` s from t = 0.

    Args:
      model: the identified arm (its ``dynamics``; its ``payload`` is ignored,
        the arm predicted without one; its tool row places E; its compliance,
        if any, gives the link side).
      period: s between updates (> 0).
      forgetting: lambda per update, in (0, 1].
      inertia: estimate the 6 inertia terms too (10 parameters), else only the
        mass and first moments (4).
      torque_std: (n,) or scalar noise standard deviation of each joint's
        effort, N m or N (the joints' weights); default 1e-3 of the effort
        limits.
      prior_std: (10,) or None: prior standard deviations of ``XX..ZZ MX MY
        MZ M`` (kg m^2, kg m, kg; the scale of the parameters); default the
        arm's moving mass m_a (the sum of its link masses) for M, m_a x 1 m for
        the first moments, m_a x 1 m^2 for the inertia terms.
      initial: (10,) starting estimate (default zero: no payload).
      mass_floor: kg under which ``payload_com`` is zero (default 1e-3 of the
        mass's prior standard deviation).
      coulomb_width: the Coulomb sign's width the arm was identified with,
        rad/s or m/s (0: sign(qd)).

    Raises:
      ValueError: a model without dynamics; a period, forgetting factor,
        standard deviation or mass floor out of range (naming it).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import PayloadEstimator
    >>> estimator = PayloadEstimator(model=load_robot("rv3sb"))
    >>> estimator.parameter_names
    ['MX', 'MY', 'MZ', 'M']
    >>> [estimator.get_output_port(i).get_name() for i in range(3)]
    ['payload_mass', 'payload_com', 'parameters']
    """

    def __init__(
        self,
        *,
        model: RobotModel,
        period: float = DEFAULT_PERIOD,
        forgetting: float = DEFAULT_FORGETTING,
        inertia: bool = False,
        torque_std: object = None,
        prior_std: object = None,
        initial: object = None,
        mass_floor: float | None = None,
        coulomb_width: float = 0.0,
    ) -> None:
        super().__init__()
        if model.dynamics is None:
            raise ValueError(
                f"model: robot '{model.name}' has no dynamics; the payload "
                "estimator subtracts the identified arm's effort"
            )
        period, forgetting = float(period), float(forgetting)
        if not math.isfinite(period) or period <= 0:
            raise ValueError(f"period: expected > 0 s, found {period}")
        if not 0 < forgetting <= 1:
            raise ValueError(f"forgetting: expected in (0, 1], found {forgetting}")
        n = model.n_joints
        arm = dataclasses.replace(model, payload=None)
        columns = PayloadColumns(arm)
        self._n, self._period, self._lambda = n, period, forgetting
        self._chain = SerialChain.from_model(arm)
        self._chi = extended_parameters(arm)
        self._columns = np.arange(self._chi.size)  # 15n (+ 3 per coupled motor)
        self._payload_columns, self._T = columns.columns, columns.T
        self._arm = arm
        self._elastic = bool(np.any(joint_compliances(arm) > 0))
        self._coulomb_width = float(coulomb_width)
        self._keep = np.arange(10) if inertia else _MOMENTS
        if torque_std is None:
            torque_std = 1e-3 * np.asarray(model.limits.effort, dtype=np.float64)
        self._sigma = _positive(torque_std, "torque_std", n)
        if prior_std is None:
            m_a = float(np.sum(np.asarray(model.dynamics)[:, 9]))
            prior_std = np.r_[np.full(6, m_a), np.full(3, m_a), m_a]
        self._scale = _positive(prior_std, "prior_std", 10)[self._keep]
        x0 = np.zeros(10) if initial is None else as_finite_array(initial, "initial")
        if x0.shape != (10,):
            raise ValueError(f"initial: expected 10 parameters, found {x0.shape}")
        self._floor = 1e-3 * self._scale[-1] if mass_floor is None else mass_floor
        if not (math.isfinite(self._floor) and self._floor >= 0):
            raise ValueError(f"mass_floor: expected >= 0 kg, found {self._floor}")
        p = self._keep.size
        self._p = p
        x0 = x0[self._keep] / self._scale
        self._ins = [
            self.DeclareVectorInputPort(name, n) for name in ("q", "qd", "qdd", "tau")
        ]
        self._state = self.DeclareDiscreteState(np.r_[x0, np.eye(p).ravel()])
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        ticket = {self.xd_ticket()}
        self.DeclareVectorOutputPort("payload_mass", 1, self._calc_mass, ticket)
        self.DeclareVectorOutputPort("payload_com", 3, self._calc_com, ticket)
        self.DeclareVectorOutputPort("parameters", 10, self._calc_parameters, ticket)

    @property
    def period(self) -> float:
        """s between updates."""
        return self._period

    @property
    def forgetting(self) -> float:
        """lambda per update."""
        return self._lambda

    @property
    def parameter_names(self) -> list[str]:
        """Names of the estimated parameters, in the state's order."""
        return [INERTIAL_KEYS[k] for k in self._keep]

    def memory(self) -> float:
        """period / (1 - lambda), s: the forgetting's time constant (inf for
        lambda = 1)."""
        return math.inf if self._lambda == 1 else self._period / (1 - self._lambda)

    def measurement(
        self, q: object, qd: object, qdd: object, tau: object
    ) -> tuple[np.ndarray, np.ndarray]:
        """(H (n, 10), y (n,)) of one sample (module docstring): the payload's
        regressor at the (link-side) motion, N m or N per unit of phi_E, and
        the measured effort minus the arm's prediction, N m or N."""
        q, qd, qdd, tau = (np.asarray(v, dtype=np.float64) for v in (q, qd, qdd, tau))
        if self._elastic:
            q = link_side_positions(
                self._arm, q[None], qd[None], qdd[None], tau[None],
                self._coulomb_width,
            )[0]  # fmt: skip
        Y = regressor(
            self._chain,
            q[None],
            qd[None],
            qdd[None],
            self._columns,
            coulomb_width=self._coulomb_width,
            asymmetric=True,
        )[0]
        return Y[:, self._payload_columns] @ self._T, tau - Y @ self._chi

    def _update(self, context: Context, discrete: DiscreteValues) -> EventStatus:
        H, y = self.measurement(*(port.Eval(context) for port in self._ins))
        p, lam = self._p, self._lambda
        state = context.get_discrete_state(self._state).value()
        x, P = state[:p], state[p:].reshape(p, p)
        Hs = H[:, self._keep] * self._scale / self._sigma[:, None]
        ys = y / self._sigma
        PHt = P @ Hs.T
        S = lam * np.eye(self._n) + Hs @ PHt
        K = np.linalg.solve(S, PHt.T).T
        x = x + K @ (ys - Hs @ x)
        P = (P - K @ PHt.T) / lam
        P = 0.5 * (P + P.T)
        w, V = np.linalg.eigh(P)
        if w[-1] > 1.0:  # bounded covariance: no wind-up of unexcited directions
            P = (V * np.minimum(w, 1.0)) @ V.T
        discrete.get_mutable_vector(self._state).SetFromVector(np.r_[x, P.ravel()])
        return EventStatus.Succeeded()

    def _phi(self, context: Context) -> np.ndarray:
        phi = np.zeros(10)
        x = context.get_discrete_state(self._state).value()[: self._p]
        phi[self._keep] = x * self._scale
        return phi

    def _calc_mass(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector([max(self._phi(context)[9], 0.0)])

    def _calc_com(self, context: Context, output: BasicVector) -> None:
        phi = self._phi(context)
        m = phi[9]
        output.SetFromVector(phi[6:9] / m if m > self._floor else np.zeros(3))

    def _calc_parameters(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._phi(context))

    def GetCovariance(self, context: Context) -> np.ndarray:
        """(10, 10) covariance of the estimated parameters in their units (kg
        m^2, kg m, kg, squared), zero in the rows of those not estimated: P
        scaled back (with lambda < 1 a tracking figure, not a statistic)."""
        p = self._p
        P = context.get_discrete_state(self._state).value()[p:].reshape(p, p)
        out = np.zeros((10, 10))
        out[np.ix_(self._keep, self._keep)] = P * np.outer(self._scale, self._scale)
        return out

    @classmethod
    def AddToBuilder(
        cls,
        builder: DiagramBuilder,
        *,
        model: RobotModel,
        q: OutputPort | None = None,
        qd: OutputPort | None = None,
        qdd: OutputPort | None = None,
        tau: OutputPort | None = None,
        payload_mass: InputPort | None = None,
        name: str = "payload_estimator",
        **options: object,
    ) -> PayloadEstimator:
        """Adds the estimator (``model`` and ``options`` as its constructor)
        to ``builder`` under ``name``, connects the given measured signals to
        its inputs of the same names (e.g. the ``signals`` of
        :func:`~rmdrake.systems.station.MakeStation`'s ``add_systems``) and
        its ``payload_mass`` output to the ``payload_mass`` input port given
        (a compensation controller's); returns it."""
        system = builder.AddNamedSystem(name, cls(model=model, **options))
        for port_name, port in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
            if port is not None:
                builder.Connect(port, system.GetInputPort(port_name))
        if payload_mass is not None:
            builder.Connect(system.GetOutputPort("payload_mass"), payload_mass)
        return system


def _positive(value: object, name: str, size: int) -> np.ndarray:
    """(size,) finite values > 0 from a scalar or a vector, else ValueError
    naming ``name``."""
    v = np.broadcast_to(np.asarray(value, dtype=np.float64), (size,)).copy()
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"{name}: expected {size} finite values > 0, found {v}")
    return v
