"""The desired motion of the station: the Fourier excitation, or any joint-space
pydrake ``Trajectory`` such as the point-to-point setpoints of a calibration run.

:func:`rmdrake.systems.station.MakeStation` takes either as its ``trajectory``
and adds its source with :func:`AddDesiredMotion`. Both sources have the output
ports ``state`` (2n, desired [q; v] in rad, rad/s) and ``vdot`` (n, desired
acceleration in rad/s^2) that the controller reads (m, m/s, m/s^2 for a prismatic
joint, here and below):

* a :class:`~rmdrake.excitation.trajectory.FourierTrajectory` becomes a
  :class:`~rmdrake.systems.excitation.FourierExcitationSource` named
  ``excitation`` (Drake's Sine and gains, periodic);
* a pydrake ``Trajectory`` (an (n, 1) column of joint angles in rad over time
  in s) becomes a :class:`JointTrajectorySource` named ``desired_motion``:
  a Drake ``TrajectorySource`` with ``output_derivative_order=2``, so q, v and
  vdot are the trajectory's value and exact derivatives. Before its start time
  it outputs the start value, after its end time the end value with zero
  derivatives.

:func:`setpoint_trajectory` builds the point-to-point motion of a measurement
run: smooth moves between joint configurations with holds in between;
:func:`motion_effort` says what following such a motion asks of a robot's
actuators.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.polynomial import Polynomial
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.primitives import Demultiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial, Trajectory

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.robot import RobotModel, require_dynamics
from rmdrake.systems.excitation import FourierExcitationSource

__all__ = [
    "DesiredMotion",
    "JointTrajectorySource",
    "AddDesiredMotion",
    "check_motion",
    "motion_duration",
    "motion_effort",
    "motion_start",
    "require_effort",
    "setpoint_move_times",
    "setpoint_times",
    "setpoint_trajectory",
]

_PEAK_V = 1.875  # max of d/ds (10 s^3 - 15 s^4 + 6 s^5) on [0, 1]
_PEAK_A = 10.0 / math.sqrt(3.0)  # max of its second derivative

DesiredMotion = FourierTrajectory | Trajectory
"""What ``MakeStation`` accepts as its ``trajectory``."""


class JointTrajectorySource(Diagram):
    """Desired joint motion from a pydrake ``Trajectory`` of joint angles.

    .. pydrake_system::

        name: JointTrajectorySource
        output_ports:
        - state
        - vdot

    ::

        ┌───────────────────────┐────► state  (2n, [q; v], rad or m, /s)
        │ JointTrajectorySource │
        └───────────────────────┘────► vdot   (n, rad/s^2 or m/s^2)

    Inside: a ``TrajectorySource(trajectory, output_derivative_order=2,
    zero_derivatives_beyond_limits=True)`` giving [q; v; vdot] and a
    ``Demultiplexer`` splitting it. The trajectory is part of the system (Drake's
    ``TrajectorySource`` keeps it as a member, not in the Context): a different
    motion needs a new source, hence a new station.

    Args:
      trajectory: (n, 1) joint positions (rad or m) over time in s, with
        derivatives (a ``PiecewisePolynomial``, for example); copied.

    Example:

    >>> import numpy as np
    >>> from rmdrake.systems import JointTrajectorySource, setpoint_trajectory
    >>> path = setpoint_trajectory(np.ones((1, 2)), move_time=1.0, settle_time=0.5)
    >>> source = JointTrajectorySource(trajectory=path)
    >>> [source.get_output_port(i).get_name() for i in range(2)]
    ['state', 'vdot']
    """

    def __init__(self, *, trajectory: Trajectory) -> None:
        super().__init__()
        if trajectory.cols() != 1:
            raise ValueError(
                f"trajectory: expected a column (n, 1) of joint angles, found "
                f"({trajectory.rows()}, {trajectory.cols()})"
            )
        n = trajectory.rows()
        self._trajectory = trajectory.Clone()
        builder = DiagramBuilder()
        source = builder.AddNamedSystem(
            "trajectory", TrajectorySource(trajectory, 2, True)
        )
        split = builder.AddNamedSystem("split", Demultiplexer([2 * n, n]))
        builder.Connect(source.get_output_port(), split.get_input_port())
        builder.ExportOutput(split.get_output_port(0), "state")
        builder.ExportOutput(split.get_output_port(1), "vdot")
        builder.BuildInto(self)
        self._n = n

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self._n

    def trajectory(self) -> Trajectory:
        """A copy of the trajectory (rad or m over s)."""
        return self._trajectory.Clone()


def check_motion(trajectory: DesiredMotion, model: RobotModel) -> None:
    """TypeError unless ``trajectory`` is a FourierTrajectory or a pydrake
    Trajectory; ValueError unless it has ``model``'s joint count (as a column)."""
    if isinstance(trajectory, FourierTrajectory):
        trajectory.check_joint_count(model)
        return
    if not isinstance(trajectory, Trajectory):
        raise TypeError(
            "trajectory: expected a FourierTrajectory or a pydrake Trajectory, "
            f"found {type(trajectory).__name__}"
        )
    shape = (trajectory.rows(), trajectory.cols())
    if shape != (model.n_joints, 1):
        raise ValueError(
            f"trajectory has shape {shape} but robot '{model.name}' needs "
            f"({model.n_joints}, 1)"
        )


