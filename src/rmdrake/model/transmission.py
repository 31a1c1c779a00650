"""Transmissions between motors and joints: gear ratios and coupled motors.

An industrial arm's drives log the motor side: motor angles q_m (rad at the
motor shaft) and motor torques tau_m (N m at the motor shaft), through gear
ratios of 30-100, and a wrist motor may turn with two joints (a coupled
wrist: motor 6 turns with joint 5 and joint 6). The robot YAML's optional
``transmission:`` entry describes this linear map:

    q_m = T q,   T = diag(ratio) @ C,

``ratio`` (n,) the gear ratios n_m (motor rad per joint rad, sign allowed:
a motor that turns the other way has n_m < 0) and ``coupling`` C (n, n) with
a unit diagonal (identity when left out). Example: a wrist whose motor 6
turns 0.8 rad per rad of joint 5 on top of its own joint::

    transmission:
      ratio: [100, 100, 80, 60, 60, 50]
      coupling: [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],
                 [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0.8, 1]]
      torque_constant: [0.5, 0.5, 0.4, 0.2, 0.2, 0.2]   # optional, N m/A

gives q_m6 = 50 (0.8 q5 + q6). Power balance (tau^T qd = tau_m^T qd_m for
every qd) gives the joint efforts tau = T^T tau_m: motor 6's torque acts on
joint 6 with 50 and on joint 5 with 40. ``torque_constant`` k_m (N m/A at
the motor shaft, before the gear) turns motor currents into motor torques,
tau_m = k_m i, for motor-side logs (:mod:`rmdrake.dynamics.joint_log`); it is
not the robot's ``drive: {gain}``, which is per joint, gear included, for
joint-side logs of currents.

Coupled motors. A motor whose row of C has an off-diagonal entry is
*coupled* (:attr:`Transmission.coupled`): its speed s_m = c_m . qd (c_m the
row, in joint-reflected units) is no joint's own, so its rotor inertia and
friction are three parameters of their own (``Iam, fvm, fcm`` in
:mod:`rmdrake.model.dynamic_parameters`) acting on the joints j with
c_mj != 0: joint j gets c_mj (Ia_m c_m . qdd + fv_m s_m + fc_m sign(s_m)).
They are in joint-reflected units (kg m^2, N m s/rad, N m, reflected through
n_m: the motor's own rotor inertia is Ia_m / n_m^2, its viscous friction
fv_m / n_m^2 N m s/rad and its Coulomb friction fc_m / |n_m| N m at the
motor shaft). An uncoupled motor's terms are its joint's ``Ia, fv, fc``
(reflected by n_m^2, n_m^2 and |n_m|): no new parameters.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.io.yaml import yaml_vector

__all__ = ["TRANSMISSION_KEYS", "Transmission", "transmission_from_dict"]

TRANSMISSION_KEYS: tuple[str, ...] = ("ratio", "coupling", "torque_constant")
"""The keys of the robot YAML's ``transmission:`` mapping (``ratio`` required)."""


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True)
class Transmission:
    """Motor-to-joint transmission q_m = diag(ratio) @ coupling @ q (module
    docstring).

    Attributes:
      ratio: (n,) gear ratios n_m, motor rad per joint rad (m per rad of motor
        on a slide: motor rad per joint m), finite and non-zero.
      coupling: (n, n) C, unit diagonal, invertible (default identity).
      torque_constant: (n,) motor torque constants k_m, N m/A at the motor
        shaft (positive), or None when unknown.

    Example:

    >>> import numpy as np
    >>> from rmdrake.model import Transmission
    >>> gears = Transmission(ratio=[100.0, 50.0])
    >>> gears.motor_positions(np.array([0.1, 0.2])).round(6).tolist()
    [10.0, 10.0]
    >>> from rmdrake import load_robot
    >>> load_robot("rv3sb_geared").transmission.coupled
    (5,)
    """

    ratio: np.ndarray
    coupling: np.ndarray | None = None
    torque_constant: np.ndarray | None = None

    def __post_init__(self) -> None:
        n_ = as_finite_array(self.ratio, "transmission.ratio", (None,))
        n = n_.size
        if n < 1 or np.any(n_ == 0):
            j = int(np.flatnonzero(n_ == 0)[0]) if n else 0
            raise ValueError(
                f"transmission.ratio: expected non-zero gear ratios (motor rad "
                f"per joint rad), found 0 for motor {j + 1}"
            )
        C = np.eye(n) if self.coupling is None else self.coupling
        C = as_finite_array(C, "transmission.coupling", (n, n))
        off = np.flatnonzero(np.diag(C) != 1.0)
        if off.size:
            j = int(off[0])
            raise ValueError(
                f"transmission.coupling: expected a unit diagonal (row m is "
                f"motor m's turns per joint turn, its own joint 1), found "
                f"{C[j, j]:g} at row {j + 1}"
            )
        cond = np.linalg.cond(C)
        if not cond < 1e12:
            raise ValueError(
                f"transmission.coupling: expected an invertible matrix, found "
                f"condition number {cond:.3g} (two motors turn alike)"
            )
        object.__setattr__(self, "ratio", _frozen(n_))
        object.__setattr__(self, "coupling", _frozen(C))
        if self.torque_constant is not None:
            k = as_finite_array(
                self.torque_constant, "transmission.torque_constant", (n,)
            )
            if np.any(k <= 0):
                j = int(np.flatnonzero(k <= 0)[0])
                raise ValueError(
                    f"transmission.torque_constant: expected positive N m/A, "
                    f"found {k[j]:g} for motor {j + 1}"
                )
            object.__setattr__(self, "torque_constant", _frozen(k))

    @property
    def n(self) -> int:
        """Number of motors (= joints) n."""
        return int(self.ratio.size)

    @property
    def matrix(self) -> np.ndarray:
        """(n, n) T = diag(ratio) @ coupling: q_m = T q."""
        return self.ratio[:, None] * self.coupling

    @property
    def coupled(self) -> tuple[int, ...]:
        """0-based indices of the coupled motors (rows of ``coupling`` with a
        non-zero off-diagonal entry), ascending; e.g. (5,) for a coupled
        wrist's motor 6."""
        off = self.coupling - np.diag(np.diag(self.coupling))
        return tuple(int(m) for m in np.flatnonzero(np.any(off != 0, axis=1)))

    def joint_positions(self, q_m: object) -> np.ndarray:
        """Joint positions q = T^-1 q_m, (N, n) rad (or m) from motor
        positions (N, n) rad; also velocities and accelerations (linear)."""
        x = np.asarray(q_m, dtype=np.float64)
        return np.linalg.solve(self.matrix, x.T).T

    def motor_positions(self, q: object) -> np.ndarray:
        """Motor positions q_m = T q, (N, n) rad at the motor shafts, from
        joint positions (N, n) (rad or m); also velocities and accelerations."""
        return np.asarray(q, dtype=np.float64) @ self.matrix.T

    def joint_efforts(self, tau_m: object) -> np.ndarray:
        """Joint efforts tau = T^T tau_m, (N, n) N m (or N), from motor
        torques (N, n) N m at the motor shafts (power balance)."""
        return np.asarray(tau_m, dtype=np.float64) @ self.matrix

    def motor_efforts(self, tau: object) -> np.ndarray:
        """Motor torques tau_m = T^-T tau, (N, n) N m, from joint efforts."""
        x = np.asarray(tau, dtype=np.float64)
        return np.linalg.solve(self.matrix.T, x.T).T

    def to_dict(self) -> dict[str, Any]:
        """The ``transmission:`` mapping (plain floats; ``coupling`` only when
        not the identity)."""
        out: dict[str, Any] = {"ratio": [float(v) for v in self.ratio]}
        if np.any(self.coupling != np.eye(self.n)):
            out["coupling"] = [[float(v) for v in r] for r in self.coupling]
        if self.torque_constant is not None:
            out["torque_constant"] = [float(v) for v in self.torque_constant]
        return out


