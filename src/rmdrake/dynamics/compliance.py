"""Joint deflection of an elastic robot under gravity and a payload.

An elastic joint j (``RobotModel.compliance``, stiffness k_j > 0) has a motor
side, whose angle q_m the encoder reads, and a link side q_l, which the MDH
chain turns. At rest the spring k_j (q_m - q_l) balances the generalized force
tau_j(q_l) that gravity applies to the link side (Drake's sign, as
``MultibodyPlant.CalcGravityGeneralizedForces``: negative where gravity pulls
the joint towards negative angles), so

    q_l = q_m + C tau(q_l),    C = diag(1 / k_j) (0 on rigid joints).

tau depends on q_l, so the link angles solve a fixed point; the map is a
contraction when every ``c_j |d tau_j / d q_l|`` is well below 1 (0.3 % on
the shipped ``demo_rh``), and :func:`link_angles` iterates it to round-off.
The inverse, the motor angles that put the link side at q_l (the pre-deflection
of a compensation), is explicit: q_m = q_l - C tau(q_l).

tau comes from the robot's standard parameters (links and rotors' masses and
first moments) and a payload of mass m on the tool, whose centre of mass is the
robot's ``payload.com``: the gravity torque is linear in m, so each pose may
carry its own payload mass (the ``payload`` column of calibration readings).
Everything is vectorised over poses (the joint-torque regressor of
:mod:`rmdrake.dynamics.regressor` at zero speed and acceleration). Units: rad
or m, N m or N, kg.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.kinematics.forward import link_frames
from rmdrake.model.dynamic_parameters import (
    N_PER_LINK,
    payload_parameters,
    standard_parameters,
)
from rmdrake.model.robot import DYNAMIC_KEYS, Payload, RobotModel

__all__ = [
    "DRAKE_POSES",
    "GravityModel",
    "gravity_torques",
    "joint_compliances",
    "link_angles",
    "lowest_structural_mode",
    "motor_angles",
    "payload_choices",
    "payload_masses",
    "with_payload_mass",
]

_MAX_ITERATIONS = 50


def joint_compliances(model: RobotModel) -> np.ndarray:
    """(n,) c_j = 1 / k_j of ``model`` in rad/(N m) (m/N on a slide); zeros for
    a rigid robot."""
    if model.compliance is None:
        return np.zeros(model.n_joints)
    return model.compliance.compliances


def payload_masses(model: RobotModel, payload_mass: object, count: int) -> np.ndarray:
    """(count,) payload mass per pose in kg: ``None`` for the model's own payload
    (0 without one), a scalar, or one value per pose.

    Raises:
      ValueError: negative or non-finite masses, a wrong count, or a mass > 0
        on a robot without a ``payload`` entry (whose centre of mass is then
        unknown).
    """
    if payload_mass is None:
        pl = model.payload
        return np.full(count, 0.0 if pl is None else pl.mass)
    m = as_finite_array(payload_mass, "payload")
    m = np.full(count, float(m)) if m.ndim == 0 else m
    if m.shape != (count,):
        raise ValueError(f"payload: expected {count} masses, found {m.shape}")
    if np.any(m < 0):
        raise ValueError(f"payload: expected masses >= 0 kg, found {m.min():g}")
    if np.any(m > 0) and model.payload is None:
        raise ValueError(
            f"payload: masses up to {m.max():g} kg given, but robot '{model.name}' "
            "has no payload entry (its centre of mass on the tool: payload: {mass, "
            "com, inertia})"
        )
    return m


def payload_choices(model: RobotModel, payload: object) -> np.ndarray | None:
    """The payload masses a simulation spreads its readings over: None (no
    payload column), or one or several masses in kg, checked as
    :func:`payload_masses` checks them.

    Raises:
      ValueError: an empty or nested list, and what :func:`payload_masses`
        refuses.
    """
    if payload is None:
        return None
    masses = np.atleast_1d(np.asarray(payload, float))
    if masses.ndim != 1 or masses.size == 0:
        raise ValueError("payload: expected one or more masses in kg")
    return payload_masses(model, masses, masses.size)


DRAKE_POSES = 8
"""Calls of :class:`GravityModel` with at most this many poses use Drake's plant."""


