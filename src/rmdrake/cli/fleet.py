"""``rmdrake fleet``: identify many arms, one log each, and name the ones that
have drifted from the fleet (argument parsing and printing only; the method is
:mod:`rmdrake.dynamics.fleet`, the files :mod:`rmdrake.pipelines.fleet`; see
:mod:`rmdrake.cli`)."""

from __future__ import annotations

import argparse
import dataclasses

from rmdrake.cli import options as arg

__all__ = ["FLEET_COMMANDS"]

_DESCRIPTION = """\
Identifies each joint log as one arm (named after the log's stem), writes
OUT/<arm>.yaml per arm and OUT/fleet.csv (a row per arm: its base parameters,
their standard deviations, its flags), and flags every parameter where an arm
departs from the fleet's robust centre (median over the arms; spread Qn, a
robust standard deviation) by more than the threshold, in sigma, where sigma
counts the arm's own std and the fleet's spread (sqrt(std^2 + spread^2)),
corrected for the few arms the spread comes from. The threshold is set so that
a healthy fleet raises any flag with probability --false-alarm (1 %: 4.06 sigma
for 4 arms x 52 parameters, 4.31 for 12, 4.44 for 21), or given (--threshold).
A fleet of a few arms cannot measure its spread: give the build spread the
manufacturer states (--build-spread 3%), pooled with the fleet's. With
--reference the centre is that
robot's parameters instead. An arm whose log is bad or whose fit is refused is
a failed row and the others go on; the exit code is then 3 (after writing the
others).

With --history the logs are one arm's over time, each dated in its file name
(arm3_2026-01-15.csv): each is identified, each base parameter gets a trend
(weighted straight line over the dates, per year, with its std) and those
that drift beyond the family-wise threshold over the parameters are flagged;
written: OUT/<log>.yaml per log, OUT/history.csv (a row per parameter: trend,
its std, sigma, change), OUT/history_fits.csv (a row per fit) and
OUT/history.png (each flagged parameter over time)."""


def _add_fleet(sub: argparse._SubParsersAction) -> None:
    from rmdrake.dynamics.fleet import (
        DEFAULT_BUILD_DOF,
        DEFAULT_FALSE_ALARM,
        FLEET_METHODS,
        MAX_THRESHOLD,
    )

    p = sub.add_parser(
        "fleet",
        help="identify many arms, one log each; flag the arms that drifted",
        description=_DESCRIPTION,
    )
    arg.add_robot_option(p, "the robot of every arm (kinematics; dynamics = prior)")
    p.add_argument(
        "--logs",
        required=True,
        nargs="+",
        type=arg.input_path("log"),
        metavar="LOG",
        help="joint logs, one per arm (CSV or NPZ): paths or a quoted glob "
        "pattern ('logs/*.csv'); each arm is named after its log's stem",
    )
    p.add_argument(
        "--out",
        required=True,
        type=arg.output_folder,
        help="folder for <arm>.yaml and fleet.csv (created if missing)",
    )
    p.add_argument(
        "--history",
        action="store_true",
        help="the logs are one arm's over time, each with its date YYYY-MM-DD "
        "in its file name: flag the parameters that drift, with their trend",
    )
    p.add_argument(
        "--threshold",
        type=_threshold,
        help="flag a parameter beyond this many sigma (combined standard "
        "deviations, corrected for the fleet's size; at most "
        f"{MAX_THRESHOLD:g}); default: the family-wise threshold of --false-alarm",
    )
    p.add_argument(
        "--false-alarm",
        type=arg.unit_interval,
        default=DEFAULT_FALSE_ALARM,
        help="the chance that a healthy fleet raises any flag, which sets the "
        "threshold over arms x parameters tests",
    )
    p.add_argument(
        "--build-spread",
        type=_relative,
        metavar="SPREAD",
        help="known arm-to-arm spread of every standard dynamic parameter, one "
        "sigma, relative ('3%%' or 0.03), pooled with the fleet's spread; for "
        "fleets of a few arms",
    )
    p.add_argument(
        "--build-dof",
        type=_dof,
        default=DEFAULT_BUILD_DOF,
        help="degrees of freedom of --build-spread ('inf': exact, the fleet's "
        "spread is not used)",
    )
    p.add_argument(
        "--reference",
        type=arg.robot_path,
        help="compare with this known-good robot (an identified YAML, with its "
        "stds, or any robot with dynamics) instead of the fleet's median",
    )
    p.add_argument(
        "--method",
        choices=FLEET_METHODS,
        default="wls",
        help="estimator (least squares: they record each parameter's std)",
    )
    arg.add_log_options(p)
    p.add_argument("--idle-speed", type=arg.non_negative, help="rad/s or m/s; "
                   "standstill at the ends is removed (0: kept)")  # fmt: skip
    p.add_argument(
        "--decimate", type=arg.count, default=1, help="keep every k-th sample"
    )
    p.add_argument("--terms", help="dynamic terms to fit, as identify's --terms")
    arg.add_execution_options(p)
    p.set_defaults(handler=_fleet)


