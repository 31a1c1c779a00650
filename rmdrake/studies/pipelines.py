"""File-to-file pipelines behind ``rmdrake calibrate``, ``simulate`` and
``identify``: read and check the inputs, run, write the result atomically and
return the lines that say what was done. Scripts can call them as the command
line does."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

from rmdrake.calibration.estimators import make_calibrator
from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identified_model, identify
from rmdrake.io import (
    JointLog,
    read_joint_log,
    read_plane_measurements,
    write_joint_log,
)
from rmdrake.robot import load_robot
from rmdrake.studies.simulate import (
    controller_model_for,
    log_summary,
    simulate_trajectory,
    station_config,
)
from rmdrake.trajectory import load_fourier

__all__ = ["calibrate_file", "identify_file", "simulate_file"]

Echo = Callable[[str], None]


def calibrate_file(
    robot: str,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    method: str = "de+lm",
    echo: Echo = print,
    **options: Any,
) -> Path:
    """Calibrates ``robot`` from a plane-measurement CSV; writes the calibrated
    robot YAML (its ``calibration`` record names the file). ``options`` go to
    :func:`~rmdrake.calibration.estimators.make_calibrator`."""
    model = load_robot(robot)
    data = read_plane_measurements(measurements, model.n_joints)
    est = make_calibrator(method, model, **options).fit(data)
    record = dict(est.model_.calibration)
    record["data"] = {**record["data"], "file": str(measurements)}
    calibrated = dataclasses.replace(est.model_, calibration=record)
    echo(
        f"robot '{model.name}': {data.n_readings} readings on "
        f"{data.plate_ids.size} plates from {measurements}"
    )
    echo(est.summary())
    return calibrated.save(out)


def simulate_file(
    robot: str,
    trajectory: str | os.PathLike,
    out: str | os.PathLike,
    *,
    nominal: str | None = None,
    periods: float = 1.0,
    derivatives: bool = True,
    echo: Echo = print,
    **station: Any,
) -> Path:
    """Runs the true ``robot`` along a Fourier trajectory YAML in the Drake
    station and writes the joint log (t,q,tau[,qd,qdd]; CSV or NPZ by suffix).

    The controller uses ``nominal`` (default :func:`controller_model_for`);
    ``station`` are the options of
    :func:`~rmdrake.studies.simulate.station_config` (rate in Hz, accuracy,
    v_eps in rad/s, torque noise in N m, encoder resolution in rad, seed).
    """
    true_model = load_robot(robot)
    controller = load_robot(nominal) if nominal else None
    controller = controller or controller_model_for(true_model, str(robot))
    traj = load_fourier(trajectory)
    config = station_config(**station)
    duration = periods * traj.period
    same = "" if controller is not true_model else ", the true robot itself"
    echo(
        f"simulating '{true_model.name}' (controller model '{controller.name}'"
        f"{same}) for {duration:.6g} s ({periods:g} period(s) of "
        f"{traj.period:.6g} s), logging at {1 / config.log_period:g} Hz"
    )
    bar: list[tqdm] = []  # opened at the first step: bad input fails before

    def progress(t: float, t_final: float) -> None:
        if not bar:
            bar.append(tqdm(total=round(duration, 3), desc="simulated s", leave=False))
        bar[0].update(t - bar[0].n)

    try:
        log, wall = simulate_trajectory(
            config, true_model, controller, traj, periods=periods, progress=progress
        )
    finally:
        for b in bar:
            b.close()
    if not derivatives:
        log = JointLog(t=log.t, q=log.q, tau=log.tau)
    path = write_joint_log(out, log)
    fields = "t,q,tau,qd,qdd" if log.qd is not None else "t,q,tau"
    echo(
        f"wrote {path}: {log.n_samples} samples x {log.n_joints} joints ({fields}) "
        f"in {wall:.2f} s wall time ({duration / wall:.2f}x real time)"
    )
    for line in log_summary(log, traj, true_model.limits.effort):
        echo(line)
    return path


def identify_file(
    robot: str,
    log_path: str | os.PathLike,
    out: str | os.PathLike,
    *,
    trajectory: str | os.PathLike | None = None,
    method: str = "physical",
    seed: int = 0,
    coulomb_width: float = 0.0,
    echo: Echo = print,
    **preparation: Any,
) -> Path:
    """Identifies ``robot``'s dynamics from a joint log; writes the identified
    robot YAML.

    Args:
      trajectory: the excitation YAML the log followed: the log must cover at
        least one of its periods.
      coulomb_width: rad/s; the Coulomb term is fc tanh(qd / width) (0: sign).
      preparation: options of :func:`~rmdrake.dynamics.data.prepare_samples`
        (rate, cutoff, decimate, derivative_cutoff).
    """
    model = load_robot(robot)
    log = read_joint_log(log_path, n_joints=model.n_joints)
    if trajectory is not None:
        load_fourier(trajectory).check_covers(log.t, f"log {log_path}")
    samples = prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd, **preparation)
    result = identify(
        model,
        samples,
        method=method,
        seed=seed,
        progress=True,
        coulomb_width=coulomb_width,
    )
    notes = {
        "log": str(log_path),
        "samples": samples.n_samples,
        "rate_Hz": samples.rate,
        "preparation": list(samples.notes),
        "coulomb_width": coulomb_width,
    }
    path = identified_model(model, result, notes=notes).save(out)
    echo(
        f"robot '{model.name}': {samples.n_samples} samples at {samples.rate:g} Hz; "
        f"{result.base.count} base parameters identified by {method}"
    )
    for note in samples.notes:
        echo(f"  {note}")
    rms = ", ".join(f"{v:.4g}" for v in result.residual_rms)
    echo(f"residual RMS per joint [N m]: {rms}")
    return path