class GravityModel:
    """The gravity torques of a robot, precomputed for repeated calls (build it
    once where tau is evaluated often, e.g. in a controller).

    Statics on the MDH frames (:func:`rmdrake.kinematics.forward.link_frames`): link
    i's mass M_i and first moment s_i = M_i c_i (in its frame, the
    ``MX MY MZ M`` of its standard parameters, the payload's added to link n)
    give the generalized gravity force on joint j

        tau_j = z_j . sum_{i >= j} (R_i s_i x g + (p_i - p_j) x M_i g)

    (revolute; z_j . sum_{i >= j} M_i g on a slide), g the robot's gravity in
    B. Rotor inertia and friction do not enter.

    Example:

    >>> import numpy as np
    >>> from rmdrake import GravityModel, gravity_torques, load_robot
    >>> robot = load_robot("rv3sb")
    >>> gravity = GravityModel(robot)  # build once, call often
    >>> q = np.zeros((4, 6))
    >>> bool(np.allclose(gravity(q), gravity_torques(robot, q)))
    True
    """

    def __init__(self, model: RobotModel) -> None:
        if model.dynamics is None:
            raise ValueError(
                f"robot '{model.name}': the gravity torques need its 'dynamics' section"
            )
        n = model.n_joints
        self.model = model
        chi = standard_parameters(dataclasses.replace(model, payload=None))
        first = [DYNAMIC_KEYS.index(k) for k in ("MX", "MY", "MZ", "M")]
        self._links = chi.reshape(n, N_PER_LINK)[:, first]  # (n, 4)
        self._payload = np.zeros(4)
        if model.payload is not None:
            unit = Payload(1.0, model.payload.p_EPcm, np.zeros(6))
            self._payload = payload_parameters(model, unit)[first]  # per kg
        self._table = model.table
        self._slide = model.sigma.astype(bool)
        self._plant = None  # Drake's, built at the first small call

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_plant": None}  # a plant does not pickle

    def __call__(self, q_l: object, payload_mass: object = None) -> np.ndarray:
        """tau at link angles ``q_l`` ((N, n) or (n,)), as
        :func:`gravity_torques`. Up to :data:`DRAKE_POSES` poses are evaluated
        by Drake's ``CalcGravityGeneralizedForces`` on a plant of the rigid
        model (a controller's call), more by the vectorised statics of the class
        docstring; the two agree to round-off."""
        q = as_finite_array(q_l, "q_l")
        single = q.ndim == 1
        q = np.atleast_2d(q)
        model = self.model
        n = model.n_joints
        if q.shape[1] != n:
            raise ValueError(f"q_l: expected {n} joints per pose, found {q.shape[1]}")
        m = payload_masses(model, payload_mass, q.shape[0])
        if q.shape[0] <= DRAKE_POSES:
            tau = self._drake(q, m)
            return tau[0] if single else tau
        R, p = link_frames(self._table, q, sigma=model.sigma)  # (n+1,3,3,N), (n+1,3,N)
        R, p = R[:n], p[:n]
        links = np.broadcast_to(self._links[:, :, None], (n, 4, q.shape[0])).copy()
        links[-1] += self._payload[:, None] * m  # (n, 4, N): s_i and M_i per pose
        g = model.gravity[None, :, None]
        s = np.einsum("iabN,ibN->iaN", R, links[:, :3])  # first moments in B
        f = links[:, 3:4] * g  # (n, 3, N) weights
        moment = np.cross(s, g, axis=1) + np.cross(p, f, axis=1)  # about B's origin
        F = np.cumsum(f[::-1], axis=0)[::-1]  # suffix sums over i >= j
        T = np.cumsum(moment[::-1], axis=0)[::-1]
        z = R[:, :, 2]  # (n, 3, N)
        about = T - np.cross(p, F, axis=1)
        tau = np.where(
            self._slide[:, None], (z * F).sum(axis=1), (z * about).sum(axis=1)
        )
        tau = tau.T
        return tau[0] if single else tau

    def _drake(self, q: np.ndarray, m: np.ndarray) -> np.ndarray:
        """(N, n) gravity torques by Drake's plant of the rigid model, its
        payload body (if any) at each pose's mass."""
        if self._plant is None:
            from rmdrake.model.plant import MakePlant  # Drake, when first asked

            model = self.model
            payload = None if model.payload is None else model.payload.with_mass(1.0)
            rigid = dataclasses.replace(model, compliance=None, payload=payload)
            plant, _ = MakePlant(rigid, visual=False)
            body = None if payload is None else plant.GetBodyByName("payload")
            self._plant = (plant, plant.CreateDefaultContext(), body)
        plant, context, body = self._plant
        tau = np.empty_like(q)
        for k in range(q.shape[0]):
            plant.SetPositions(context, q[k])
            if body is not None:
                body.SetMass(context, m[k])
            tau[k] = plant.CalcGravityGeneralizedForces(context)
        return tau