def AddDesiredMotion(
    builder: DiagramBuilder, trajectory: DesiredMotion
) -> FourierExcitationSource | JointTrajectorySource:
    """Adds the source of ``trajectory`` to ``builder`` (see the module
    docstring for which and its name); returns it, ports unconnected."""
    if isinstance(trajectory, FourierTrajectory):
        return FourierExcitationSource.AddToBuilder(builder, trajectory=trajectory)
    return builder.AddNamedSystem(
        "desired_motion", JointTrajectorySource(trajectory=trajectory)
    )


def motion_start(trajectory: DesiredMotion) -> np.ndarray:
    """(n,) desired joint positions (rad or m) where the motion starts: q0 of a Fourier
    trajectory (its value at t = 0), else the value at ``start_time()``."""
    if isinstance(trajectory, FourierTrajectory):
        return np.asarray(trajectory.q0, dtype=float)
    return trajectory.value(trajectory.start_time())[:, 0]


def motion_duration(
    source: FourierExcitationSource | JointTrajectorySource,
    context: Context,
    periods: float | None,
    duration: float | None,
) -> float:
    """Length in s of a station run from the root ``context``'s time.

    ``duration`` when given; else, for a Fourier source, ``periods`` (default
    1) times the period in the context; for a trajectory source, up to the
    trajectory's end time.

    Raises:
      ValueError: both given, a value that is not finite and > 0, ``periods``
        for a trajectory source (it has no period), or a run that would end
        at or before the context's time.
    """
    for name, value in (("periods", periods), ("duration", duration)):
        if value is not None and (not math.isfinite(value) or value <= 0):
            unit = " s" if name == "duration" else ""
            raise ValueError(f"{name}: expected > 0{unit}, found {value}")
    if periods is not None and duration is not None:
        raise ValueError("periods, duration: give one or the other")
    if duration is not None:
        return float(duration)
    if isinstance(source, FourierExcitationSource):
        return (1.0 if periods is None else float(periods)) * source.trajectory.period
    if periods is not None:
        raise ValueError(
            "periods: the station follows a Trajectory, which has no period; "
            "give duration (s) or neither (runs to its end time)"
        )
    remaining = source.trajectory().end_time() - context.get_time()
    if not remaining > 0:
        raise ValueError(
            f"the trajectory ends at {source.trajectory().end_time()} s, not after "
            f"the context's time {context.get_time()} s: give duration (s)"
        )
    return float(remaining)


def _move_times(move_time: object, N: int) -> np.ndarray:
    """``move_time`` (one value or N, s) as an (N,) array of positive values."""
    times = as_finite_array(move_time, "move_time", None)
    times = np.full(N, float(times)) if times.ndim == 0 else times
    if times.shape != (N,) or np.any(times <= 0):
        raise ValueError(
            f"move_time: expected one value or {N} values > 0 s, found {move_time}"
        )
    return times


def setpoint_times(
    count: int,
    *,
    move_time: float | np.ndarray,
    settle_time: float,
    start_time: float = 0.0,
) -> np.ndarray:
    """(count,) times in s at the end of each hold of :func:`setpoint_trajectory`
    (same arguments): ``start_time + sum_{k <= i} (move_time_k + settle_time)``,
    i = 0..count-1.

    Example:

    >>> from rmdrake.systems import setpoint_times
    >>> setpoint_times(3, move_time=1.0, settle_time=0.5).tolist()  # end of each hold
    [1.5, 3.0, 4.5]
    """
    return start_time + np.cumsum(_move_times(move_time, count) + settle_time)


