"""``rmdrake plan``: will a calibration plan reach a tool accuracy on every arm
built, and with what confidence (argument parsing and printing only; the
study is :mod:`rmdrake.studies.planning`)."""

from __future__ import annotations

import argparse
import sys

from rmdrake.cli import options as arg

_DESCRIPTION = """\
Monte Carlo planning of a kinematic calibration: draws N true arms within the
build tolerances, takes each one's readings with the plan, calibrates it (LM
of --params, as `rmdrake calibrate --method lm --params`, with its sanity
checks against --noise) and measures its tool-point error at
held-out poses. Writes OUT/plan.yaml, robots.csv (one row per arm and plan),
summary.yaml and plan.png, and prints the plan with the fewest readings that
meets --target on at least --confidence of the arms (the one-sided 95 %
lower bound of its share of arms, so enough arms must be drawn: 59 of 59 show
0.95). Each arm is a task:
local Dask worker processes by default, one per core."""


def _readings(text: str) -> tuple[int, ...]:
    """``30,60,120``: counts >= 1, each once."""
    values = tuple(arg.count(v.strip()) for v in text.split(","))
    if len(set(values)) != len(values):
        raise argparse.ArgumentTypeError(f"a count given twice in {text!r}")
    return values


def _confidence(text: str) -> float:
    """A fraction in (0, 1): 1 cannot be shown by any number of arms."""
    value = arg.positive(text)
    if value >= 1:
        raise argparse.ArgumentTypeError(
            f"expected 0 < value < 1, found {text} (the 95 % lower bound of N arms "
            "of N is 0.05^(1/N), never 1; give e.g. 0.99)"
        )
    return value