def gravity_torques(
    model: RobotModel | GravityModel, q_l: object, payload_mass: object = None
) -> np.ndarray:
    """Generalized gravity force on the joints at link angles ``q_l``.

    Args:
      model: the robot (``dynamics`` needed; its payload's centre of mass is
        used, its mass replaced by ``payload_mass``), or its
        :class:`GravityModel`.
      q_l: (N, n) or (n,) link-side joint positions, rad or m.
      payload_mass: kg at the tool: None (the model's payload), a scalar, or
        (N,) one per pose.

    Returns:
      (N, n) or (n,) tau in N m or N, Drake's sign (the force gravity applies,
      ``-g(q)`` of ``M qdd + C qd + g = tau_motor``).

    Example:

    >>> import numpy as np
    >>> from rmdrake import gravity_torques, load_robot
    >>> tau = gravity_torques(load_robot("rv3sb"), np.zeros(6))
    >>> tau.shape, bool(abs(tau[0]) < 1e-9)  # joint 1's axis is vertical
    ((6,), True)
    """
    gravity = model if isinstance(model, GravityModel) else GravityModel(model)
    return gravity(q_l, payload_mass)


def motor_angles(
    model: RobotModel | GravityModel, q_l: object, payload_mass: object = None
) -> np.ndarray:
    """Motor-side positions that hold the link side at ``q_l`` at rest:
    q_m = q_l - C tau(q_l) (shape of ``q_l``; rad or m). Equal to q_l on a rigid
    robot.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, motor_angles
    >>> q_l = np.array([0.0, 0.5, 0.5, 0.0, 0.5, 0.0])
    >>> rigid = motor_angles(load_robot("rv3sb"), q_l)
    >>> bool((rigid == q_l).all())
    True
    >>> elastic = motor_angles(load_robot("demo_rh_elastic"), q_l)
    >>> bool(np.abs(elastic - q_l).max() > 0)  # the springs deflect under gravity
    True
    """
    q = as_finite_array(q_l, "q_l")
    robot = model.model if isinstance(model, GravityModel) else model
    c = joint_compliances(robot)
    if not np.any(c):
        return q.copy()
    return q - c * gravity_torques(model, q, payload_mass)


