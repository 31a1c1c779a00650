"""The ``rmdrake`` command (DESIGN §4).

Each subcommand has an ``_add_<name>(subparsers)`` function that declares its
arguments and sets ``handler``. Handlers print a short human summary, write files
atomically and raise ``ValueError`` on bad input; :func:`main` turns that into a
one-line ``rmdrake: error: ...`` on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np

from rmdrake.robot import DYNAMIC_KEYS, RobotModel, load_robot

__all__ = ["main"]


def _require_positive(args: argparse.Namespace, *names: str) -> None:
    """Raises ValueError naming the first option that is not a finite number > 0."""
    for name in names:
        value = getattr(args, name)
        if not np.isfinite(value) or value <= 0:
            option = "--" + name.replace("_", "-")
            raise ValueError(f"{option}: expected a positive number, found {value}")


def _robot_summary(model: RobotModel) -> str:
    deg = 180.0 / np.pi
    lines = [f"robot '{model.name}': {model.n_joints} revolute joints"]
    lines.append(
        f"{'row':>4} {'alpha[deg]':>11} {'d[m]':>9} {'theta[deg]':>11} {'r[m]':>9}"
        f" {'beta[deg]':>10} {'q range[deg]':>17} {'v[deg/s]':>9} {'effort[Nm]':>11}"
    )
    for j, (a, d, t, r, b) in enumerate(model.table, start=1):
        row = (
            f"{j:>4} {a * deg:11.3f} {d:9.4f} {t * deg:11.3f} {r:9.4f} {b * deg:10.3f}"
        )
        if j <= model.n_joints:
            lo, hi = model.limits.lower[j - 1] * deg, model.limits.upper[j - 1] * deg
            row += (
                f" {lo:8.1f}..{hi:<7.1f} {model.limits.velocity[j - 1] * deg:9.1f}"
                f" {model.limits.effort[j - 1]:11.4g}"
            )
        else:
            row += "   (tool)"
        lines.append(row)
    if model.dynamics is not None:
        masses = model.dynamics[:, DYNAMIC_KEYS.index("M")]
        lines.append(
            "link masses [kg]: "
            + ", ".join(f"{m:.4g}" for m in masses)
            + f"  (total {masses.sum():.4g})"
        )
    else:
        lines.append("no dynamic parameters")
    if model.payload is not None:
        lines.append(f"payload: {model.payload.mass:.4g} kg")
    return "\n".join(lines)


def _add_show(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("show", help="print a robot model; save a Meshcat HTML of it")
    p.add_argument("--robot", required=True, help="shipped model name or robot YAML")
    p.add_argument("--html", help="write a self-contained Meshcat HTML here")
    p.add_argument("--port", type=int, default=None, help="Meshcat port (localhost)")
    p.set_defaults(handler=_run_show)


def _run_show(args: argparse.Namespace) -> None:
    model = load_robot(args.robot)
    print(_robot_summary(model))
    if args.html:
        from rmdrake.systems.visualization import MakeMeshcat, save_robot_poses_html

        lo, hi = model.limits.lower, model.limits.upper
        mid = np.clip(np.zeros(model.n_joints), lo, hi)
        poses = [mid, np.clip(mid + 0.35 * (hi - mid), lo, hi)]
        poses.append(np.clip(mid + 0.35 * (lo - mid), lo, hi))
        poses.append(mid)
        path = save_robot_poses_html(
            model, poses, args.html, meshcat=MakeMeshcat(args.port)
        )
        print(f"wrote {path} ({len(poses)} poses, open it in a browser)")


def _add_demo(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="the main job: the paper's whole study on the RV-3SB, end to end"
    )
    p.add_argument("--out", default="out/demo", help="folder for figures and files")
    p.add_argument("--smoke", action="store_true", help="tiny sizes, for tests")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(handler=_run_demo)


def _run_demo(args: argparse.Namespace) -> None:
    import time
    from pathlib import Path

    from rmdrake.calibration.study import run_paper_study
    from rmdrake.systems.identification_study import run_identification_study

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"== rmdrake demo: the study of Wang et al. (SOFT 2016) into {out}/")
    print("\n== 1. The robot (paper Table 1)")
    _run_show(
        argparse.Namespace(robot="rv3sb", html=str(out / "rv3sb.html"), port=None)
    )
    print("\n== 2. Kinematic calibration by plane constraints (paper §2, Fig. 3)")
    run_paper_study(
        out / "kinematics", smoke=args.smoke, repeat_methods=("lm", "de+lm")
    )
    print("\n== 3. Dynamic identification with Drake as the robot (§3, Fig. 4, 6, 7)")
    run_identification_study(out / "dynamics", seed=args.seed, smoke=args.smoke)
    print(f"\n== done in {time.perf_counter() - t0:.0f} s; open {out}/*.html and PNGs")


def _add_simulate_plates(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate-plates",
        help="simulate range-finder readings on a plate at several places",
    )
    p.add_argument("--robot", required=True, help="the true robot (name or YAML)")
    p.add_argument("--out", required=True, help="measurement CSV to write")
    p.add_argument("--plates", type=int, default=5, help="plate locations")
    p.add_argument("--per-plate", type=int, default=12, help="readings per plate")
    p.add_argument("--noise", type=float, default=2e-6, help="reading noise std, m")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--selection",
        choices=("d-optimal", "first"),
        default="d-optimal",
        help="pose choice per plate: spread (D-optimal) or the first valid ones",
    )
    p.set_defaults(handler=_run_simulate_plates)


def _run_simulate_plates(args: argparse.Namespace) -> None:
    from rmdrake.calibration.measurements import simulate_plates
    from rmdrake.io import write_plane_measurements

    if args.plates < 1 or args.per_plate < 1:
        raise ValueError("--plates and --per-plate: expected positive counts")
    if not np.isfinite(args.noise) or args.noise < 0:
        raise ValueError(
            f"--noise: expected a standard deviation >= 0 m, found {args.noise}"
        )
    model = load_robot(args.robot)
    sim = simulate_plates(
        model,
        plates=args.plates,
        per_plate=args.per_plate,
        noise=args.noise,
        seed=args.seed,
        selection=args.selection,
    )
    path = write_plane_measurements(args.out, sim.data)
    t = sim.true_distance
    print(
        f"robot '{model.name}': {sim.data.n_readings} readings on {args.plates} "
        f"plates (seed {args.seed}); readings {t.min() * 1e3:.1f}..{t.max() * 1e3:.1f}"
        f" mm, incidence <= {np.rad2deg(sim.incidence.max()):.1f} deg, noise "
        f"{args.noise * 1e6:.3g} um"
    )
    for i, plate in enumerate(sim.plates):
        c, n = plate.X_BP[:3, 3], plate.normal
        print(
            f"  plate {i}: centre ({c[0]:+.3f}, {c[1]:+.3f}, {c[2]:+.3f}) m, normal "
            f"({n[0]:+.2f}, {n[1]:+.2f}, {n[2]:+.2f})"
        )
    print(f"wrote {path}")


def _add_calibrate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate", help="plane-constraint kinematic calibration -> robot YAML"
    )
    p.add_argument("--robot", required=True, help="nominal robot (name or YAML)")
    p.add_argument("--measurements", required=True, help="plane measurement CSV")
    p.add_argument("--out", required=True, help="calibrated robot YAML to write")
    p.add_argument(
        "--params",
        default="paper",
        help="paper | full (identifiable subset chosen) | comma-separated names",
    )
    p.add_argument("--method", choices=("de", "lm", "de+lm"), default="de+lm")
    p.add_argument("--seed", type=int, default=0, help="seed of the DE")
    p.add_argument(
        "--loss",
        choices=("linear", "huber", "soft_l1", "cauchy", "arctan"),
        default="linear",
        help="LM loss; a robust one resists outlier readings",
    )
    p.add_argument("--f-scale", type=float, default=1e-5, help="robust loss scale, m")
    p.add_argument("--maxiter", type=int, default=None, help="DE generations")
    p.add_argument(
        "--length-bound", type=float, default=3e-3, help="DE bound on dd, dr: +-m"
    )
    p.add_argument(
        "--angle-bound",
        type=float,
        default=3e-3,
        help="DE bound on dalpha, dtheta, dbeta: +-rad",
    )
    p.add_argument(
        "--no-progress", action="store_true", help="hide the DE progress bar"
    )
    p.set_defaults(handler=_run_calibrate)


def _run_calibrate(args: argparse.Namespace) -> None:
    import dataclasses
    import warnings

    from rmdrake.calibration.estimators import make_calibrator
    from rmdrake.calibration.readings import MeasurementWarning
    from rmdrake.io import read_plane_measurements

    model = load_robot(args.robot)
    data = read_plane_measurements(args.measurements, model.n_joints)
    options: dict = {"params": args.params}
    if args.method != "lm":
        _require_positive(args, "length_bound", "angle_bound")
        options.update(
            seed=args.seed,
            progress=not args.no_progress,
            length_bound=args.length_bound,
            angle_bound=args.angle_bound,
        )
        if args.maxiter is not None:
            options["maxiter"] = args.maxiter
    if args.method != "de":
        options.update(loss=args.loss, f_scale=args.f_scale)
    est = make_calibrator(args.method, model, **options)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MeasurementWarning)
        est.fit(data)
    for w in caught:
        if issubclass(w.category, MeasurementWarning):
            print(f"rmdrake: warning: {w.message}", file=sys.stderr)
    calibrated = est.model_
    record = dict(calibrated.calibration)
    record["data"] = {**record["data"], "file": str(args.measurements)}
    calibrated = dataclasses.replace(calibrated, calibration=record)
    print(
        f"robot '{model.name}': {data.n_readings} readings on "
        f"{data.plate_ids.size} plates from {args.measurements}"
    )
    print(est.summary())
    path = calibrated.save(args.out)
    print(f"wrote {path}")


def _per_joint_option(text: str, what: str) -> float | np.ndarray:
    """Parses ``0.05`` or a comma list ``0.1,0.1,0.05,...`` (one per joint)."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(
            f"{what}: expected a number or a comma-separated list, found {text!r}"
        ) from None
    return values[0] if len(values) == 1 else np.array(values)


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate the true robot on an excitation trajectory; write the log",
        description=(
            "Runs the true robot (Drake MultibodyPlant with friction and rotor "
            "inertia) under an inverse-dynamics controller on the nominal model "
            "along a Fourier trajectory and writes the joint-space log "
            "t,q1..qn,tau1..taun,qd1..qdn,qdd1..qddn (CSV, or NPZ for a .npz path)."
        ),
    )
    p.add_argument("--robot", required=True, help="the true robot (name or YAML)")
    p.add_argument("--trajectory", required=True, help="Fourier trajectory YAML")
    p.add_argument("--out", required=True, help="joint-space log to write")
    p.add_argument(
        "--nominal",
        help="robot model of the controller (default: the shipped robot whose "
        "name the true robot carries, else the true robot itself)",
    )
    p.add_argument("--rate", type=float, default=150.0, help="log rate, Hz")
    p.add_argument("--periods", type=float, default=1.0, help="trajectory periods")
    p.add_argument(
        "--noise",
        default="0",
        help="torque-sensor noise std, N m (one value or one per joint)",
    )
    p.add_argument(
        "--encoder-resolution",
        default="0",
        help="encoder resolution, rad per count (one value or one per joint)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the torque noise")
    p.add_argument(
        "--no-derivatives",
        action="store_true",
        help="write t,q,tau only (identification then estimates qd, qdd from q)",
    )
    p.add_argument(
        "--accuracy",
        type=float,
        default=1e-4,
        help="integrator target accuracy (error-controlled RK3)",
    )
    p.add_argument(
        "--v-eps",
        type=float,
        default=None,
        help="smooth-sign width of the Coulomb friction, rad/s (default 1e-3)",
    )
    p.set_defaults(handler=_run_simulate)