def _relative(text: str) -> float:
    """A relative spread, ``3%`` or ``0.03``, in [0, 0.5]."""
    pct = text.strip().endswith("%")
    value = arg.non_negative(text.strip().rstrip("%")) / (100.0 if pct else 1.0)
    if value > 0.5:
        raise argparse.ArgumentTypeError(
            f"expected a relative spread up to 50 %, found {text} (3 %: '3%%')"
        )
    return value


def _threshold(text: str) -> float:
    """sigma > 0, at most :data:`~rmdrake.dynamics.fleet.MAX_THRESHOLD`."""
    from rmdrake.dynamics.fleet import check_threshold

    try:
        return check_threshold(arg.positive(text), "")
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).lstrip(": ")) from None


def _dof(text: str) -> float:
    """Degrees of freedom > 0, or ``inf``."""
    return float("inf") if text.strip().lower() == "inf" else arg.positive(text)


def _fleet(args: argparse.Namespace) -> None:
    from rmdrake.errors import ImplausibleResultError
    from rmdrake.model.loading import load_robot
    from rmdrake.pipelines.fleet import (
        FLEET_CSV,
        arm_names,
        check_fleet_options,
        expand_logs,
        run_fleet,
    )

    logs = expand_logs(args.logs)
    names = arm_names(logs)
    log_path, out_path = arg.input_path("log"), arg.output_path
    if args.history:
        from rmdrake.pipelines.history import (
            HISTORY_CSV,
            HISTORY_FITS_CSV,
            HISTORY_PNG,
            log_dates,
        )

        for other in ("reference", "build_spread"):
            if getattr(args, other) is not None:
                flag = "--" + other.replace("_", "-")
                raise ValueError(f"{flag}: not with --history (one arm, its own fits)")
        log_dates(logs)  # every log dated, before any work
        tables = [HISTORY_CSV, HISTORY_FITS_CSV, HISTORY_PNG]
    else:
        tables = [FLEET_CSV]
    options = {**arg.log_options(args), "decimate": args.decimate}
    check_fleet_options(args.method, args.threshold, options)  # before any work
    files = argparse.Namespace(  # the robot files are inputs too: never written
        robot=args.robot,
        reference=args.reference,
        logs=[log_path(str(p)) for p in logs],
        out=[out_path(f"{args.out}/{n}.yaml") for n in names]
        + [out_path(f"{args.out}/{t}") for t in tables],
    )
    arg.check_paths(files)  # not a FIFO, no output over a log, all writable
    robot = arg.robot_of(args)
    if args.terms is not None:
        terms = robot.dynamic_terms.with_text(args.terms)
        robot = dataclasses.replace(robot, terms=terms)
    if args.idle_speed is not None:  # else prepare_samples' default
        options["idle_speed"] = args.idle_speed
    if args.history:
        from rmdrake.pipelines.history import run_history

        history = run_history(
            robot,
            logs,
            args.out,
            method=args.method,
            threshold=args.threshold,
            false_alarm=args.false_alarm,
            execution=arg.execution_of(args),
            **options,
        )
        if history.failed:
            listed = ", ".join(a.arm for a in history.failed)
            raise ImplausibleResultError(
                [
                    f"{len(history.failed)} of {len(history.fits)} logs not "
                    f"identified ({listed}): see their rows in {history.fits_csv}"
                ]
            )
        return
    reference = load_robot(args.reference) if args.reference else None
    run = run_fleet(
        robot,
        logs,
        args.out,
        method=args.method,
        threshold=args.threshold,
        false_alarm=args.false_alarm,
        build_spread=args.build_spread,
        build_dof=args.build_dof,
        reference=reference,
        execution=arg.execution_of(args),
        **options,
    )
    if run.failed:
        listed = ", ".join(a.arm for a in run.failed)
        raise ImplausibleResultError(
            [
                f"{len(run.failed)} of {len(run.arms)} arms not identified "
                f"({listed}): see their rows in {run.csv}; the others are written"
            ]
        )


FLEET_COMMANDS = (_add_fleet,)
