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

The study runs as steps, each returning a small dataclass:
:func:`true_dynamics` (:class:`TrueDynamics`), :func:`design_step`
(:class:`ExcitationDesign`), :func:`simulate_step` (:class:`StudyLogs`),
:func:`identify_step` (:class:`StudyFits`), :func:`validate_step`
(:class:`StudyValidation`); :func:`write_identification_files` turns them into
files. :func:`design_step` takes any
:class:`~rmdrake.studies.scenarios.ExcitationRunConfig` (the closed-loop study
designs its excitation with it too).
"""

from __future__ import annotations

import dataclasses
import os
import pickle
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.estimators import IDENTIFICATION_METHODS
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.dynamics.identification import (
    Identification,
    identified_model,
    identify,
)
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.excitation.design import ExcitationResult, design_excitation
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.dynamic_parameters import (
    perturb_standard_parameters,
    standard_parameters,
)
from rmdrake.model.robot import RobotModel
from rmdrake.progress import simulated_time_progress
from rmdrake.report.plots import (
    plot_cartesian_path,
    plot_joint_trajectories,
    plot_torque_comparison,
)
from rmdrake.studies.scenarios import (
    ExcitationRunConfig,
    IdentificationStudyConfig,
    stream,
)
from rmdrake.systems.station import MakeStation, RunStation
from rmdrake.systems.station_config import StationConfig
from rmdrake.systems.visualization import save_robot_poses_html

__all__ = [
    "ExcitationDesign",
    "IdentificationStudy",
    "StudyFits",
    "StudyLogs",
    "StudyValidation",
    "TrueDynamics",
    "design_step",
    "estimated_samples",
    "identify_step",
    "perturb_dynamics",
    "run_identification_study",
    "simulate_log",
    "simulate_step",
    "true_dynamics",
    "validate_step",
    "write_identification_files",
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

    Example:

    >>> import dataclasses
    >>> from rmdrake.studies import IdentificationStudy
    >>> [f.name for f in dataclasses.fields(IdentificationStudy)][:3]
    ['cond', 'cond_random_median', 'design_time']
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
    progress: bool | Callable[[float, float], None] = False,
) -> JointLog:
    """One run of the Drake station (true robot, controller on the nominal
    model) with the given sensor noise (N m or N std, rad or m per count,
    noise seed); ``progress`` shows the simulated seconds and the time left
    (True: a bar of its own; a ``progress(t, t_final)`` callback, s: the
    caller's, e.g. one bar over several runs).
    Returns the logged q, qd, qdd, tau.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.studies import perturb_dynamics
    >>> from rmdrake.systems import StationConfig
    >>> nominal = load_robot("rv3sb")
    >>> true = perturb_dynamics(nominal, seed=0)
    >>> config = StationConfig()
    >>> type(config).__name__, true.n_joints
    ('StationConfig', 6)

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake.studies import simulate_log
        # trajectory: an excitation (rmdrake.excitation.FourierTrajectory)
        log = simulate_log(config, true, nominal, trajectory,
                           torque_noise=0.01, seed=0, periods=2.0)
    """
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
    if callable(progress):
        return RunStation(station, periods=periods, progress=progress)
    duration = periods * trajectory.period
    with simulated_time_progress(duration, disable=not progress) as report:
        return RunStation(station, periods=periods, progress=report)


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

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.studies import perturb_dynamics
    >>> true = perturb_dynamics(load_robot("rv3sb"), seed=0, name="rv3sb_true")
    >>> true.name, true.n_joints
    ('rv3sb_true', 6)
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


@dataclasses.dataclass(frozen=True)
class TrueDynamics:
    """Step 0 of the study: the true robot and its base parameters.

    Attributes:
      model: the nominal robot with perturbed dynamics (:func:`perturb_dynamics`).
      base_count: number nb of base parameters of the nominal model.
      x_true: (nb,) the true robot's base parameters (SI units of each:
        kg, kg m, kg m^2, N m s/rad, N m; N and kg for a prismatic joint).
    """

    model: RobotModel
    base_count: int
    x_true: np.ndarray


@dataclasses.dataclass(frozen=True)
class ExcitationDesign:
    """Step 1: the excitation designed by DE on the nominal model.

    Attributes:
      result: what :func:`~rmdrake.excitation.design.design_excitation` found
        (joint-space trajectory in rad or m, cond(A), DE history and time, s).
      cond_random_median: median cond(A) of the random feasible trajectories.
      cond_full_median: median cond(A) of the same trajectories scaled up to
        the limits.
    """

    result: ExcitationResult
    cond_random_median: float
    cond_full_median: float

    @property
    def trajectory(self) -> FourierTrajectory:
        """The designed trajectory (joint space, rad or m)."""
        return self.result.trajectory

    @property
    def cond(self) -> float:
        """cond(A) of the designed trajectory on one full period."""
        return self.result.cond


@dataclasses.dataclass(frozen=True)
class StudyLogs:
    """Step 2: the station runs of the true robot (joint space, SI units).

    Attributes:
      rate: log rate, Hz (1 / the station's ``log_period``).
      clean: noise-free log of one period of the excitation (exact q, qd,
        qdd, tau as simulated).
      clean_time: wall time of that run, s.
      noise_sigma: (n,) injected torque (force) noise std, N m (N): ``noise``
        times each joint's peak |tau| in ``clean``.
      identification: noisy log of ``periods`` periods of the excitation.
      validation_trajectory: the random feasible trajectory of the validation.
      validation: noisy log of one period of it.
    """

    rate: float
    clean: JointLog
    clean_time: float
    noise_sigma: np.ndarray
    identification: JointLog
    validation_trajectory: FourierTrajectory
    validation: JointLog


@dataclasses.dataclass(frozen=True)
class StudyFits:
    """Step 3: the identifications.

    Attributes:
      noise_free_error: method -> max |x - x_true| / max |x_true| from the
        clean log's exact samples (every method but ``de``).
      results: method -> its identification from the noisy log (qdd estimated
        from qd, tau as logged).
      times: method -> wall time of that identification, s.
      base_error: method -> (nb,) |x - x_true| / max(|x_true|, floor), with
        floor 1e-3 max |x_true|.
    """

    noise_free_error: dict[str, float]
    results: dict[str, Identification]
    times: dict[str, float]
    base_error: dict[str, np.ndarray]


@dataclasses.dataclass(frozen=True)
class StudyValidation:
    """Step 4: each identified model predicts the validation torques.

    Attributes:
      samples: the validation samples (q, qd, tau as logged; qdd estimated).
      predicted: method -> (M, n) predicted torques (forces), N m (N).
      rms: method -> (n,) RMS of predicted - measured torque, N m (N).
      relative: method -> (n,) ``rms`` / RMS measured torque.
    """

    samples: JointSamples
    predicted: dict[str, np.ndarray]
    rms: dict[str, np.ndarray]
    relative: dict[str, np.ndarray]


def true_dynamics(nominal: RobotModel, seed: int) -> TrueDynamics:
    """Step 0: the true robot (:func:`perturb_dynamics` of ``nominal`` with
    ``seed``) and its base parameters in the nominal model's base set."""
    true = perturb_dynamics(nominal, seed)
    base = base_parameters(nominal)
    return TrueDynamics(true, base.count, base.regroup(standard_parameters(true)))


def design_step(
    nominal: RobotModel, config: ExcitationRunConfig, *, progress: bool
) -> ExcitationDesign:
    """Step 1: designs the excitation by DE on ``nominal`` (paper eq. 16-17)
    with the budget of ``config`` (``design_maxiter``, ``design_popsize``,
    ``n_random``, and a wall-time ``design_time`` s only when one is given,
    with a warning if it stops the design), seeded by :func:`stream` 4 of
    ``config.design_seed``; ``progress`` prints the DE's progress.

    The design depends on these inputs only, so this process keeps the last
    four: the same nominal model (equal pickled bytes), ``design_seed`` and
    budget give the same design object without a second DE (a closed loop
    that runs one excitation on several true robots, or a scenario whose
    closed loop has its identification study's ``design_seed`` and budget,
    designs once). Treat it as read-only."""
    key = (
        pickle.dumps(nominal),
        config.design_seed,
        config.design_time,
        config.design_maxiter,
        config.design_popsize,
        config.n_random,
    )
    if key not in _DESIGNS:
        if len(_DESIGNS) == 4:
            del _DESIGNS[next(iter(_DESIGNS))]  # the oldest
        _DESIGNS[key] = _design(nominal, config, progress=progress)
    return _DESIGNS[key]


_DESIGNS: dict[tuple, ExcitationDesign] = {}
""":func:`design_step`'s last four designs, by their inputs."""


def _design(
    nominal: RobotModel, config: ExcitationRunConfig, *, progress: bool
) -> ExcitationDesign:
    """:func:`design_step` without the memo."""
    design = design_excitation(
        nominal,
        seed=stream(config.design_seed, 4),
        max_time=config.design_time,
        maxiter=config.design_maxiter,
        popsize=config.design_popsize,
        n_random=config.n_random,
        progress=progress,
        budget_keys=("design_time", "design_maxiter"),
    )
    return ExcitationDesign(
        design,
        float(np.median(design.random_conds)),
        float(np.median(design.random_conds_full)),
    )


def simulate_step(
    nominal: RobotModel,
    true: RobotModel,
    trajectory: FourierTrajectory,
    config: IdentificationStudyConfig,
) -> StudyLogs:
    """Step 2: runs the true robot in ``config.station`` (controller on
    ``nominal``): one noise-free period of ``trajectory``, then with sensor
    noise (``config.noise`` of each joint's peak torque in the noise-free
    run, encoder quantum ``config.encoder_resolution``) ``config.periods``
    periods of it and one period of a random feasible validation trajectory.
    Seeds: the noise ``config.seed`` + 1 and + 2, the validation trajectory
    ``config.seed`` + 100."""
    seed = config.seed
    station = config.station
    t0 = time.perf_counter()
    desc = "simulated s of the noise-free period"
    with simulated_time_progress(trajectory.period, desc=desc) as report:
        clean = simulate_log(station, true, nominal, trajectory, seed=seed,
                             progress=report)  # fmt: skip
    clean_time = time.perf_counter() - t0
    val_traj = random_fourier_trajectory(nominal, fill=0.8, seed=seed + 100)
    noisy_time = config.periods * trajectory.period
    robot_time = noisy_time + val_traj.period
    print(
        f"simulating {robot_time:.4g} s of robot time more ({config.periods:g} "
        f"period{'s' * (config.periods != 1)} and a validation period): about "
        f"{clean_time * robot_time / trajectory.period:.0f} s at the "
        f"{clean_time:.1f} s the first period took"
    )
    sigma = config.noise * np.abs(clean.tau).max(axis=0)
    desc = "simulated s of robot time more"  # the unit and total of the line
    with simulated_time_progress(robot_time, desc=desc) as report:
        log = simulate_log(
            station,
            true,
            nominal,
            trajectory,
            torque_noise=sigma,
            encoder_resolution=config.encoder_resolution,
            seed=seed + 1,
            periods=config.periods,
            progress=report,
        )
        val_log = simulate_log(
            station,
            true,
            nominal,
            val_traj,
            torque_noise=sigma,
            encoder_resolution=config.encoder_resolution,
            seed=seed + 2,
            progress=lambda t, _: report(noisy_time + t, robot_time),
        )
    return StudyLogs(
        rate=1.0 / station.log_period,
        clean=clean,
        clean_time=clean_time,
        noise_sigma=sigma,
        identification=log,
        validation_trajectory=val_traj,
        validation=val_log,
    )


def identify_step(
    nominal: RobotModel,
    truth: TrueDynamics,
    logs: StudyLogs,
    config: IdentificationStudyConfig,
    methods: tuple[str, ...],
) -> StudyFits:
    """Step 3: each method identifies the base parameters, with the station's
    Coulomb law (width ``DEFAULT_V_EPS`` rad/s): from the clean log's exact
    samples (``de`` excepted: the paper's DE is checked on the noisy run only)
    and from the noisy identification log (qdd estimated from qd low-passed at
    ``config.derivative_cutoff`` Hz)."""
    x_true = truth.x_true
    clean = logs.clean
    exact = JointSamples(clean.t, clean.q, clean.qd, clean.qdd, clean.tau, logs.rate)
    noise_free = {}
    for method in methods:
        if method == "de":
            continue  # the paper's DE is checked on the noisy run only
        r = identify(nominal, exact, method=method, coulomb_width=DEFAULT_V_EPS)
        noise_free[method] = float(
            np.abs(r.params - x_true).max() / np.abs(x_true).max()
        )
    train = estimated_samples(logs.identification, config.derivative_cutoff)
    results, times = {}, {}
    for method in methods:
        t0 = time.perf_counter()
        results[method] = identify(
            nominal,
            train,
            method=method,
            seed=config.seed,
            de_maxiter=config.de_maxiter,
            coulomb_width=DEFAULT_V_EPS,
            progress=config.de_maxiter > 10,  # the DE's generations (30 s in paper)
        )
        times[method] = time.perf_counter() - t0
    floor = 1e-3 * np.abs(x_true).max()
    base_error = {
        m: np.abs(r.params - x_true) / np.maximum(np.abs(x_true), floor)
        for m, r in results.items()
    }
    return StudyFits(noise_free, results, times, base_error)


def validate_step(
    nominal: RobotModel,
    logs: StudyLogs,
    fits: StudyFits,
    config: IdentificationStudyConfig,
) -> StudyValidation:
    """Step 4: each identified model predicts the torques of the validation
    log from its states (qdd estimated as for identification); compared with
    the torques as logged (noisy, unfiltered)."""
    val = estimated_samples(logs.validation, config.derivative_cutoff)
    raw = val.tau  # as logged: noisy, unfiltered
    predicted = {m: r.predict(nominal, val) for m, r in fits.results.items()}
    rms = {m: np.sqrt(np.mean((p - raw) ** 2, axis=0)) for m, p in predicted.items()}
    rms_tau = np.sqrt(np.mean(raw**2, axis=0))
    relative = {m: v / rms_tau for m, v in rms.items()}
    return StudyValidation(val, predicted, rms, relative)


def write_identification_files(
    out_dir: str | os.PathLike,
    nominal: RobotModel,
    config: IdentificationStudyConfig,
    *,
    truth: TrueDynamics,
    design: ExcitationDesign,
    logs: StudyLogs,
    fits: StudyFits,
    validation: StudyValidation,
) -> Path:
    """Writes the study's files into ``out_dir`` (created if missing), prints
    what it wrote and returns the folder.

    Files: ``true_robot.yaml``, ``excitation.yaml`` (headed by a ``# warning:``
    comment if a wall-time budget stopped the design),
    ``identification_log.csv``, ``validation_log.csv``,
    ``identified_<method>.yaml``, ``fig4_joint_trajectories.png`` (joint
    angles, rad or m), ``fig6_cartesian_path.png`` (tool point in the base
    frame B, m), ``fig7_torques.png`` (validation torques, N m or N) and, if
    ``config.html``, ``excitation.html`` (the robot following the excitation).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    truth.model.save(out / "true_robot.yaml")
    design.result.save(out / "excitation.yaml")  # with the budget's warning
    write_joint_log(out / "identification_log.csv", logs.identification)
    write_joint_log(out / "validation_log.csv", logs.validation)
    for method, r in fits.results.items():
        identified_model(nominal, r, notes={"study": "rmdrake demo"}).save(
            out / f"identified_{method}.yaml"
        )
    rate = logs.rate
    t, q, _, _ = design.trajectory.sample(rate)
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
    predicted = validation.predicted
    shown = {m: predicted[m] for m in ("ols", "physical") if m in predicted}
    val = validation.samples
    plot_torque_comparison(val.t, val.tau, shown, out / "fig7_torques.png")
    if config.html:
        step = max(1, round(rate / 10))  # 10 poses per second
        save_robot_poses_html(
            nominal, q[::step], out / "excitation.html", seconds_per_pose=step / rate
        )
    print(
        f"wrote {out}/ (trajectory, logs, identified robots, Fig. 4, 6, 7"
        + (", excitation.html)" if config.html else ")")
    )
    return out


def run_identification_study(
    nominal: RobotModel,
    config: IdentificationStudyConfig,
    out_dir: str | os.PathLike,
) -> IdentificationStudy:
    """Runs the study, prints its table and writes its files into ``out_dir``.

    The steps: :func:`true_dynamics`, :func:`design_step`,
    :func:`simulate_step`, :func:`identify_step`, :func:`validate_step`, then
    :func:`write_identification_files`.

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

    Example:

    >>> from rmdrake.studies import IdentificationStudyConfig
    >>> config = IdentificationStudyConfig(design_maxiter=50, periods=2.0)
    >>> config.design_maxiter
    50

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake import load_robot
        from rmdrake.studies import run_identification_study
        study = run_identification_study(load_robot("rv3sb"), config, "out")
    """
    methods = _checked_methods(config.methods)
    truth = true_dynamics(nominal, config.seed)
    print(
        f"robot {nominal.name}: {truth.base_count} base parameters; true robot = "
        "nominal perturbed 10-30 % per link (mass, centre of mass, inertia, Ia, "
        "fv, fc)"
    )
    design = design_step(nominal, config, progress=config.design_maxiter > 10)
    _print_design(design)
    logs = simulate_step(nominal, truth.model, design.trajectory, config)
    print(
        f"simulated 1 period of the true robot in Drake: {logs.clean.t.size} "
        f"samples ({logs.clean_time:.1f} s)"
    )
    print(
        f"identification log: {config.periods:g} "
        f"period{'s' * (config.periods != 1)} of the excitation, "
        f"{logs.identification.t.size} samples at {logs.rate:g} Hz"
    )
    fits = identify_step(nominal, truth, logs, config, methods)
    validation = validate_step(nominal, logs, fits, config)
    study = IdentificationStudy(
        cond=design.cond,
        cond_random_median=design.cond_random_median,
        design_time=design.result.time,
        noise_free_error=fits.noise_free_error,
        base_error=fits.base_error,
        validation_rms=validation.rms,
        noise_sigma=logs.noise_sigma,
        validation_relative=validation.relative,
        times=fits.times,
    )
    _print_table(study, methods, config.de_maxiter)
    write_identification_files(
        out_dir,
        nominal,
        config,
        truth=truth,
        design=design,
        logs=logs,
        fits=fits,
        validation=validation,
    )
    return study


def _checked_methods(methods: list[str]) -> tuple[str, ...]:
    """``methods`` as a tuple; ValueError names one that is not known."""
    for m in methods:
        if m not in IDENTIFICATION_METHODS:
            raise ValueError(
                f"identification method '{m}': expected one of "
                f"{', '.join(IDENTIFICATION_METHODS)}"
            )
    return tuple(methods)


def _print_design(design: ExcitationDesign) -> None:
    result = design.result
    cond_random, cond_full = design.cond_random_median, design.cond_full_median
    print(
        f"excitation: cond(A) {result.cond:.4g} on one period after "
        f"{result.generations} DE generations ({result.time:.0f} s); random "
        f"feasible median {cond_random:.4g} ({cond_random / result.cond:.2f}x), "
        f"{cond_full:.4g} ({cond_full / result.cond:.2f}x) scaled up to the limits"
    )


def _print_table(
    study: IdentificationStudy, methods: tuple[str, ...], de_maxiter: int
) -> None:
    """The study's figures; a note under the table when the DE ran on a token
    budget (under 50 generations: a smoke run) and its rows mean nothing."""
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
    if "de" in methods and de_maxiter < 50:
        print(
            f"  (DE budget of {de_maxiter} generations: the DE figures are not "
            "meaningful at this budget)"
        )
    for m in methods:
        rel = " ".join(f"{100 * v:6.2f}%" for v in study.validation_relative[m])
        print(f"  {m:>9} relative RMS error: {rel}")
