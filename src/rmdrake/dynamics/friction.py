"""The joint friction law of rmdrake, written once.

Per joint j, with the joint velocity v_j in rad/s (m/s for a prismatic joint)::

    tau_f,j = fv_j * v_j + fc_j * s(v_j)        (N m or N, opposing the motion)

with fv_j the viscous coefficient (N m s/rad or N s/m, >= 0), fc_j the Coulomb
coefficient (N m or N, >= 0) and s the sign function, either

* exact: s(v) = sign(v), with sign(0) = 0 (a joint at rest has no Coulomb
  torque); the model of a real robot and the regressor's default; or
* smooth: s(v) = tanh(v / w) for a width w > 0 in rad/s (m/s on a prismatic
  joint: one width for all joints); the simulator's law
  (:class:`rmdrake.systems.friction.JointFriction`, w = :data:`DEFAULT_V_EPS`).

The smooth sign differs from sign(v) by less than 2 exp(-2 |v| / w): below 1e-3
for |v| > 3.8 w. Near v = 0 its Coulomb term acts as a damper fc / w
(N m s/rad or N s/m), stiff for a small w; with the exact sign an error-controlled
integrator chatters at every velocity reversal. Identifying simulated data with
the simulator's width (``coulomb_width`` of :func:`rmdrake.dynamics.regressor`)
fits the law that produced the data.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DEFAULT_V_EPS", "coulomb_sign", "friction_torque"]

DEFAULT_V_EPS = 1e-3
"""The simulator's smooth-sign width in rad/s (m/s on a prismatic joint):
s(v) = tanh(v / 1e-3)."""


def coulomb_sign(v: object, width: float = 0.0) -> np.ndarray:
    """The Coulomb term's sign s(v) (dimensionless, in [-1, 1]).

    Args:
      v: joint velocities, rad/s or m/s, any shape.
      width: 0 for the exact sign(v) (0 at v = 0); > 0 (rad/s or m/s) for the
        smooth
        sign tanh(v / width).

    Raises:
      ValueError: a negative or non-finite width.

    Example:

    >>> from rmdrake.dynamics import coulomb_sign
    >>> coulomb_sign([-1.0, 0.0, 2.0]).tolist()
    [-1.0, 0.0, 1.0]
    >>> coulomb_sign([0.001], width=0.01).round(3).tolist()  # smooth near 0
    [0.1]
    """
    width = float(width)
    if not math.isfinite(width) or width < 0:
        raise ValueError(
            f"coulomb width: expected a width >= 0 in rad/s or m/s, found {width}"
        )
    v = np.asarray(v, dtype=np.float64)
    return np.sign(v) if width == 0 else np.tanh(v / width)


def friction_torque(
    v: object,
    fv: object,
    fc: object,
    coulomb_width: float = 0.0,
    *,
    fcn: object = None,
    tau0: object = None,
) -> np.ndarray:
    """Friction effort fv * v + fc * s(v), N m or N: what the joints lose;
    with ``fcn`` the Coulomb part is fc max(s, 0) + fcn min(s, 0), and
    ``tau0`` is added (module docstring).

    Args:
      v: joint velocities, rad/s or m/s, shape (..., n).
      fv: (n,) viscous coefficients, N m s/rad or N s/m.
      fc: (n,) Coulomb coefficients, N m or N.
      coulomb_width: width of s in rad/s or m/s: 0 (default) for sign(v), > 0 for
        tanh(v / coulomb_width) (:data:`DEFAULT_V_EPS` for the simulator's law).
      fcn: optional (n,) Coulomb levels for negative velocity, N m or N
        (None: fc).
      tau0: optional (n,) constant offsets, N m or N (None: 0).

    Returns:
      Array of the broadcast shape of v, fv and fc, N m or N.

    Raises:
      ValueError: a negative or non-finite width.

    Example:

    >>> from rmdrake.dynamics import friction_torque
    >>> friction_torque([-0.5, 0.5], fv=2.0, fc=1.5).tolist()  # fv v + fc sign(v)
    [-2.5, 2.5]
    """
    v = np.asarray(v, dtype=np.float64)
    fv = np.asarray(fv, dtype=np.float64)
    fc = np.asarray(fc, dtype=np.float64)
    s = coulomb_sign(v, coulomb_width)
    if fcn is not None:  # fc max(s, 0) + fcn min(s, 0), in fewer operations
        fc = np.where(s > 0.0, fc, np.asarray(fcn, dtype=np.float64))
    out = fv * v + fc * s
    return out if tau0 is None else out + np.asarray(tau0, dtype=np.float64)