def _add_plan(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "plan",
        help="will a calibration plan reach a tool accuracy on every arm? "
        "(Monte Carlo over true arms)",
        description=_DESCRIPTION,
    )
    arg.add_robot_option(p, "nominal robot")
    p.add_argument(
        "--robots",
        required=True,
        type=arg.count,
        metavar="N",
        help="true arms drawn (N)",
    )
    kind = p.add_mutually_exclusive_group(required=True)
    kind.add_argument(
        "--plates", type=arg.count, metavar="P", help="plate plan: plate locations (P)"
    )
    kind.add_argument(
        "--poses", type=arg.count, metavar="P", help="tracker plan: robot poses (P)"
    )
    kind.add_argument(
        "--placements",
        type=arg.count,
        metavar="P",
        help="socket plan: placements of a plate with two sockets 50 mm apart (P)",
    )
    kind.add_argument(
        "--frames",
        type=arg.count,
        metavar="F",
        help="6-DoF plan: robot poses, each measured as a marker frame (F)",
    )
    p.add_argument(
        "--per-plate",
        type=arg.count,
        metavar="K",
        help="plates: readings per plate (default 12; --readings overrides it)",
    )
    p.add_argument(
        "--markers",
        type=arg.count,
        metavar="M",
        help="points: markers on the tool, each measured at every pose (default 3)",
    )
    p.add_argument(
        "--per-socket",
        type=arg.count,
        metavar="K",
        help="sockets: seated configurations per socket (default 25; --readings "
        "overrides it)",
    )
    p.add_argument(
        "--angle-noise",
        type=arg.non_negative,
        metavar="RAD",
        help="frames: the instrument's angle noise std per axis, rad (default "
        "2.5 rad/m x --noise)",
    )
    p.add_argument(
        "--noise",
        required=True,
        metavar="SIGMA",
        type=arg.non_negative,
        help="instrument noise std, m: range finder per reading, tracker per "
        "coordinate, socket seating per coordinate, 6-DoF position per "
        "coordinate (declared to the sanity checks)",
    )
    p.add_argument(
        "--length-std",
        type=arg.non_negative,
        metavar="M",
        default=0.0,
        help="m, std of the true length errors dd<j>, dr<j> of --params",
    )
    p.add_argument(
        "--angle-std",
        type=arg.non_negative,
        metavar="RAD",
        default=0.0,
        help="rad, std of the true angle errors dalpha<j>, dtheta<j>, dbeta<j> "
        "of --params",
    )
    p.add_argument(
        "--stiffness-std",
        type=arg.non_negative,
        metavar="STD",
        default=0.0,
        help="std of log k of each elastic joint (a factor exp(+-std) at one "
        "sigma; robots with elastic joints only)",
    )
    p.add_argument(
        "--params",
        default="paper",
        metavar="PARAMS",
        help="error parameters drawn and fitted: paper (Wang et al.'s 17), full, "
        "or comma names (dalpha2,dd3,...); full, and any set on points, is "
        "fitted as its identifiable subset",
    )
    p.add_argument(
        "--readings",
        type=_readings,
        metavar="R1,R2,...",
        help="plan sizes to sweep, comma counts: plates: readings in all, each a "
        "multiple of --plates (per plate = readings / plates, overriding "
        "--per-plate); points: poses (overriding --poses); sockets: "
        "configurations in all, each a multiple of 2 x --placements. Default: "
        "the one plan",
    )
    p.add_argument(
        "--poses-from",
        choices=("random", "d-optimal"),
        default="random",
        help="poses: random valid ones, or the D-optimal ones of a pool 4 times "
        "larger, planned with the nominal",
    )
    p.add_argument(
        "--target",
        required=True,
        metavar="M",
        type=arg.positive,
        help="m: an arm meets it when its mean held-out tool-point error is at "
        "most this (1e-4 = 0.1 mm; at most 0.1 of the robot's reach)",
    )
    p.add_argument(
        "--confidence",
        type=_confidence,
        metavar="FRACTION",
        default=0.95,
        help="the fraction of arms that must meet the target, in (0, 1): the "
        "recommended plan's one-sided 95 %% lower bound on its fraction reaches "
        "it (all of N arms show 0.05^(1/N): 59 arms for 0.95)",
    )
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="plan seed")
    p.add_argument(
        "--validation",
        type=arg.count,
        metavar="POSES",
        default=200,
        help="held-out poses per arm, uniform within the joint limits",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        type=arg.output_folder,
        help="folder for plan.yaml, robots.csv, summary.yaml and plan.png; one "
        "that holds a robots.csv is refused without --resume",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the interrupted plan in --out (the same options; "
        "--target and --confidence may change): only the missing arms run",
    )
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    arg.add_execution_options(p)
    p.set_defaults(handler=_plan)


def _plan(args: argparse.Namespace) -> None:
    from rmdrake.calibration.registry import KINDS
    from rmdrake.studies.planning import PlanConfig, run_plan

    robot = arg.robot_of(args)
    kinds = list(KINDS.values())
    kind = next(k for k in kinds if getattr(args, k.plan_option) is not None)
    for other in kinds:
        if other is not kind and getattr(args, other.plan_extra) is not None:
            raise ValueError(
                f"--{other.plan_extra.replace('_', '-')}: a {other.plan_word} "
                f"plan's option; this is --{kind.plan_option}"
            )
    plan = kind.plan(getattr(args, kind.plan_option), getattr(args, kind.plan_extra))
    config = PlanConfig(
        robot=robot,
        robots=args.robots,
        noise=args.noise,
        length_std=args.length_std,
        angle_std=args.angle_std,
        stiffness_std=args.stiffness_std,
        params=args.params,
        readings=args.readings or (),
        poses_from=args.poses_from,
        target=args.target,
        confidence=args.confidence,
        seed=args.seed,
        n_validation=args.validation,
        plan=plan,
    )
    try:
        # A scheduler answers before plan.yaml or robots.csv is written: a
        # wrong address leaves no plan that a rerun would have to --resume.
        with arg.connected(arg.execution_of(args)) as execution:
            run_plan(
                config,
                args.out,
                execution=execution,
                resume=args.resume,
                progress=not args.no_progress,
            )
    except KeyboardInterrupt:
        print(
            f"rmdrake: interrupted; the arms done are kept in {args.out}/robots.csv: "
            "rerun with --resume to finish the plan",
            file=sys.stderr,
        )
        raise SystemExit(130) from None


PLAN_COMMANDS = (_add_plan,)
