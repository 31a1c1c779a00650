"""Joint friction (viscous + Coulomb) as a force system for the true robot.

MultibodyPlant has no Coulomb friction (URDF ``<dynamics friction>`` is ignored),
and in a discrete (SAP) plant its joint damping acts implicitly at the next step's
velocity, which biases identified rotor inertias by about time_step * fv. So all
joint friction of the simulated robot lives here, applied through the plant's
``applied_generalized_force`` input, and the plant's joint damping stays zero
(see :func:`rmdrake.plant.MakePlant`).

Friction model (DESIGN §2), per joint j, with v_j in rad/s::

    tau_f,j = fv_j * v_j + fc_j * s(v_j)        (N m, opposing the motion)

where s is either the exact sign or the smooth sign ``tanh(v / v_eps)``. The smooth
sign differs from sign(v) by less than 2 exp(-2 |v| / v_eps): below 1e-3 for
|v| > 3.8 v_eps. Its width matters for the integrator: near v = 0 the Coulomb term
acts as a damper fc / v_eps (N m s/rad), stiff for small v_eps; with the exact
sign an error-controlled integrator chatters at every velocity reversal.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from rmdrake.arrays import as_finite_array

__all__ = ["DEFAULT_V_EPS", "JointFriction", "friction_torque"]

DEFAULT_V_EPS = 1e-3
"""Default smooth-sign width v_eps in rad/s (tanh(v / v_eps))."""


def friction_torque(
    v: np.ndarray,
    fv: np.ndarray,
    fc: np.ndarray,
    v_eps: float = DEFAULT_V_EPS,
    exact_sign: bool = False,
) -> np.ndarray:
    """Friction torque fv * v + fc * s(v) in N m (the torque the joint loses).

    Args:
      v: joint velocities in rad/s, shape (..., n).
      fv: (n,) viscous coefficients, N m s/rad.
      fc: (n,) Coulomb coefficients, N m.
      v_eps: smooth-sign width in rad/s (ignored when ``exact_sign``).
      exact_sign: use sign(v) (0 at v = 0) instead of tanh(v / v_eps).
    """
    v = np.asarray(v, dtype=np.float64)
    s = np.sign(v) if exact_sign else np.tanh(v / v_eps)
    return fv * v + fc * s


class JointFriction(LeafSystem):
    """Viscous + Coulomb joint friction, as a generalized force on the plant.

    .. pydrake_system::

        name: JointFriction
        input_ports:
        - state  (or v)
        output_ports:
        - generalized_force

    ::

                   ┌───────────────┐
        state ────►│ JointFriction │────► generalized_force
        (or v)     └───────────────┘

    ``state`` is the plant state [q; v] (2n; only v is used) and ``v`` the joint
    velocities (n, rad/s), chosen by ``input``. The output is
    ``-(fv * v + fc * s(v))`` (n, N m), ready for the plant's
    ``applied_generalized_force`` input; see the module docstring for s.

    Parameters in the Context: one numeric parameter vector
    ``[fv (n, N m s/rad); fc (n, N m); v_eps (1, rad/s)]``, set and read with
    :meth:`SetFriction` and :meth:`GetFriction`. ``exact_sign`` is structural
    (a constructor option).
    """

    def __init__(
        self,
        *,
        fv: np.ndarray,
        fc: np.ndarray,
        v_eps: float = DEFAULT_V_EPS,
        exact_sign: bool = False,
        input: str = "state",
    ) -> None:
        super().__init__()
        fv = as_finite_array(fv, "fv", (None,))
        n = fv.shape[0]
        fc = as_finite_array(fc, "fc", (n,))
        _check_friction(fv, fc, v_eps)
        if input not in ("state", "v"):
            raise ValueError(f"input: expected 'state' or 'v', found {input!r}")
        self._n = n
        self._exact = bool(exact_sign)
        self._param = self.DeclareNumericParameter(
            BasicVector(np.concatenate([fv, fc, [float(v_eps)]]))
        )
        size = 2 * n if input == "state" else n
        self._offset = n if input == "state" else 0
        self._input = self.DeclareVectorInputPort(input, size)
        self.DeclareVectorOutputPort(
            "generalized_force",
            n,
            self._calc,
            {self.input_port_ticket(self._input.get_index()),
             self.all_parameters_ticket()},
        )  # fmt: skip

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self._n

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
    ) -> None:
        """Sets any of the friction parameters in ``context`` (units as above)."""
        old_fv, old_fc, old_eps = self.GetFriction(context)
        fv = old_fv if fv is None else as_finite_array(fv, "fv", (self._n,))
        fc = old_fc if fc is None else as_finite_array(fc, "fc", (self._n,))
        v_eps = old_eps if v_eps is None else float(v_eps)
        _check_friction(fv, fc, v_eps)
        context.get_mutable_numeric_parameter(self._param).SetFromVector(
            np.concatenate([fv, fc, [v_eps]])
        )

    def GetFriction(self, context: Context) -> tuple[np.ndarray, np.ndarray, float]:
        """(fv, fc, v_eps) from ``context``."""
        p = context.get_numeric_parameter(self._param).get_value()
        n = self._n
        return p[:n].copy(), p[n : 2 * n].copy(), float(p[2 * n])

    def _calc(self, context: Context, output: BasicVector) -> None:
        v = self._input.Eval(context)[self._offset :]
        p = context.get_numeric_parameter(self._param).get_value()
        n = self._n
        s = np.sign(v) if self._exact else np.tanh(v / p[2 * n])
        output.SetFromVector(-(p[:n] * v + p[n : 2 * n] * s))


def _check_friction(fv: np.ndarray, fc: np.ndarray, v_eps: float) -> None:
    for name, value in (("fv", fv), ("fc", fc)):
        if np.any(value < 0):
            j = int(np.flatnonzero(value < 0)[0])
            raise ValueError(
                f"{name}: expected >= 0 for every joint, found {value[j]} for "
                f"joint {j + 1}"
            )
    if not np.isfinite(v_eps) or v_eps <= 0:
        raise ValueError(f"v_eps: expected a positive width in rad/s, found {v_eps}")