def _nominal_for(true_model: RobotModel, robot_arg: str) -> RobotModel:
    """Default controller model: the shipped robot named like the true one when
    the true robot was given as a file, else the true robot itself."""
    from rmdrake.robot import shipped_robots

    if true_model.name in shipped_robots() and robot_arg != true_model.name:
        return load_robot(true_model.name)
    return true_model


def _run_simulate(args: argparse.Namespace) -> None:
    import time

    from tqdm import tqdm

    from rmdrake.excitation import load_fourier
    from rmdrake.io import JointLog, write_joint_log
    from rmdrake.systems.friction import DEFAULT_V_EPS
    from rmdrake.systems.station import MakeStation, RunStation

    _require_positive(args, "rate", "periods")
    if not np.isfinite(args.accuracy) or not 0 < args.accuracy < 1:
        raise ValueError(
            f"--accuracy: expected 0 < accuracy < 1, found {args.accuracy}"
        )
    true_model = load_robot(args.robot)
    nominal = (
        load_robot(args.nominal)
        if args.nominal
        else _nominal_for(true_model, str(args.robot))
    )
    traj = load_fourier(args.trajectory)
    traj.check_limits(true_model)
    station = MakeStation(
        true_model,
        trajectory=traj,
        nominal_model=nominal,
        log_period=1.0 / args.rate,
        torque_noise=_per_joint_option(args.noise, "--noise"),
        encoder_resolution=_per_joint_option(
            args.encoder_resolution, "--encoder-resolution"
        ),
        seed=args.seed,
        v_eps=DEFAULT_V_EPS if args.v_eps is None else args.v_eps,
    )
    duration = args.periods * traj.period
    print(
        f"simulating '{true_model.name}' (controller model '{nominal.name}'"
        f"{'' if nominal is not true_model else ', the true robot itself'}) for "
        f"{duration:.6g} s ({args.periods:g} period(s) of {traj.period:.6g} s), "
        f"logging at {args.rate:g} Hz"
    )
    bar = tqdm(
        total=round(duration, 3), unit="s", unit_scale=False, desc="simulated",
        disable=None, leave=False, bar_format="{l_bar}{bar}| {n:.2f}/{total} s "
        "[{elapsed}<{remaining}]",
    )  # fmt: skip
    t0 = time.perf_counter()
    last = [0.0]

    def progress(t: float, t_final: float) -> None:
        if t - last[0] >= 0.01 * duration or t >= t_final:
            bar.update(t - last[0])
            last[0] = t

    try:
        log = RunStation(
            station, periods=args.periods, accuracy=args.accuracy, progress=progress
        )
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    if args.no_derivatives:
        log = JointLog(t=log.t, q=log.q, tau=log.tau)
    path = write_joint_log(args.out, log)
    deg = 180.0 / np.pi
    err = np.abs(log.q - traj.q(log.t)).max(axis=0) * deg
    peak = np.abs(log.tau).max(axis=0)
    print(
        f"wrote {path}: {log.n_samples} samples x {log.n_joints} joints "
        f"({'t,q,tau,qd,qdd' if log.qd is not None else 't,q,tau'}) in "
        f"{wall:.2f} s wall time ({duration / wall:.2f}x real time)"
    )
    print("max tracking error [deg]: " + ", ".join(f"{e:.3g}" for e in err))
    print("peak |tau| [N m]:         " + ", ".join(f"{v:.4g}" for v in peak))
    # The plant clamps actuation to +-effort; a joint at its limit saturated.
    effort = true_model.limits.effort
    for j in np.flatnonzero(peak >= effort * (1.0 - 1e-9)):
        share = np.mean(np.abs(log.tau[:, j]) >= effort[j] * (1.0 - 1e-9))
        print(
            f"warning: joint {j + 1} saturated at its effort limit {effort[j]:.4g} "
            f"N m in {100 * share:.1f} % of the samples (tracking suffers; "
            "lower the trajectory's accelerations)"
        )


