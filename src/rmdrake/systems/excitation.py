"""The Fourier excitation trajectory (paper eq. 11-13) as a Drake source system.

For a plain ``TrajectorySource`` use :class:`FourierTrajectoryView` instead;
:class:`FourierExcitationSource` evaluates the series in Drake's own systems
(a ``Sine`` and gains), :class:`FourierTrajectoryView` with
:func:`rmdrake.excitation.trajectory.fourier_series`.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import AffineSystem, MatrixGain, Multiplexer, Sine
from pydrake.trajectories import Trajectory

from rmdrake.excitation.trajectory import FourierTrajectory

__all__ = ["FourierExcitationSource", "FourierTrajectoryView"]


class FourierExcitationSource(Diagram):
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
    ``vdot`` its desired acceleration. Outputs follow the series at every
    time, t < 0 included (it is periodic).

    Inside, Drake's own systems, so a simulation step evaluates no Python: a
    ``Sine`` (``harmonics``) with one entry per joint j and harmonic l,
    amplitude sqrt(a_jl^2 + b_jl^2) / w_l and phase atan2(-b_jl, a_jl) at
    w_l = 2 pi f l (so a_jl sin(w_l t) / w_l - b_jl cos(w_l t) / w_l, eq. 11),
    whose value and first two time derivatives the gains ``q_sum`` (an
    AffineSystem adding q0), ``v_sum`` and ``vdot_sum`` add up per joint, and a
    ``Multiplexer`` (``state``). Equal to
    :func:`rmdrake.excitation.trajectory.fourier_series` to round-off. The
    trajectory is part of the system (Drake keeps these values as members,
    not in the Context): another trajectory needs another source.

    Args:
      trajectory: the trajectory (keyword-only); it fixes n and N.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.systems import FourierExcitationSource
    >>> trajectory = random_fourier_trajectory(load_robot("rv3sb"), seed=0)
    >>> source = FourierExcitationSource(trajectory=trajectory)
    >>> source.n_joints, source.num_output_ports() > 0
    (6, True)
    """

    def __init__(self, *, trajectory: FourierTrajectory) -> None:
        super().__init__()
        n, N = trajectory.n_joints, trajectory.harmonics
        self._n, self._N, self._trajectory = n, N, trajectory
        a, b = np.asarray(trajectory.a), np.asarray(trajectory.b)
        w = 2.0 * math.pi * trajectory.base_frequency * np.arange(1, N + 1)
        builder = DiagramBuilder()
        sine = builder.AddNamedSystem(
            "harmonics",
            Sine(
                amplitudes=(np.hypot(a, b) / w).ravel(),
                frequencies=np.tile(w, n),
                phases=np.arctan2(-b, a).ravel(),
                is_time_based=True,
            ),
        )
        G = np.kron(np.eye(n), np.ones((1, N)))  # (n, nN): sum per joint
        q = builder.AddNamedSystem(
            "q_sum",
            AffineSystem(
                np.zeros((0, 0)), np.zeros((0, n * N)), np.zeros(0),
                np.zeros((n, 0)), G, np.asarray(trajectory.q0, float),
            ),
        )  # fmt: skip
        v = builder.AddNamedSystem("v_sum", MatrixGain(G))
        vdot = builder.AddNamedSystem("vdot_sum", MatrixGain(G))
        state = builder.AddNamedSystem("state", Multiplexer([n, n]))
        for k, gain in enumerate((q, v, vdot)):
            builder.Connect(sine.get_output_port(k), gain.get_input_port())
        builder.Connect(q.get_output_port(), state.get_input_port(0))
        builder.Connect(v.get_output_port(), state.get_input_port(1))
        for name, system in (("q", q), ("v", v), ("vdot", vdot), ("state", state)):
            builder.ExportOutput(system.get_output_port(), name)
        builder.BuildInto(self)

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

    @property
    def trajectory(self) -> FourierTrajectory:
        """The trajectory this source follows."""
        return self._trajectory


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

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> import numpy as np
    >>> from rmdrake.systems import FourierTrajectoryView
    >>> trajectory = random_fourier_trajectory(load_robot("rv3sb"), seed=0)
    >>> view = FourierTrajectoryView(trajectory)
    >>> view.rows(), view.cols()
    (6, 1)
    >>> bool(np.allclose(view.value(0.0).ravel(), trajectory.q0))  # starts at q0
    True
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