def setpoint_trajectory(
    q_list: np.ndarray,
    *,
    move_time: float | np.ndarray,
    settle_time: float,
    q_start: np.ndarray | None = None,
    start_time: float = 0.0,
) -> PiecewisePolynomial:
    """Point-to-point joint motion through the configurations ``q_list``.

    Interval i (i = 0..N-1) starts with a move of ``move_time[i]`` s from the
    previous configuration (``q_start`` for i = 0) to ``q_list[i]`` along the
    quintic q_a + (q_b - q_a) (10 s^3 - 15 s^4 + 6 s^5), s = elapsed / move
    time (zero velocity and acceleration at both ends; peak velocity 1.875
    |q_b - q_a| / move time, peak acceleration 5.77 |q_b - q_a| / move time^2;
    :func:`setpoint_move_times` keeps them within limits), then holds at
    ``q_list[i]`` for ``settle_time`` s. The holds end at
    :func:`setpoint_times`, where a reading is taken. The polynomial
    coefficients are exact (no fit), so are the trajectory's derivatives.

    Args:
      q_list: (N, n) joint configurations, rad or m.
      move_time: duration of every move, or (N,) of each, s (> 0).
      settle_time: duration of each hold, s (>= 0).
      q_start: (n,) configuration at ``start_time``, rad or m; default
        ``q_list[0]`` (the first move is then a hold).
      start_time: s.

    Returns:
      A ``PiecewisePolynomial`` (n, 1) from ``start_time`` to the last hold's
      end.

    Example:

    >>> import numpy as np
    >>> from rmdrake.systems import setpoint_trajectory
    >>> poses = np.array([[0.0, 0.5], [0.5, 0.0]])  # two setpoints of a 2-joint arm
    >>> path = setpoint_trajectory(
    ...     poses, move_time=1.0, settle_time=0.5, q_start=[0.0, 0.0]
    ... )
    >>> path.end_time(), path.value(1.0).ravel().round(6).tolist()
    (3.0, [0.0, 0.5])
    """
    q_list = as_finite_array(q_list, "q_list", (None, None))
    N, n = q_list.shape
    if N == 0:
        raise ValueError("q_list: expected at least one configuration")
    moves = _move_times(move_time, N)
    T_hold = float(settle_time)
    if not (math.isfinite(T_hold) and T_hold >= 0):
        raise ValueError(f"settle_time: expected >= 0 s, found {settle_time}")
    q_a = q_list[0] if q_start is None else as_finite_array(q_start, "q_start", (n,))
    ends = setpoint_times(N, move_time=moves, settle_time=T_hold, start_time=0.0)
    segments, breaks = [], [float(start_time)]
    for i in range(N):
        # The quintic in the segment's local time tau: q_a + dq (10 tau^3 / T^3
        # - 15 tau^4 / T^4 + 6 tau^5 / T^5), T the move time.
        quintic = np.array([10.0, -15.0, 6.0]) / moves[i] ** np.arange(3.0, 6.0)
        coefficients = np.zeros((n, 6))
        coefficients[:, 0] = q_a
        coefficients[:, 3:] = (q_list[i] - q_a)[:, None] * quintic
        segments.append(np.array([[Polynomial(c)] for c in coefficients]))
        breaks.append(start_time + ends[i] - T_hold)
        if T_hold > 0:
            segments.append(np.array([[Polynomial([v])] for v in q_list[i]]))
            breaks.append(start_time + ends[i])
        q_a = q_list[i]
    return PiecewisePolynomial(segments, breaks)


def setpoint_move_times(
    q_list: np.ndarray,
    *,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    q_start: np.ndarray | None = None,
) -> np.ndarray:
    """(N,) shortest duration in s of each move of :func:`setpoint_trajectory`
    that keeps every joint's |v| <= ``velocity`` (n, rad/s or m/s) and |vdot| <=
    ``acceleration`` (n, rad/s^2 or m/s^2): for move i, the largest over the joints of
    max(1.875 |dq| / v_max, sqrt(5.77 |dq| / a_max)), dq the joint's step in
    rad; 0 for a move that moves nothing. Their maximum is a uniform
    ``move_time``.

    Example:

    >>> import numpy as np
    >>> from rmdrake.systems import setpoint_move_times
    >>> poses = np.array([[1.0, 0.0]])
    >>> v_max, a_max = np.array([1.0, 1.0]), np.array([10.0, 10.0])
    >>> times = setpoint_move_times(
    ...     poses, velocity=v_max, acceleration=a_max, q_start=[0.0, 0.0]
    ... )
    >>> times.round(3).tolist()
    [1.875]
    """
    q_list = as_finite_array(q_list, "q_list", (None, None))
    n = q_list.shape[1]
    first = q_list[:1] if q_start is None else as_finite_array(q_start, "q_start", (n,))
    step = np.abs(np.diff(np.vstack([np.reshape(first, (1, n)), q_list]), axis=0))
    v_max = as_finite_array(velocity, "velocity", (n,))
    a_max = as_finite_array(acceleration, "acceleration", (n,))
    if np.any(v_max <= 0) or np.any(a_max <= 0):
        raise ValueError("velocity, acceleration: expected positive limits")
    need = np.maximum(_PEAK_V * step / v_max, np.sqrt(_PEAK_A * step / a_max))
    return need.max(axis=1)