def _add_excite(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "excite", help="optimal Fourier excitation by DE (paper eq. 16-17) -> YAML"
    )
    p.add_argument("--robot", required=True, help="shipped model name or robot YAML")
    p.add_argument("--out", required=True, help="Fourier trajectory YAML to write")
    p.add_argument("--harmonics", type=int, default=5)
    p.add_argument("--base-frequency", type=float, default=0.1, help="Hz")
    p.add_argument("--sample-rate", type=float, default=150.0, help="Hz")
    p.add_argument("--criterion", choices=("cond", "logdet"), default="cond")
    p.add_argument("--max-time", type=float, default=240.0, help="DE budget, s")
    p.add_argument("--maxiter", type=int, default=400, help="DE generations")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(handler=_run_excite)


def _run_excite(args: argparse.Namespace) -> None:
    from rmdrake.excitation import design_excitation

    _require_positive(args, "base_frequency", "sample_rate", "max_time")
    model = load_robot(args.robot)
    result = design_excitation(
        model,
        harmonics=args.harmonics,
        base_frequency=args.base_frequency,
        sample_rate=args.sample_rate,
        criterion=args.criterion,
        seed=args.seed,
        maxiter=args.maxiter,
        max_time=args.max_time,
    )
    path = result.trajectory.save(args.out)
    M = int(round(args.sample_rate / args.base_frequency))
    median = float(np.median(result.random_conds))
    median_full = float(np.median(result.random_conds_full))
    print(
        f"robot '{model.name}': {args.harmonics} harmonics at "
        f"{args.base_frequency:g} Hz; DE ({args.criterion}) ran "
        f"{result.generations} generations in {result.time:.1f} s ({result.stopped})"
    )
    print(
        f"cond(A) on {M} samples: optimised {result.cond:.4g}; median of "
        f"{result.random_conds.size} random feasible trajectories {median:.4g} "
        f"({median / result.cond:.2f}x higher), {median_full:.4g} "
        f"({median_full / result.cond:.2f}x) when each is scaled up to its limits"
    )
    print(f"wrote {path}")


