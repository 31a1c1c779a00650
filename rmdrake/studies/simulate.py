"""Simulating a robot on a Fourier trajectory in the Drake station, as
``rmdrake simulate`` does: which model the controller uses, the run with
progress, and what the log says about effort saturation."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from rmdrake.io import JointLog
from rmdrake.robot import RobotModel, load_robot, shipped_robots
from rmdrake.systems.station import MakeStation, RunStation
from rmdrake.systems.station_config import SensorConfig, StationConfig
from rmdrake.trajectory import FourierTrajectory

__all__ = [
    "controller_model_for",
    "log_summary",
    "saturation_warnings",
    "simulate_trajectory",
    "station_config",
]


def controller_model_for(true_model: RobotModel, robot_arg: str) -> RobotModel:
    """The model a controller uses when none is named: the shipped robot whose
    name the true robot carries, when the true robot was given as a file (a
    perturbed copy of a shipped robot), else the true robot itself; with rigid
    joints either way (the station's computed-torque controller assumes them;
    an elastic arm's encoders read the motor side it feeds back)."""
    model = true_model
    if true_model.name in shipped_robots() and robot_arg != true_model.name:
        model = load_robot(true_model.name)
    if model.compliance is not None:
        model = dataclasses.replace(model, compliance=None)
    return model


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
    plant clamps actuation there, so tracking suffers."""
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
      ValueError: accuracy outside (0, 1).
    """
    if not np.isfinite(accuracy) or not 0 < accuracy < 1:
        raise ValueError(f"--accuracy: expected 0 < accuracy < 1, found {accuracy}")
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
    peak effort per joint (N m or N) and a warning per saturated joint."""
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
