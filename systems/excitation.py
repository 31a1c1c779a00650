"""The Fourier excitation trajectory (paper eq. 11-13) as a Drake source system.

For a plain ``TrajectorySource`` use :class:`FourierTrajectoryView` instead;
:class:`FourierExcitationSource` keeps the coefficients in the Context, so one
diagram can run many trajectories. Both evaluate the series with
:func:`rmdrake.excitation.trajectory.fourier_series`.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    LeafSystem,
    ValueProducer,
)
from pydrake.trajectories import Trajectory

from rmdrake.excitation.trajectory import FourierTrajectory, fourier_series

__all__ = ["FourierExcitationSource", "FourierTrajectoryView"]


class FourierExcitationSource(LeafSystem):
    """Desired joint motion from a Fourier trajectory, evaluated at context time.

    .. pydrake_system::

        name: FourierExcitationSource
        output_ports:
        - q
        - v
        - vdot
        - state

    ::

        ┌─────────────────────────┐────► q      (n, rad or m)
        │ FourierExcitationSource │────► v      (n, rad/s or m/s)
        │                         │────► vdot   (n, rad/s^2 or m/s^2)
        └─────────────────────────┘────► state  (2n, [q; v])

    ``state`` is the desired state of an ``InverseDynamicsController`` and
    ``vdot`` its desired acceleration. The trajectory lives in the Context as
    one numeric parameter vector ``[base_frequency (Hz); q0 (n, rad or m);
    a (n*N, rad/s or m/s, row-major (n, N)); b (likewise)]``; n and N are fixed at
    construction. Set and get it with :meth:`SetTrajectory` and
    :meth:`GetTrajectory`. The four outputs share one cached evaluation of
    :func:`rmdrake.excitation.trajectory.fourier_series` per time and parameter value.
    Outputs follow the series at every time, t < 0 included (it is periodic).

    Args:
      trajectory: the initial trajectory (keyword-only); it fixes n and N.
    """

    def __init__(self, *, trajectory: FourierTrajectory) -> None:
        super().__init__()
        n, N = trajectory.n_joints, trajectory.harmonics
        self._n, self._N = n, N
        self._param = self.DeclareNumericParameter(BasicVector(_pack(trajectory)))
        deps = {self.time_ticket(), self.all_parameters_ticket()}
        # q, v and vdot share one evaluation of the sines and cosines per time.
        self._motion = self.DeclareCacheEntry(
            "desired motion [q; v; vdot]",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(BasicVector(3 * n)),
                calc=self._calc_motion,
            ),
            deps,
        )
        ticket = {self._motion.ticket()}
        for name, lo, hi in (
            ("q", 0, n), ("v", n, 2 * n), ("vdot", 2 * n, 3 * n), ("state", 0, 2 * n),
        ):  # fmt: skip
            self.DeclareVectorOutputPort(
                name,
                hi - lo,
                lambda c, o, lo=lo, hi=hi: o.SetFromVector(
                    self._motion.Eval(c).get_value()[lo:hi]
                ),
                ticket,
            )

    @classmethod
    def AddToBuilder(
        cls,
        builder: DiagramBuilder,
        *,
        trajectory: FourierTrajectory,
        name: str = "excitation",
    ) -> FourierExcitationSource:
        """Adds a source of ``trajectory`` named ``name`` to ``builder`` and returns
        it (its ports are left unconnected)."""
        return builder.AddNamedSystem(name, cls(trajectory=trajectory))

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self._n

    @property
    def harmonics(self) -> int:
        """Number of harmonics N."""
        return self._N

    def SetTrajectory(self, context: Context, trajectory: FourierTrajectory) -> None:
        """Stores ``trajectory`` (same n and N as at construction) in ``context``."""
        if (trajectory.n_joints, trajectory.harmonics) != (self._n, self._N):
            raise ValueError(
                f"trajectory: expected {self._n} joints and {self._N} harmonics, "
                f"found {trajectory.n_joints} and {trajectory.harmonics}"
            )
        context.get_mutable_numeric_parameter(self._param).SetFromVector(
            _pack(trajectory)
        )

    def GetTrajectory(self, context: Context) -> FourierTrajectory:
        """The trajectory stored in ``context``."""
        f, q0, a, b = self._unpack(context)
        return FourierTrajectory(base_frequency=f, q0=q0, a=a, b=b)

    def _unpack(
        self, context: Context
    ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        p = context.get_numeric_parameter(self._param).get_value()
        n, nN = self._n, self._n * self._N
        return (
            float(p[0]),
            p[1 : 1 + n],
            p[1 + n : 1 + n + nN].reshape(n, self._N),
            p[1 + n + nN :].reshape(n, self._N),
        )

    def _calc_motion(self, context: Context, value: AbstractValue) -> None:
        f, q0, a, b = self._unpack(context)
        q, v, vdot = fourier_series(
            context.get_time(), base_frequency=f, q0=q0, a=a, b=b, orders=(0, 1, 2)
        )
        value.get_mutable_value().SetFromVector(np.concatenate([q, v, vdot]))


def _pack(trajectory: FourierTrajectory) -> np.ndarray:
    return np.concatenate(
        [[trajectory.base_frequency], trajectory.q0, trajectory.a.ravel(),
         trajectory.b.ravel()]
    )  # fmt: skip


class FourierTrajectoryView(Trajectory):
    """A :class:`~rmdrake.excitation.trajectory.FourierTrajectory` as a pydrake
    ``Trajectory`` (an (n, 1) column), for a ``TrajectorySource``.

    Values and derivatives of every order are evaluated exactly (no
    interpolation), so ``TrajectorySource(FourierTrajectoryView(traj),
    output_derivative_order=2)`` outputs [q; qd; qdd] (rad, rad/s, rad/s^2;
    m, m/s, m/s^2 on a prismatic joint).
    ``end_time`` (s, default infinite) is what ``end_time()`` reports; keep it
    infinite in a ``TrajectorySource``, which outputs zero derivatives after it.
    ``order`` > 0 views that derivative of the trajectory.
    """

    def __init__(
        self, traj: FourierTrajectory, order: int = 0, end_time: float = math.inf
    ) -> None:
        Trajectory.__init__(self)
        self._traj = traj
        self._order = order
        self._end = end_time

    def __deepcopy__(self, memo: dict) -> FourierTrajectoryView:
        # TrajectorySource deep-copies its trajectory; the data are immutable.
        return FourierTrajectoryView(self._traj, self._order, self._end)

    def DoClone(self) -> FourierTrajectoryView:
        return FourierTrajectoryView(self._traj, self._order, self._end)

    def do_rows(self) -> int:
        return self._traj.n_joints

    def do_cols(self) -> int:
        return 1

    def do_start_time(self) -> float:
        return 0.0

    def do_end_time(self) -> float:
        return self._end

    def do_value(self, t: float) -> np.ndarray:
        return self._traj.derivative(float(t), self._order)[:, None]

    def do_has_derivative(self) -> bool:
        return True

    def DoEvalDerivative(self, t: float, derivative_order: int) -> np.ndarray:
        return self._traj.derivative(float(t), self._order + derivative_order)[:, None]

    def DoMakeDerivative(self, derivative_order: int) -> FourierTrajectoryView:
        return FourierTrajectoryView(
            self._traj, self._order + derivative_order, self._end
        )