def motion_effort(
    model: RobotModel,
    trajectory: PiecewisePolynomial,
    *,
    v_eps: float = DEFAULT_V_EPS,
    max_step: float = 0.01,
) -> tuple[np.ndarray, np.ndarray]:
    """The effort (torque, or force on a prismatic joint) ``model``'s joints
    need to follow ``trajectory`` (an (n, 1) ``PiecewisePolynomial`` of joint
    positions in rad or m over s, e.g. from :func:`setpoint_trajectory`), as a
    fraction of their effort limits (N m or N).

    tau = the rigid-body inverse dynamics (rotor inertia, payload and gravity
    included) + fv v + fc tanh(v / v_eps), with ``model``'s own parameters, by
    :func:`rmdrake.dynamics.torques` (what its MultibodyPlant's inverse
    dynamics and :class:`~rmdrake.systems.friction.JointFriction` give), in one
    vectorised evaluation at evenly spaced times in each segment, ends
    included, at least 8 and enough that no joint moves more than
    ``max_step`` (rad or m) between samples when it moves monotonically (as in the
    quintic moves). No servo holds a motion that needs more than 1: the plant
    clamps the actuation at the effort limit and the joint gives way.

    Returns:
      (peak (n,): max over the samples of |tau_j| / effort_j; t_peak (n,): the
      time of each joint's peak, s).
    """
    check_motion(trajectory, model)
    if not (math.isfinite(max_step) and max_step > 0):
        raise ValueError(f"max_step: expected > 0 rad or m, found {max_step}")
    breaks = np.asarray(trajectory.get_segment_times())
    travel = np.abs(np.diff(trajectory.vector_values(breaks), axis=1)).max(axis=0)
    count = np.maximum(8, np.ceil(travel / max_step).astype(np.int64) + 1)
    segment = np.repeat(np.arange(count.size), count)
    first = np.cumsum(count) - count
    s = (np.arange(segment.size) - first[segment]) / (count[segment] - 1)
    t = breaks[segment] + s * np.diff(breaks)[segment]
    q, v, vdot = (trajectory.derivative(k).vector_values(t).T for k in range(3))
    tau = torques(model, q, v, vdot, standard_parameters(model), coulomb_width=v_eps)
    ratio = np.abs(tau) / model.limits.effort
    return ratio.max(axis=0), t[ratio.argmax(axis=0)]


def require_effort(
    model: RobotModel, trajectory: PiecewisePolynomial, *, v_eps: float
) -> None:
    """ValueError unless ``model``'s actuators can follow ``trajectory`` (an
    (n, 1) ``PiecewisePolynomial`` of joint positions, rad or m over s):
    :func:`motion_effort` (its own dynamics and payload, friction of smoothing
    ``v_eps`` in rad/s or m/s) at most 1 on every joint. Beyond it the plant
    clamps the actuation, the joint gives way under its load and the
    computed-torque servo, fighting it, drives every joint to its limits: a
    demo_rh whose joint 4 needed up to 1.04 x its effort limit to hold its
    payload ended 1e4 rad away, and its encoders read angles of an arm that
    had fallen. Slower moves do not help a static load. A kinematic-only
    model is refused by name (:func:`~rmdrake.model.robot.require_dynamics`).
    Run before a station simulates the true robot along planned moves."""
    require_dynamics(model, "the simulated station runs", role="true robot")
    peak, t_peak = motion_effort(model, trajectory, v_eps=v_eps)
    if np.all(peak <= 1.0):
        return
    j = int(np.argmax(peak))
    unit = "N" if model.sigma[j] == 1 else "N m"  # a slide's effort is a force
    raise ValueError(
        f"true_model: robot '{model.name}' cannot follow the planned moves: "
        f"joint {j + 1} needs {peak[j]:.3g} x its effort limit "
        f"({model.limits.effort[j]:.3g} {unit}) at t = {t_peak[j]:.1f} s "
        f"({np.sum(peak > 1)} joint(s) over); check its link masses and payload "
        "(the static load), or plan slower moves or other poses"
    )
