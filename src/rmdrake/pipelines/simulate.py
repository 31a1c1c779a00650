"""``rmdrake simulate``: a robot run on a Fourier trajectory in the Drake
station, its joint log written; which model the controller uses, the run with
progress, and what the log says about effort saturation."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.excitation.trajectory import (
    FourierTrajectory,
    check_sampling,
    load_fourier,
)
from rmdrake.model.loading import controller_model_for, load_robot
from rmdrake.model.robot import RobotModel, require_dynamics
from rmdrake.model.same_robot import check_same_robot
from rmdrake.pipelines.checked import Echo
from rmdrake.progress import simulated_time_progress
from rmdrake.systems.station import MakeStation, RunStation
from rmdrake.systems.station_config import (
    COUPLED_RATE,
    SensorConfig,
    StationConfig,
    discrete_time_step,
)

__all__ = [
    "MAX_NOISE_SHARE",
    "check_sensor_noise",
    "simulate_file",
    "log_summary",
    "saturation_warnings",
    "simulate_trajectory",
    "station_config",
]

MAX_NOISE_SHARE = 1.0
"""The largest torque noise std, as a share of each joint's effort limit: a
sensor whose noise is the joint's whole effort measures nothing (real torque
sensors: well under 1 %). The encoder's resolution has its bound in the
station (:data:`~rmdrake.systems.station.MAX_RESOLUTION_SHARE`)."""


def check_sensor_noise(model: RobotModel, torque_noise: object = 0.0) -> None:
    """Refuses, before the station is built, a torque noise std (N m or N,
    one or per joint) over :data:`MAX_NOISE_SHARE` x the joint's effort
    limit.

    Raises:
      ValueError: one line naming the option, the joint and the bound."""
    n = model.n_joints
    x = np.asarray(torque_noise, dtype=np.float64).ravel()
    if model.limits.effort is None or x.size not in (1, n):
        return  # the sensor's own checks name a wrong count
    x = np.broadcast_to(x, (n,))
    bound = MAX_NOISE_SHARE * np.asarray(model.limits.effort, dtype=np.float64)
    over = np.flatnonzero(np.isfinite(bound) & (x > bound))
    if over.size:
        j = int(over[0])
        unit = "N" if model.sigma[j] == 1 else "N m"
        raise ValueError(
            f"--noise {x[j]:.4g} {unit}: over {MAX_NOISE_SHARE:g}x joint {j + 1}'s "
            f"effort limit ({bound[j]:.4g} {unit}); no torque sensor of this robot "
            f"is that noisy (another unit? {unit})"
        )


def simulate_trajectory(
    config: StationConfig,
    true_model: RobotModel,
    nominal_model: RobotModel,
    trajectory: FourierTrajectory,
    *,
    periods: float = 1.0,
    progress: Callable[[float, float], None] | None = None,
) -> tuple[JointLog, float]:
    """Runs ``periods`` periods of ``trajectory`` on the station; returns the
    log and the wall time in s.

    Raises:
      ValueError: joint counts or limits that do not match the trajectory, a
        robot without dynamics, a bad configuration value.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.pipelines import simulate_trajectory, station_config
    >>> robot = load_robot("rv3sb")
    >>> trajectory = random_fourier_trajectory(robot, seed=0)
    >>> log, wall = simulate_trajectory(
    ...     station_config(), robot, robot, trajectory, periods=0.02
    ... )
    >>> log.q.shape[1], bool(log.t[-1] <= 0.2 + 1e-9)
    (6, True)
    """
    trajectory.check_limits(true_model)
    station = MakeStation(
        config,
        true_model=true_model,
        trajectory=trajectory,
        nominal_model=nominal_model,
    )
    t0 = time.perf_counter()
    log = RunStation(station, periods=periods, progress=progress)
    return log, time.perf_counter() - t0


def _slides(sigma: object, n: int) -> np.ndarray:
    """(n,) bool, True for a prismatic joint (``sigma`` None: all revolute)."""
    return np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1


def saturation_warnings(
    log: JointLog, effort: np.ndarray, *, sigma: object = None
) -> list[str]:
    """One message per joint whose logged effort reached its limit (N m, or N
    for a prismatic joint as ``sigma`` (n,) says; None: all revolute): the
    plant clamps actuation there, so tracking suffers.

    Example:

    >>> import numpy as np
    >>> from rmdrake import JointLog
    >>> from rmdrake.pipelines import saturation_warnings
    >>> tau = np.array([[5.0, 1.0], [10.0, 1.0]])  # N m; joint 1 reaches 10 N m
    >>> log = JointLog(t=np.arange(2.0), q=np.zeros((2, 2)), tau=tau)
    >>> warnings = saturation_warnings(log, effort=np.array([10.0, 10.0]))
    >>> len(warnings), warnings[0].split(" in ")[0]
    (1, 'joint 1 saturated at its effort limit 10 N m')
    """
    peak = np.abs(log.tau).max(axis=0)
    slide = _slides(sigma, peak.size)
    messages = []
    for j in np.flatnonzero(peak >= effort * (1.0 - 1e-9)):
        share = np.mean(np.abs(log.tau[:, j]) >= effort[j] * (1.0 - 1e-9))
        messages.append(
            f"joint {j + 1} saturated at its effort limit {effort[j]:.4g} "
            f"{'N' if slide[j] else 'N m'} in {100 * share:.1f} % of the samples "
            "(tracking suffers; lower the trajectory's accelerations)"
        )
    return messages


def station_config(
    *,
    rate: float = 150.0,
    accuracy: float = 1e-4,
    v_eps: float | None = None,
    torque_noise: float | list[float] = 0.0,
    encoder_resolution: float | list[float] = 0.0,
    seed: int = 0,
    bandwidth: float | None = None,
) -> StationConfig:
    """The default station, logging at ``rate`` Hz (the integrator's largest
    step is one log period), with the RK3 ``accuracy``, the true robot's Coulomb
    smoothing ``v_eps`` (rad/s, or m/s for a prismatic joint; None: the
    default), the joint sensors (effort noise std in N m or N, encoder
    resolution in rad or m per count, noise seed) and the controller's
    feedback ``bandwidth`` (rad/s; None: the default, too high for an elastic
    arm, whose lowest structural mode it must stay below).

    Raises:
      ValueError: accuracy outside (0, 1); a bandwidth over the log rate's
        Nyquist frequency, pi x ``rate`` rad/s (a loop faster than its own
        sampling is no controller's; 1e9 rad/s drove q1 from -29 to 50 rad).

    Example:

    >>> from rmdrake.pipelines import station_config
    >>> config = station_config(rate=100.0, torque_noise=0.05, seed=2)
    >>> round(1 / config.log_period), config.sensors.torque_noise, config.sensors.seed
    (100, 0.05, 2)
    """
    if not np.isfinite(accuracy) or not 0 < accuracy < 1:
        raise ValueError(f"--accuracy: expected 0 < accuracy < 1, found {accuracy}")
    if bandwidth is not None and not bandwidth <= np.pi * rate:
        raise ValueError(
            f"--bandwidth: {bandwidth:g} rad/s is over the Nyquist frequency of "
            f"the {rate:g} Hz rate ({np.pi * rate:.4g} rad/s): lower it or raise "
            "--rate"
        )
    config = StationConfig(log_period=1.0 / rate)
    config.simulator.max_step_size = config.log_period
    config.simulator.accuracy = accuracy
    if v_eps is not None:
        config.v_eps = v_eps
    if bandwidth is not None:
        config.controller.bandwidth = float(bandwidth)
    config.sensors = SensorConfig(
        torque_noise=torque_noise, encoder_resolution=encoder_resolution, seed=seed
    )
    return config


def log_summary(
    log: JointLog,
    trajectory: FourierTrajectory,
    effort: np.ndarray,
    *,
    sigma: object = None,
) -> list[str]:
    """Lines on a simulated log: the largest tracking error per joint (deg, or
    mm for a prismatic joint as ``sigma`` (n,) says; None: all revolute), the
    peak effort per joint (N m or N) and a warning per saturated joint.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.pipelines import log_summary, simulate_trajectory, station_config
    >>> robot = load_robot("rv3sb")
    >>> trajectory = random_fourier_trajectory(robot, seed=0)
    >>> config = station_config()
    >>> log, _ = simulate_trajectory(config, robot, robot, trajectory, periods=0.02)
    >>> lines = log_summary(log, trajectory, robot.limits.effort)
    >>> len(lines) >= 2
    True
    """
    err = np.abs(log.q - trajectory.q(log.t)).max(axis=0)
    peak = np.abs(log.tau).max(axis=0)
    slide = _slides(sigma, err.size)
    lines = [
        "max tracking error: "
        + ", ".join(
            f"{e * 1e3:.3g} mm" if s else f"{np.rad2deg(e):.3g} deg"
            for e, s in zip(err, slide, strict=True)
        ),
        "peak effort:        "
        + ", ".join(
            f"{v:.4g} {'N' if s else 'N m'}" for v, s in zip(peak, slide, strict=True)
        ),
    ]
    return lines + [
        f"warning: {m}" for m in saturation_warnings(log, effort, sigma=sigma)
    ]


def simulate_file(
    robot: str,
    trajectory: str | os.PathLike,
    out: str | os.PathLike,
    *,
    nominal: str | None = None,
    periods: float = 1.0,
    derivatives: bool = True,
    motor_side: bool = False,
    echo: Echo = print,
    **station: Any,
) -> Path:
    """Runs the true ``robot`` along a Fourier trajectory YAML in the Drake
    station and writes the joint log (t,q,tau[,qd,qdd]; CSV or NPZ by suffix).

    With ``motor_side`` the log is written as the robot's drives would log it
    (t,qm,taum[,qdm,qddm], :mod:`rmdrake.dynamics.joint_log`) through its
    transmission. A robot with coupled motors runs on the discrete station
    (Drake's coupler constraints need it; step
    :func:`~rmdrake.systems.station_config.discrete_time_step` of the log
    period, so the logged q, qd, qdd are the step's end and the efforts the
    step's: O(step) from the rigid-body identity at the logged state).

    The controller uses ``nominal`` (default :func:`controller_model_for`);
    ``station`` are the options of
    :func:`~rmdrake.pipelines.simulate.station_config` (rate in Hz, accuracy,
    v_eps in rad/s, torque noise in N m, encoder resolution in rad, seed).

    Raises:
      ValueError: a kinematic-only ``robot`` (the true robot needs its
        dynamics and its effort limits, where the plant clamps the actuation)
        or ``nominal`` (the controller needs its dynamics), by name
        (:func:`~rmdrake.model.robot.require_dynamics`); a ``nominal`` of
        another robot than ``robot``
        (:func:`~rmdrake.model.same_robot.check_same_robot`); ``motor_side``
        for a robot without a transmission; a torque noise over the effort
        limits (:func:`check_sensor_noise`); all before the station is built.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import load_robot, random_fourier_trajectory, read_joint_log
    >>> from rmdrake.pipelines import simulate_file
    >>> trajectory = random_fourier_trajectory(load_robot("rv3sb"), seed=0)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     yaml = trajectory.save(Path(tmp, "excitation.yaml"))
    ...     lines = []
    ...     csv = Path(tmp, "log.csv")
    ...     out = simulate_file("rv3sb", yaml, csv, periods=0.02, echo=lines.append)
    ...     log = read_joint_log(out)
    ...
    >>> log.q.shape[1], log.qd is not None
    (6, True)
    """
    true_model = load_robot(robot)
    require_dynamics(true_model, "rmdrake simulate")
    if motor_side and true_model.transmission is None:
        raise ValueError(
            f"--motor-side: robot '{true_model.name}' has no transmission (robot "
            "YAML 'transmission: {ratio: [...]}'): its log is the joint side"
        )
    check_sensor_noise(true_model, station.get("torque_noise", 0.0))
    controller = load_robot(nominal) if nominal else None
    controller = controller or controller_model_for(true_model, str(robot))
    if controller is not true_model:
        require_dynamics(
            controller, "rmdrake simulate", effort=False, role="nominal robot"
        )
    check_same_robot(
        true_model,
        controller,
        what="nominal",
        remedy="give this robot's controller model with --nominal",
    )
    traj = load_fourier(trajectory)
    config = station_config(**station)
    if true_model.coupled_motors:
        config.time_step = discrete_time_step(config.log_period, COUPLED_RATE)
        motors = ", ".join(str(m + 1) for m in true_model.coupled_motors)
        echo(
            f"coupled motor(s) {motors}: the discrete station (time step "
            f"{config.time_step:.4g} s; Drake's coupler constraints need it)"
        )
    check_sampling(traj.base_frequency, 1.0 / config.log_period, periods, traj.n_joints)
    duration = periods * traj.period
    same = "" if controller is not true_model else ", the true robot itself"
    if controller.compliance is None and true_model.compliance is not None:
        same = ", rigid joints"
    echo(
        f"simulating '{true_model.name}' (controller model '{controller.name}'"
        f"{same}) for {duration:.6g} s ({periods:g} period(s) of "
        f"{traj.period:.6g} s), logging at {1 / config.log_period:g} Hz"
    )
    with simulated_time_progress(duration) as progress:
        log, wall = simulate_trajectory(
            config, true_model, controller, traj, periods=periods, progress=progress
        )
    if not derivatives:
        log = JointLog(t=log.t, q=log.q, tau=log.tau)
    path = write_joint_log(out, log, true_model.transmission if motor_side else None)
    fields = "t,q,tau,qd,qdd" if log.qd is not None else "t,q,tau"
    if motor_side:
        fields = "t,qm,taum,qdm,qddm" if log.qd is not None else "t,qm,taum"
    echo(
        f"wrote {path}: {log.n_samples} samples x {log.n_joints} joints ({fields}) "
        f"in {wall:.2f} s wall time ({duration / wall:.2f}x real time)"
    )
    for line in log_summary(
        log, traj, true_model.limits.effort, sigma=true_model.sigma
    ):
        echo(line)
    return path
