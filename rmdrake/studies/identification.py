"""The paper's dynamic study (§3.2, §4; Fig. 4, 6, 7), with Drake as the robot.

:func:`run_identification_study` designs the excitation of the robot by DE,
runs it on a *true* robot (the nominal parameters perturbed by 10-30 % per link,
friction and rotor inertia present) in the Drake station of
:mod:`rmdrake.systems.station`, identifies the base parameters with every
estimator, and validates them on a *different* trajectory. Sizes, noise,
budgets and the station come from an
:class:`~rmdrake.studies.scenarios.IdentificationStudyConfig`:

1. Noise-free run (exact logged qd, qdd; identification with the station's own
   smooth Coulomb sign): the base parameters must come back to round-off.
2. Noisy run, as a robot's drives log it: Gaussian torque noise of ``noise``
   (1 %) of each joint's peak torque, encoder quantisation of q, the drive's
   velocity qd; qdd is *estimated* (central differences of qd low-passed at
   ``derivative_cutoff``, zero phase) and the torques are used as logged. The
   torques are deliberately not filtered: a filtered torque smooths the
   Coulomb step at every velocity reversal, which biased the wrist joints'
   friction by several noise levels in this study (parallel filtering of the
   regressor columns recovered only part of it).
3. Validation: a second, random feasible trajectory simulated the same way;
   each method predicts its torques from the same kind of states and is
   compared with the measured (noisy) torques; the ratio to the injected noise
   is reported.

The identification model uses the station's friction law, fc tanh(qd / v_eps)
with the simulator's v_eps = 1e-3 rad/s (``coulomb_width``): with sign(qd) the
samples in the near-stick phase after each reversal, where the true friction is
a steep damper, cost up to 3x the noise on the wrist joints.
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.dynamics.identification import (
    IDENTIFICATION_METHODS,
    identified_model,
    identify,
)
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.excitation.design import design_excitation
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.dynamic_parameters import (
    perturb_standard_parameters,
    standard_parameters,
)
from rmdrake.model.robot import RobotModel
from rmdrake.report.plots import (
    plot_cartesian_path,
    plot_joint_trajectories,
    plot_torque_comparison,
)
from rmdrake.studies.scenarios import IdentificationStudyConfig
from rmdrake.systems.station import MakeStation, RunStation
from rmdrake.systems.station_config import StationConfig
from rmdrake.systems.visualization import save_robot_poses_html

__all__ = [
    "IdentificationStudy",
    "estimated_samples",
    "perturb_dynamics",
    "run_identification_study",
    "simulate_log",
]


@dataclasses.dataclass
class IdentificationStudy:
    """Numbers of one study run (all SI; errors relative where named so).

    Attributes:
      cond: cond(A) of the designed excitation on the full period.
      cond_random_median: median cond(A) of random feasible trajectories.
      design_time: s.
      noise_free_error: method -> max |x - x_true| / max |x_true| (base).
      base_error: method -> (nb,) |x - x_true| / max(|x_true|, floor), noisy run.
      validation_rms: method -> (n,) RMS of predicted - measured torque, N m
        (force, N, for a prismatic joint).
      noise_sigma: (n,) injected torque (force) noise std, N m (N).
      validation_relative: method -> (n,) validation RMS / RMS measured torque.
      times: method -> identification wall time (noisy run), s.
    """

    cond: float
    cond_random_median: float
    design_time: float
    noise_free_error: dict[str, float]
    base_error: dict[str, np.ndarray]
    validation_rms: dict[str, np.ndarray]
    noise_sigma: np.ndarray
    validation_relative: dict[str, np.ndarray]
    times: dict[str, float]


def simulate_log(
    config: StationConfig,
    true_model: RobotModel,
    nominal_model: RobotModel,
    trajectory: FourierTrajectory,
    *,
    torque_noise: object = 0.0,
    encoder_resolution: object = 0.0,
    seed: int = 0,
    periods: float = 1.0,
) -> JointLog:
    """One run of the Drake station (true robot, controller on the nominal
    model) with the given sensor noise (N m or N std, rad or m per count,
    noise seed);
    returns the logged q, qd, qdd, tau."""
    n = true_model.n_joints
    sensors = dataclasses.replace(
        config.sensors,
        torque_noise=np.broadcast_to(torque_noise, n).astype(float).tolist(),
        encoder_resolution=np.broadcast_to(encoder_resolution, n)
        .astype(float)
        .tolist(),
        seed=int(seed),
    )
    station = MakeStation(
        dataclasses.replace(config, sensors=sensors),
        true_model=true_model,
        trajectory=trajectory,
        nominal_model=nominal_model,
    )
    return RunStation(station, periods=periods)


def perturb_dynamics(
    model: RobotModel, seed: int, *, name: str | None = None
) -> RobotModel:
    """``model`` with a "true" robot's dynamics: its standard parameters
    (mass, first moments, inertia, Ia, fv, fc of each link) perturbed 10-30 %
    per link by
    :func:`~rmdrake.model.dynamic_parameters.perturb_standard_parameters`, drawn
    from ``numpy.random.default_rng(seed)``; its kinematics unchanged. A
    payload is part of link n's standard parameters, so it is perturbed with
    them and the result has no separate payload.

    Args:
      model: the robot (with a ``dynamics`` section).
      seed: seeds the perturbation.
      name: the result's name; default ``<model name>_true``.
    """
    rng = np.random.default_rng(seed)
    chi = perturb_standard_parameters(standard_parameters(model), rng)
    return dataclasses.replace(
        model.with_dynamics(chi.reshape(model.n_joints, 13)),
        payload=None,  # folded into link n by standard_parameters: count it once
        name=f"{model.name}_true" if name is None else name,
    )


def estimated_samples(log: JointLog, derivative_cutoff: float) -> JointSamples:
    """Samples as a robot's drives give them: q, qd and tau as logged, qdd
    estimated from qd (central differences low-passed at ``derivative_cutoff``
    Hz, zero phase)."""
    return prepare_samples(
        log.t, log.q, log.tau, log.qd, derivative_cutoff=derivative_cutoff
    )


def run_identification_study(
    nominal: RobotModel,
    config: IdentificationStudyConfig,
    out_dir: str | os.PathLike,
) -> IdentificationStudy:
    """Runs the study, prints its table and writes its files into ``out_dir``.

    Args:
      nominal: the nominal robot (with a ``dynamics`` section).
      config: noise, budgets, methods and the station (see
        :class:`~rmdrake.studies.scenarios.IdentificationStudyConfig`).
      out_dir: folder for the files (created if missing).

    Files: ``excitation.yaml``, ``identification_log.csv``,
    ``validation_log.csv``, ``identified_<method>.yaml``, ``true_robot.yaml``,
    ``fig4_joint_trajectories.png``, ``fig6_cartesian_path.png``,
    ``fig7_torques.png`` and ``excitation.html``.

    Raises:
      ValueError: a method that is not one of ``IDENTIFICATION_METHODS``.
    """
    methods = tuple(config.methods)
    for m in methods:
        if m not in IDENTIFICATION_METHODS:
            raise ValueError(
                f"identification method '{m}': expected one of "
                f"{', '.join(IDENTIFICATION_METHODS)}"
            )
    seed = config.seed
    station = config.station
    rate = 1.0 / station.log_period
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    true = perturb_dynamics(nominal, seed)
    true.save(out / "true_robot.yaml")
    base = base_parameters(nominal)
    x_true = base.regroup(standard_parameters(true))
    print(
        f"robot {nominal.name}: {base.count} base parameters; true robot = nominal "
        "perturbed 10-30 % per link (mass, centre of mass, inertia, Ia, fv, fc)"
    )

    # 1. Excitation design (paper eq. 16-17).
    design = design_excitation(
        nominal,
        seed=seed,
        max_time=config.design_time,
        maxiter=config.design_maxiter,
        popsize=config.design_popsize,
        n_random=config.n_random,
        progress=config.design_maxiter > 10,
    )
    traj = design.trajectory
    traj.save(out / "excitation.yaml")
    cond_random = float(np.median(design.random_conds))
    cond_full = float(np.median(design.random_conds_full))
    print(
        f"excitation: cond(A) {design.cond:.4g} on one period after "
        f"{design.generations} DE generations ({design.time:.0f} s); random "
        f"feasible median {cond_random:.4g} ({cond_random / design.cond:.2f}x), "
        f"{cond_full:.4g} ({cond_full / design.cond:.2f}x) scaled up to the limits"
    )

    # 2. Noise-free run: identification must return the truth.
    t0 = time.perf_counter()
    clean = simulate_log(station, true, nominal, traj, seed=seed)
    print(
        f"simulated 1 period of the true robot in Drake: {clean.t.size} samples "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    exact = JointSamples(clean.t, clean.q, clean.qd, clean.qdd, clean.tau, rate)
    noise_free = {}
    for method in methods:
        if method == "de":
            continue  # the paper's DE is checked on the noisy run only
        r = identify(nominal, exact, method=method, coulomb_width=DEFAULT_V_EPS)
        noise_free[method] = float(
            np.abs(r.params - x_true).max() / np.abs(x_true).max()
        )

    # 3. Noisy runs: identification trajectory and a different validation one.
    sigma = config.noise * np.abs(clean.tau).max(axis=0)
    log = simulate_log(
        station,
        true,
        nominal,
        traj,
        torque_noise=sigma,
        encoder_resolution=config.encoder_resolution,
        seed=seed + 1,
        periods=config.periods,
    )
    write_joint_log(out / "identification_log.csv", log)
    print(
        f"identification log: {config.periods:g} periods of the excitation, "
        f"{log.t.size} samples at {rate:g} Hz"
    )
    val_traj = random_fourier_trajectory(nominal, fill=0.8, seed=seed + 100)
    val_log = simulate_log(
        station,
        true,
        nominal,
        val_traj,
        torque_noise=sigma,
        encoder_resolution=config.encoder_resolution,
        seed=seed + 2,
    )
    write_joint_log(out / "validation_log.csv", val_log)
    train = estimated_samples(log, config.derivative_cutoff)
    val = estimated_samples(val_log, config.derivative_cutoff)
    raw = val.tau  # as logged: noisy, unfiltered
    floor = 1e-3 * np.abs(x_true).max()
    results, times = {}, {}
    for method in methods:
        t0 = time.perf_counter()
        r = identify(
            nominal,
            train,
            method=method,
            seed=seed,
            de_maxiter=config.de_maxiter,
            coulomb_width=DEFAULT_V_EPS,
        )
        times[method] = time.perf_counter() - t0
        results[method] = r
        identified_model(nominal, r, notes={"study": "rmdrake demo"}).save(
            out / f"identified_{method}.yaml"
        )
    predicted = {m: r.predict(nominal, val) for m, r in results.items()}
    val_rms = {
        m: np.sqrt(np.mean((p - raw) ** 2, axis=0)) for m, p in predicted.items()
    }
    rms_tau = np.sqrt(np.mean(raw**2, axis=0))
    study = IdentificationStudy(
        cond=design.cond,
        cond_random_median=cond_random,
        design_time=design.time,
        noise_free_error=noise_free,
        base_error={
            m: np.abs(r.params - x_true) / np.maximum(np.abs(x_true), floor)
            for m, r in results.items()
        },
        validation_rms=val_rms,
        noise_sigma=sigma,
        validation_relative={m: v / rms_tau for m, v in val_rms.items()},
        times=times,
    )
    _print_table(study, methods)

    # 4. Figures.
    t, q, _, _ = traj.sample(rate)
    plot_joint_trajectories(
        t,
        q,
        out / "fig4_joint_trajectories.png",
        lower=nominal.limits.lower,
        upper=nominal.limits.upper,
        sigma=nominal.sigma,
    )
    plot_cartesian_path(
        t,
        tool_points(nominal.table, q, sigma=nominal.sigma),
        out / "fig6_cartesian_path.png",
    )
    shown = {m: predicted[m] for m in ("ols", "physical") if m in predicted}
    plot_torque_comparison(val.t, raw, shown, out / "fig7_torques.png")
    if config.html:
        step = max(1, round(rate / 10))  # 10 poses per second
        save_robot_poses_html(
            nominal, q[::step], out / "excitation.html", seconds_per_pose=step / rate
        )
    print(
        f"wrote {out}/ (trajectory, logs, identified robots, Fig. 4, 6, 7"
        + (", excitation.html)" if config.html else ")")
    )
    return study


def _print_table(study: IdentificationStudy, methods: tuple[str, ...]) -> None:
    n = study.noise_sigma.size
    print("noise-free data, max base-parameter error / max |x_true|:")
    for m, e in study.noise_free_error.items():
        print(f"  {m:>9}: {e:.2e}")
    print(
        "noisy data (torque noise 1 % of peak, encoder quantisation, qdd "
        "estimated from qd); validation on a different trajectory:"
    )
    print(
        "  injected noise sigma [N m, N for a prismatic joint]: "
        + " ".join(f"{s:7.4f}" for s in study.noise_sigma)
    )
    head = " ".join(f"{'j' + str(j + 1):>7}" for j in range(n))
    print(f"  {'method':>9} {head}  {'median base err':>15} {'time[s]':>8}")
    for m in methods:
        ratio = study.validation_rms[m] / study.noise_sigma
        row = " ".join(f"{v:7.2f}" for v in ratio)
        print(
            f"  {m:>9} {row}  {np.median(study.base_error[m]):15.3g} "
            f"{study.times[m]:8.2f}"
        )
    print(
        "  (per joint: validation RMS torque error / injected noise sigma; "
        "target <= 1.5 for ols, wls, physical)"
    )
    for m in methods:
        rel = " ".join(f"{100 * v:6.2f}%" for v in study.validation_relative[m])
        print(f"  {m:>9} relative RMS error: {rel}")