def _add_identify(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("identify", help="dynamic identification from a joint log")
    p.add_argument("--robot", required=True, help="robot (kinematics; dynamics=prior)")
    p.add_argument("--log", required=True, help="joint-space log, CSV or NPZ")
    p.add_argument("--out", required=True, help="identified robot YAML to write")
    p.add_argument(
        "--method", choices=("ols", "wls", "de", "physical"), default="physical"
    )
    p.add_argument("--rate", type=float, default=None, help="resample to Hz")
    p.add_argument("--cutoff", type=float, default=None, help="low-pass Hz (0: none)")
    p.add_argument("--decimate", type=int, default=1)
    p.add_argument("--seed", type=int, default=0, help="seed of the DE method")
    p.add_argument(
        "--trajectory",
        default=None,
        help="the excitation YAML the log followed: the log must cover one period",
    )
    p.add_argument(
        "--derivative-cutoff",
        type=float,
        default=None,
        help="Hz: estimate missing derivatives from signals low-passed here, "
        "keeping q, qd, tau unfiltered",
    )
    p.add_argument(
        "--coulomb-width",
        type=float,
        default=0.0,
        help="rad/s: Coulomb term fc tanh(qd/width) instead of fc sign(qd) "
        "(rmdrake simulate uses 1e-3)",
    )
    p.set_defaults(handler=_run_identify)


def _run_identify(args: argparse.Namespace) -> None:
    from rmdrake.dynamics.data import prepare_samples
    from rmdrake.dynamics.identification import identified_model, identify
    from rmdrake.io import read_joint_log

    model = load_robot(args.robot)
    log = read_joint_log(args.log, n_joints=model.n_joints)
    if args.trajectory is not None:
        from rmdrake.excitation import load_fourier

        period = load_fourier(args.trajectory).period
        covered = float(log.t[-1] - log.t[0]) if log.t.size else 0.0
        # A period logged at rate r spans period - 1/r between its samples.
        step = float(np.median(np.diff(log.t))) if log.t.size > 1 else 0.0
        if covered + 1.5 * step < period:
            raise ValueError(
                f"log {args.log} covers {covered:.4g} s, shorter than one period "
                f"({period:.4g} s) of the excitation {args.trajectory}"
            )
    samples = prepare_samples(
        log.t,
        log.q,
        log.tau,
        log.qd,
        log.qdd,
        rate=args.rate,
        cutoff=args.cutoff,
        decimate=args.decimate,
        derivative_cutoff=args.derivative_cutoff,
    )
    result = identify(
        model,
        samples,
        method=args.method,
        seed=args.seed,
        progress=True,
        coulomb_width=args.coulomb_width,
    )
    notes = {
        "log": str(args.log),
        "samples": samples.n_samples,
        "rate_Hz": samples.rate,
        "preparation": list(samples.notes),
        "coulomb_width": args.coulomb_width,
    }
    path = identified_model(model, result, notes=notes).save(args.out)
    print(
        f"robot '{model.name}': {samples.n_samples} samples at {samples.rate:g} Hz; "
        f"{result.base.count} base parameters identified by {args.method}"
    )
    for note in samples.notes:
        print(f"  {note}")
    rms = ", ".join(f"{v:.4g}" for v in result.residual_rms)
    print(f"residual RMS per joint [N m]: {rms}")
    print(f"wrote {path}")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rmdrake",
        description="Accuracy for large manipulators in Drake (Wang et al. 2016).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (
        _add_show,
        _add_demo,
        _add_simulate_plates,
        _add_calibrate,
        _add_simulate,
        _add_excite,
        _add_identify,
    ):
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rmdrake`` console script; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        args.handler(args)
    except (ValueError, FileNotFoundError, RuntimeError) as e:
        print(f"rmdrake: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
