"""Running a built station (:func:`rmdrake.systems.station.MakeStation`): the
simulation from its context's time under ``config.simulator``, returning the
measured joint log (and any other logged signal, such as the link-side
positions of an elastic robot).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import Context, EventStatus

from rmdrake.io import JointLog
from rmdrake.systems.station_sources import motion_duration

if TYPE_CHECKING:
    from rmdrake.systems.station import Station

__all__ = ["RunStation"]

_JOINT_LOG = ("q", "qd", "qdd", "tau")


def RunStation(
    station: Station,
    *,
    periods: float | None = None,
    duration: float | None = None,
    context: Context | None = None,
    progress: Callable[[float, float], None] | None = None,
    other_logs: dict[str, np.ndarray] | None = None,
) -> JointLog:
    """Simulates the station from its context's time; returns the log.

    The integrator is ``station.config.simulator`` (applied with Drake's
    ``ApplySimulatorConfig``); the run starts at the context's time.

    Args:
      station: from :func:`MakeStation`.
      periods: number of periods of a Fourier trajectory to run (the duration
        is periods / base_frequency of the trajectory in the context); default
        1. Not for a Trajectory (no period).
      duration: or the run's length in s; default, for a Trajectory, up to
        its end time (ValueError for both, or for periods with a Trajectory).
      context: the initial root context (default
        :meth:`Station.CreateDefaultContext`), for example with other
        parameters; it is copied, not modified, and its logs must be empty.
      progress: called as ``progress(t, t_final)`` (s) as the simulation goes.
      other_logs: if given, filled with the samples (M, size) of the loggers
        that are not in the JointLog (``q_link`` of an elastic robot).

    Returns:
      The samples at t0, t0 + log_period, ... strictly below the end time
      (periods * rate / base_frequency samples, 1500 for one period of the
      paper's trajectory): measured q, qd, qdd and tau.
    """
    if context is None:
        context = station.CreateDefaultContext()
    else:
        context = context.Clone()  # the Simulator takes ownership of its context
    t0 = context.get_time()
    t_final = t0 + motion_duration(station.source, context, periods, duration)
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(station.config.simulator, simulator)
    context.SetTime(t0)  # ApplySimulatorConfig sets the time to start_time
    if progress is not None:

        def monitor(root: Context) -> EventStatus:
            progress(root.get_time(), t_final)
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
    simulator.Initialize()
    # Stop just before the end so the log holds the samples in [t0, t_final).
    half = 0.5 * station.log_period
    simulator.AdvanceTo(t_final - half)
    logs = {k: v.FindLog(context) for k, v in station.loggers.items()}
    t = logs["q"].sample_times()
    keep = t < t_final - half
    data = {k: v.data()[:, keep].T for k, v in logs.items()}
    if other_logs is not None:
        other_logs.update({k: v for k, v in data.items() if k not in _JOINT_LOG})
    return JointLog(
        t=t[keep], q=data["q"], tau=data["tau"], qd=data["qd"], qdd=data["qdd"]
    )