def link_angles(
    model: RobotModel | GravityModel,
    q_m: object,
    payload_mass: object = None,
    *,
    tolerance: float = 1e-12,
) -> np.ndarray:
    """Link-side positions at rest for motor-side positions ``q_m``: the fixed
    point q_l = q_m + C tau(q_l) (shape of ``q_m``; rad or m).

    Args:
      model: the robot; rigid joints have q_l = q_m.
      q_m: (N, n) or (n,) motor-side (encoder) positions.
      payload_mass: as :func:`gravity_torques`.
      tolerance: largest change of the last iteration, rad or m.

    Raises:
      ValueError: the iteration does not converge (a joint so soft that the arm
        would fold under its own weight), naming the worst joint.

    Example:

    >>> import numpy as np
    >>> from rmdrake import link_angles, load_robot, motor_angles
    >>> robot = load_robot("demo_rh_elastic")
    >>> q_l = np.array([0.0, 0.5, 0.5, 0.0, 0.5, 0.0])
    >>> q_m = motor_angles(robot, q_l)
    >>> bool(np.allclose(link_angles(robot, q_m), q_l, atol=1e-10))
    True
    """
    q_m = as_finite_array(q_m, "q_m")
    robot = model.model if isinstance(model, GravityModel) else model
    c = joint_compliances(robot)
    if not np.any(c):
        return q_m.copy()
    gravity = model if isinstance(model, GravityModel) else GravityModel(model)
    q = q_m.copy()
    for _ in range(_MAX_ITERATIONS):
        step = q_m + c * gravity(q, payload_mass) - q
        q = q + step
        if np.max(np.abs(step)) <= tolerance:
            return q
    j = int(np.argmax(np.max(np.abs(np.atleast_2d(step)), axis=0)))
    raise ValueError(
        f"compliance: the link angles did not converge in {_MAX_ITERATIONS} "
        f"iterations (joint {j + 1} still moves {np.max(np.abs(step)):.3g}): a "
        "stiffness too low for the gravity load"
    )


def with_payload_mass(model: RobotModel, mass: float) -> RobotModel:
    """``model`` holding a ``mass`` kg payload of its payload's shape
    (:meth:`~rmdrake.model.robot.Payload.with_mass`); unchanged without a payload
    entry."""
    if model.payload is None or mass == model.payload.mass:
        return model
    return dataclasses.replace(model, payload=model.payload.with_mass(mass))


def lowest_structural_mode(
    model: RobotModel, q_m: object, payload_mass: object = None
) -> float:
    """Lowest natural frequency (rad/s) of the elastic joints at rest at motor
    positions ``q_m`` (n,), with the motors held still: the generalized
    eigenvalue problem K v = w^2 M v over the elastic joints, where M is the
    link-side mass matrix (Drake's, without rotor inertia: the rotors stay
    with the motors) and K = diag(k) - d tau / d q_l the joint stiffness less
    the gravity (and payload) stiffness, at the deflected link angles. A
    feedback loop on the motor side must stay well below this frequency.

    Raises:
      ValueError: a rigid robot (no elastic joint), or a negative K eigenvalue
        (the arm is unstable at rest: buckling under its load).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, lowest_structural_mode
    >>> w = lowest_structural_mode(load_robot("demo_rh_elastic"), np.zeros(6))
    >>> bool(w > 0)  # rad/s
    True
    """
    import scipy.linalg

    from rmdrake.model.plant import MakePlant

    c = joint_compliances(model)
    elastic = np.flatnonzero(c > 0)
    if elastic.size == 0:
        raise ValueError(f"robot '{model.name}' has no elastic joint")
    q_m = as_finite_array(q_m, "q_m", (model.n_joints,))
    m = float(payload_masses(model, payload_mass, 1)[0])
    q_l = link_angles(model, q_m, m)
    h = 1e-6
    n = model.n_joints
    steps = q_l + h * np.vstack([np.eye(n), -np.eye(n)])
    tau = gravity_torques(model, steps, m)
    dtau = ((tau[:n] - tau[n:]) / (2 * h)).T  # d tau_i / d q_j
    K = np.diag(model.compliance.stiffness) - dtau
    dyn = np.array(model.dynamics)
    dyn[:, DYNAMIC_KEYS.index("Ia")] = 0.0
    plant, _ = MakePlant(
        dataclasses.replace(with_payload_mass(model, m), dynamics=dyn, compliance=None),
        visual=False,
    )
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q_l)
    M = plant.CalcMassMatrix(context)
    sub = np.ix_(elastic, elastic)
    w2 = scipy.linalg.eigh(0.5 * (K[sub] + K[sub].T), M[sub], eigvals_only=True)
    if w2[0] <= 0:
        raise ValueError(
            f"robot '{model.name}': the joint stiffness does not hold the arm at "
            f"rest at q_m = {np.round(q_m, 4).tolist()} (a negative stiffness "
            "eigenvalue)"
        )
    return float(np.sqrt(w2[0]))
