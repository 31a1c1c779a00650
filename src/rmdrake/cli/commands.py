"""The ``rmdrake`` command: argument parsing and printing only.

The robot commands live in :mod:`rmdrake.cli.robots`, the kinematic calibration
commands in :mod:`rmdrake.cli.calibration`, the rest here.
``_add_<name>(subparsers)`` declares a subcommand's arguments, each option
with a validating type of :mod:`rmdrake.cli.options`; its handler ``_<name>(args)``
calls the core or a study. :func:`main` refuses an output that names an input
and maps every outcome to an exit code and one line (:mod:`rmdrake.cli.exits`:
0 done, 1 internal error, 2 bad input, 3 refused result, 130 interrupted).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

from rmdrake.cli import options as arg
from rmdrake.cli.calibration import CALIBRATION_COMMANDS
from rmdrake.cli.dynamics import DYNAMICS_COMMANDS
from rmdrake.cli.exits import OneLineParser, run_handler
from rmdrake.cli.fleet import FLEET_COMMANDS
from rmdrake.cli.plan import PLAN_COMMANDS
from rmdrake.cli.poses import POSE_COMMANDS
from rmdrake.cli.robots import ROBOT_COMMANDS
from rmdrake.cli.sockets import SOCKET_COMMANDS
from rmdrake.model.loading import load_robot
from rmdrake.version import __version__

__all__ = ["build_parser", "main"]


_MIN_LOG_SAMPLES = 3  # simulate: the shortest run, in log periods
_DEBUG, _HIDE = "on an error, print its traceback too", argparse.SUPPRESS


def _add_run(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a study from a scenario file")
    p.add_argument(
        "--scenario-file",
        type=arg.input_path("scenario"),
        help="YAML (default: the shipped scenarios)",
    )
    p.add_argument("--scenario", required=True, help="scenario name in the file")
    p.add_argument(
        "--out", required=True, type=arg.output_folder, help="folder for results"
    )
    p.add_argument("--meshcat", action="store_true", help="show the tracking live")
    arg.add_execution_options(p)
    p.set_defaults(handler=_run)


def _run(args: argparse.Namespace) -> None:
    from rmdrake.studies.runner import run_scenario
    from rmdrake.studies.scenarios import SHIPPED_SCENARIOS, load_scenario

    path = args.scenario_file or SHIPPED_SCENARIOS
    scenario = load_scenario(path, args.scenario)
    execution = arg.execution_of(args)
    run_scenario(
        scenario,
        args.out,
        name=args.scenario,
        meshcat=args.meshcat,
        execution=execution,
    )


def _add_demo(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the main job: the paper's whole study")
    p.add_argument(
        "--out", default="out/demo", type=arg.output_folder, help="results folder"
    )
    p.add_argument("--smoke", action="store_true", help="scenario paper_smoke")
    arg.add_execution_options(p)
    p.set_defaults(handler=_demo)


def _demo(args: argparse.Namespace) -> None:
    """Runs the shipped scenario ``paper`` (``paper_smoke`` with --smoke)."""
    args.scenario_file, args.meshcat = None, False
    args.scenario = "paper_smoke" if args.smoke else "paper"
    _run(args)


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="the true robot in Drake on a trajectory")
    p.add_argument("--robot", required=True, type=arg.robot_path, help="the true robot")
    p.add_argument(
        "--trajectory",
        required=True,
        type=arg.input_path("trajectory"),
        help="Fourier trajectory YAML",
    )
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="joint-space log to write"
    )
    p.add_argument(
        "--nominal",
        type=arg.robot_path,
        help="controller's robot (default: the shipped one)",
    )
    p.add_argument("--rate", type=arg.positive, default=150.0, help="log rate, Hz")
    p.add_argument("--periods", type=arg.positive, default=1.0, help="periods to run")
    p.add_argument("--noise", type=arg.per_joint, default=0.0, help="torque std, N m")
    p.add_argument("--encoder-resolution", type=arg.per_joint, default=0.0, help="rad")
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="noise seed")
    p.add_argument("--no-derivatives", action="store_true", help="write t,q,tau only")
    p.add_argument(
        "--motor-side",
        action="store_true",
        help="write the drives' log t,qm,taum[,qdm,qddm] (the robot's transmission)",
    )
    p.add_argument("--accuracy", type=arg.unit_interval, default=1e-4, help="RK3's")
    p.add_argument("--v-eps", type=arg.positive, help="Coulomb width, rad/s")
    p.add_argument("--bandwidth", type=arg.positive, help="feedback, rad/s")
    p.set_defaults(handler=_simulate)


def _simulate(args: argparse.Namespace) -> None:
    from rmdrake.excitation.trajectory import load_fourier
    from rmdrake.pipelines.simulate import simulate_file

    duration = args.periods * load_fourier(args.trajectory).period
    if duration * args.rate < _MIN_LOG_SAMPLES:  # Drake fails on a shorter run
        raise ValueError(
            f"--periods {args.periods:g}: {duration:.3g} s is under "
            f"{_MIN_LOG_SAMPLES} log periods at --rate {args.rate:g} Hz"
        )
    simulate_file(
        args.robot,
        args.trajectory,
        args.out,
        **arg.pick(args, "nominal", "periods", "rate", "accuracy", "v_eps", "seed"),
        bandwidth=args.bandwidth,
        derivatives=not args.no_derivatives,
        motor_side=args.motor_side,
        torque_noise=args.noise,
        encoder_resolution=args.encoder_resolution,
    )


def _add_excite(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("excite", help="optimal Fourier excitation by DE -> YAML")
    p.add_argument("--robot", required=True, type=arg.robot_path, help="name or YAML")
    p.add_argument(
        "--out",
        required=True,
        type=arg.output_path,
        help="Fourier trajectory YAML to write",
    )
    p.add_argument(
        "--harmonics", type=arg.count, default=5, help="Fourier harmonics per joint"
    )
    p.add_argument("--base-frequency", type=arg.positive, default=0.1, help="Hz")
    p.add_argument("--sample-rate", type=arg.positive, default=150.0, help="Hz")
    p.add_argument(
        "--criterion",
        "--objective",
        choices=("cond", "logdet"),
        default="cond",
        help="cond(A) (paper eq. 16) or log det of the information matrix "
        "(D-optimal); both figures are printed",
    )
    p.add_argument(
        "--max-time",
        type=arg.positive,
        help="wall-time budget of the DE, s (default: none, the generations "
        "decide: the same trajectory on any machine; a budget that stops the "
        "design warns, and the trajectory file says so)",
    )
    p.add_argument("--maxiter", type=arg.count, default=600, help="DE generations")
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="DE's seed")
    p.add_argument("--payload", action="store_true", help="condition the tool "
                   "payload's 10 parameters (for identify-payload)")  # fmt: skip
    arg.add_scene_options(p, "the trajectory")
    arg.add_execution_options(p, default=_EXCITE_WORKERS)
    p.set_defaults(handler=_excite)


_EXCITE_WORKERS = (
    "0, this process: a generation of the RV-3SB's 210 candidates takes "
    "0.065 s on one core, less than a round trip to workers; workers pay "
    "with larger populations and more cores"
)


def _excite(args: argparse.Namespace) -> None:
    from rmdrake.excitation.design import design_excitation

    model = load_robot(args.robot)
    names = ("harmonics", "base_frequency", "sample_rate", "criterion", "seed")
    options = arg.pick(args, *names, "maxiter", "max_time")
    options["budget_keys"] = ("--max-time", "--maxiter")
    if args.payload:
        options["payload"] = True
    options.update(arg.clearance_options(args, model))
    options["execution"] = arg.execution_of(args, default_workers=0)
    result = design_excitation(model, **options)
    path = result.save(args.out)  # headed by the budget's warning, if any
    print(f"robot '{model.name}': {result.summary()}")
    print(f"wrote {path}")


def _add_identify(sub: argparse._SubParsersAction) -> None:
    from rmdrake.dynamics.estimators import IDENTIFICATION_METHODS

    log_help = "joint-space log, CSV or NPZ; repeat for several (stacked)"
    idle_help = "rad/s or m/s; standstill at the ends is removed (0: kept)"

    p = sub.add_parser("identify", help="dynamic identification from a joint log")
    arg.add_robot_option(p, "robot (kinematics; dynamics = prior)")
    p.add_argument(
        "--log",
        required=True,
        action="append",
        type=arg.input_path("log"),
        help=log_help,
    )
    p.add_argument(
        "--out",
        required=True,
        type=arg.output_path,
        help="identified robot YAML to write",
    )
    p.add_argument(
        "--method",
        choices=IDENTIFICATION_METHODS,
        default="physical",
        help="estimator",
    )
    arg.add_log_options(p)
    p.add_argument("--idle-speed", type=arg.non_negative, help=idle_help)
    p.add_argument(
        "--decimate", type=arg.count, default=1, help="keep every k-th sample"
    )
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="DE's seed")
    p.add_argument(
        "--trajectory",
        type=arg.input_path("trajectory"),
        help="the excitation of a single log (checked)",
    )
    p.add_argument(
        "--prior", type=arg.robot_path, help="robot YAML whose dynamics are the prior"
    )
    p.add_argument("--mass-bounds", help="kg, LO:HI for every link or one per link")
    p.add_argument("--total-mass", help="kg, LO:HI on the sum of the link masses")
    p.add_argument("--terms", help=_TERMS_HELP)
    p.add_argument("--gains", type=arg.per_joint, help="N m/A per joint for a log "
                   "of currents i1..in (default: the robot's drive: gain)")  # fmt: skip
    p.add_argument("--force", action="store_true", help=arg.FORCE_HELP)
    p.set_defaults(handler=_identify)


_TERMS_HELP = (
    "dynamic terms to fit, changing the robot's model: entry: comma-separated "
    "NAME (on), no-NAME or NAME=0 (off), NAME=1 (on); NAME one of rotor_inertia "
    "(rotor, ia), viscous (fv), coulomb (fc), offset (tau0), coulomb_asymmetric "
    "(asymmetric, fcn); e.g. no-rotor,offset for a joint-torque-sensing arm"
)


def _identify(args: argparse.Namespace) -> None:
    from rmdrake.dynamics.identification import parse_mass_range
    from rmdrake.pipelines.identify import identify_file

    options = arg.pick(args, "trajectory", "method", "seed", "force")
    options.update(arg.pick(args, "prior", "gains"))
    if args.mass_bounds is not None:
        bounds = parse_mass_range(args.mass_bounds, "--mass-bounds")
        options["mass_bounds"] = bounds[0] if len(bounds) == 1 else bounds
    if args.total_mass is not None:
        total = parse_mass_range(args.total_mass, "--total-mass")
        if len(total) != 1:
            raise ValueError(
                f"--total-mass: expected one LO:HI, found {args.total_mass!r}"
            )
        options["total_mass"] = tuple(total[0])
    options.update(arg.log_options(args), decimate=args.decimate)
    if args.idle_speed is not None:  # else prepare_samples' default
        options["idle_speed"] = args.idle_speed
    robot = arg.robot_of(args)
    if args.terms is not None:
        terms = robot.dynamic_terms.with_text(args.terms)
        robot = dataclasses.replace(robot, terms=terms)
    print(f"wrote {identify_file(robot, args.log, args.out, **options)}")


def _add_correct(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("correct", help="correct a program for a calibrated robot")
    p.add_argument(
        "--robot", required=True, type=arg.robot_path, help="calibrated robot"
    )
    p.add_argument(
        "--targets",
        required=True,
        type=arg.input_path("targets"),
        help="x,y,z[,roll,pitch,yaw] or q CSV",
    )
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="corrected joint program CSV"
    )
    p.add_argument(
        "--nominal",
        type=arg.robot_path,
        help="the program's robot (default: the shipped robot named in --robot's "
        "file, else --robot itself)",
    )
    p.add_argument("--allow-unreachable", action="store_true", help="write the rest")
    p.add_argument("--payload", type=float, metavar="KG", help="tool payload of an "
                   "elastic robot's pre-deflection (default: its own)")  # fmt: skip
    p.set_defaults(handler=_correct)


def _correct(args: argparse.Namespace) -> None:
    from rmdrake.pipelines.correct import correct_file

    options = arg.pick(args, "nominal", "allow_unreachable", "payload")
    print(f"wrote {correct_file(args.robot, args.targets, args.out, **options)}")


def _add_validate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="held-out torque errors of robots on a log")
    p.add_argument("--robot", required=True, action="append", type=arg.robot_path,
                   help="robot YAML "
                   "with dynamics (repeat for a side-by-side table)")  # fmt: skip
    p.add_argument("--log", required=True, action="append",
                   type=arg.input_path("log"), help="joint-space log, "
                   "CSV or NPZ (repeat: logs prepared one by one)")  # fmt: skip
    p.add_argument(
        "--plot",
        type=arg.output_path,
        help="PNG of measured vs predicted torques to write",
    )
    p.add_argument(
        "--html",
        type=arg.output_path,
        help="Meshcat HTML of the logged motion (with --scene's cell)",
    )
    p.add_argument("--scene", type=arg.input_path("cell"),
                   help="robot cell YAML or shipped name: drawn with --html, and "
                   "the motion's nearest approach to it printed (entering it: a "
                   "warning with the link and the time; exit code unchanged)"
                   )  # fmt: skip
    arg.add_log_options(p)
    p.add_argument("--force", action="store_true", help="refusals as warnings")
    p.set_defaults(handler=_validate)


def _validate(args: argparse.Namespace) -> None:
    from rmdrake.model.scene import load_cell
    from rmdrake.pipelines.validate import validate_file

    cell = load_cell(args.scene) if args.scene else None
    options = {**arg.log_options(args), "plot": args.plot, "force": args.force}
    validate_file(args.robot, args.log, html=args.html, cell=cell, **options)


_COMMANDS = (*ROBOT_COMMANDS, _add_demo, _add_run, *CALIBRATION_COMMANDS)
_COMMANDS += DYNAMICS_COMMANDS  # identify-gains, identify-payload
_COMMANDS += PLAN_COMMANDS  # plan: a calibration plan over many arms
_COMMANDS += FLEET_COMMANDS  # fleet: identify many arms, flag drift
_COMMANDS += SOCKET_COMMANDS  # simulate-sockets, import-sockets
_COMMANDS += POSE_COMMANDS  # simulate-poses
_COMMANDS += (_add_simulate, _add_excite, _add_identify, _add_correct, _add_validate)


_PACKAGE = Path(__file__).resolve().parents[1]
"""The installed ``rmdrake`` folder: a warning raised from a file in it is ours."""


def _shows_warnings(default: Callable[..., None]) -> Callable[..., None]:
    """A ``warnings.showwarning`` that prints rmdrake's own warnings as one line
    ``rmdrake: warning: ...`` and leaves the others (Dask's, scipy's, a user's
    plug-in's) to ``default``, in Python's usual form: a third party's warning is
    never printed as if rmdrake said it."""

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        ours = category.__module__.split(".")[0] == "rmdrake"
        ours = ours or Path(filename).resolve().is_relative_to(_PACKAGE)
        if ours:
            print(f"rmdrake: warning: {message}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    return show


def build_parser() -> argparse.ArgumentParser:
    """The ``rmdrake`` parser: every subcommand with its typed options."""
    parser = OneLineParser(
        prog="rmdrake",
        description="Accuracy for large manipulators in Drake (Wang et al. 2016).",
    )
    parser.add_argument("--debug", action="store_true", help=_DEBUG)
    parser.add_argument("--version", action="version", version=f"rmdrake {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in _COMMANDS:
        add(sub)
    for p in sub.choices.values():  # --debug after the command too
        p.add_argument("--debug", action="store_true", default=_HIDE, help=_DEBUG)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rmdrake`` console script; returns the exit code
    (0 done, 1 internal error, 2 bad input, 3 refused result, 130 interrupted)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # --help (0) or a bad option (2, one line printed)
        return int(e.code or 0)
    folder = args.out if args.command in arg.FOLDER_COMMANDS else None
    with warnings.catch_warnings():
        warnings.showwarning = _shows_warnings(warnings.showwarning)
        return run_handler(_command, args, debug=args.debug, folder=folder)


def _command(args: argparse.Namespace) -> None:
    """The subcommand's handler, once its output paths are checked."""
    arg.check_paths(args)
    args.handler(args)


if __name__ == "__main__":
    sys.exit(main())