def transmission_from_dict(value: Any, n: int) -> Transmission | None:
    """The optional ``transmission:`` entry of a robot YAML for n joints
    (module docstring), or None when absent.

    Raises:
      ValueError: one line naming the key: unknown keys, a missing ratio,
        counts other than n, a non-square, singular or non-unit-diagonal
        coupling, non-positive torque constants.
    """
    if value is None:
        return None
    if not isinstance(value, Mapping) or not set(value) <= set(TRANSMISSION_KEYS):
        raise ValueError(
            "transmission: expected a mapping with ratio and optionally "
            "coupling, torque_constant"
        )
    if "ratio" not in value:
        raise ValueError("transmission: missing key 'ratio' (gear ratio per motor)")
    ratio = yaml_vector(value["ratio"], "transmission.ratio", n)
    C = value.get("coupling")
    if C is not None:
        if not isinstance(C, list) or len(C) != n:
            found = len(C) if isinstance(C, list) else type(C).__name__
            raise ValueError(
                f"transmission.coupling: expected {n} rows of {n} (a square "
                f"matrix), found {found} rows"
            )
        C = np.array(
            [yaml_vector(r, f"transmission.coupling[{i}]", n) for i, r in enumerate(C)]
        )
    k = value.get("torque_constant")
    k = None if k is None else yaml_vector(k, "transmission.torque_constant", n)
    return Transmission(ratio, C, k)
