"""``rmdrake`` true-robot commands: draw a true robot with errors near a nominal
one, compare two robots' tool positions (argument parsing and printing only;
see :mod:`rmdrake.cli`)."""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from rmdrake.cli import options as arg
from rmdrake.model.perturb import (
    MAX_ANGLE_STD,
    MAX_DYNAMICS_STD,
    MAX_LENGTH_STD,
    MAX_SCALE_FACTOR,
    MAX_STIFFNESS_STD,
)

#: Poses of the tool error ``perturb`` prints (``compare``'s default).
_POSES = 1000


def _add_perturb(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "perturb", help="draw a true robot with errors near a nominal one -> YAML"
    )
    arg.add_robot_option(p, "the nominal robot")
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="true robot YAML to write"
    )
    p.add_argument(
        "--params",
        default="paper",
        help="error parameters: paper (default, the paper's 17), full (all 5 of "
        "every MDH row) or names, comma-separated (dalpha2,dd3,dr4)",
    )
    p.add_argument(
        "--length-std",
        type=arg.non_negative,
        default=0.5e-3,
        help="std of the length errors dd, dr, m (default %(default)s; at most "
        f"{MAX_LENGTH_STD:g})",
    )
    p.add_argument(
        "--angle-std",
        type=arg.non_negative,
        default=1e-3,
        help="std of the angle errors dalpha, dtheta, dbeta, rad (default "
        f"%(default)s; at most {MAX_ANGLE_STD:g})",
    )
    p.add_argument(
        "--dynamics-std",
        type=arg.non_negative,
        default=0.0,
        help="relative std of every link's 13 standard dynamic parameters "
        f"(default 0: unchanged; at most {MAX_DYNAMICS_STD:g})",
    )
    p.add_argument(
        "--stiffness-std",
        type=arg.non_negative,
        default=0.0,
        help="std of log stiffness of the elastic joints (default 0: unchanged; "
        f"at most {MAX_STIFFNESS_STD:g})",
    )
    p.add_argument(
        "--seed",
        type=arg.non_negative_int,
        default=0,
        help="seeds the draw: the same seed gives the same robot (default 0)",
    )
    p.add_argument(
        "--scale",
        type=_factors,
        default={},
        help="then multiply named dynamic parameters, NAME=FACTOR,...: a worn "
        "joint 3 is fv3=1.5,fc3=1.5 (viscous and Coulomb friction +50 %%); "
        "names XX1 .. fc<n> (M, Ia, fv, fc per link), each once; factors "
        f"between 1/{MAX_SCALE_FACTOR:g} and {MAX_SCALE_FACTOR:g}",
    )
    p.add_argument("--name", help="the true robot's name (default: NOMINAL_true)")
    p.set_defaults(handler=_perturb)


def _factors(text: str) -> dict[str, float]:
    """``fv3=1.5,fc3=1.5`` -> {name: factor}, each factor a number > 0 and
    each name given once (the bound on the factors is
    :func:`~rmdrake.model.perturb.scale_dynamics`')."""
    out: dict[str, float] = {}
    for item in text.split(","):
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise argparse.ArgumentTypeError(
                f"expected NAME=FACTOR,... (fv3=1.5,fc3=1.5), found {text!r}"
            )
        factor = arg.positive(value)
        if key.strip() in out:
            raise argparse.ArgumentTypeError(
                f"{key.strip()} given twice ({out[key.strip()]:g} and {factor:g}); "
                "give each parameter once"
            )
        out[key.strip()] = factor
    return out


def _perturb(args: argparse.Namespace) -> None:
    from rmdrake.kinematics.compare import tool_error_stats
    from rmdrake.model.perturb import perturb_robot, scale_dynamics

    nominal = arg.robot_of(args)
    stds = arg.pick(args, "length_std", "angle_std", "dynamics_std", "stiffness_std")
    if args.scale and not any(stds.values()):  # a scaling alone: nothing drawn
        true, deltas = dataclasses.replace(nominal, name=f"{nominal.name}_true"), {}
    else:
        true, deltas = perturb_robot(
            nominal, **stds, **arg.pick(args, "params", "seed", "name")
        )
    if args.scale:
        true = scale_dynamics(true, args.scale, name=args.name)
    print(f"robot '{true.name}' drawn from '{nominal.name}' (seed {args.seed}):")
    for name, value in deltas.items():
        if name.startswith(("dd", "dr")):
            print(f"  {name:<8} {value * 1e3:+.4f} mm")
        else:
            print(f"  {name:<8} {np.rad2deg(value):+.5f} deg")
    if args.dynamics_std or args.scale:
        _print_relative("dynamics", nominal.dynamics, true.dynamics)
    if args.stiffness_std:
        k0, k = nominal.compliance.stiffness, true.compliance.stiffness
        _print_relative("stiffness", k0, k)
    stats = tool_error_stats(nominal, true, n_poses=_POSES)
    print(_stats_line(nominal.name, true.name, stats))
    print(f"wrote {true.save(args.out)}")


def _print_relative(what: str, nominal: np.ndarray, true: np.ndarray) -> None:
    """One line: how far ``true`` is from ``nominal``, relative, over the
    non-zero entries."""
    nominal, true = np.asarray(nominal), np.asarray(true)
    nz = nominal != 0
    rel = np.abs(true[nz] / nominal[nz] - 1.0) * 100
    if rel.size == 0:
        return
    print(
        f"  {what}: {rel.size} non-zero entries changed by {np.median(rel):.3g} % "
        f"(median), {rel.max():.3g} % (largest)"
    )


def _stats_line(a: str, b: str, stats: dict[str, float]) -> str:
    return (
        f"tool error between {a} and {b} over {stats['n_poses']} random poses: "
        f"mean {stats['mean'] * 1e3:.4f} mm, 95th {stats['p95'] * 1e3:.4f} mm, "
        f"max {stats['max'] * 1e3:.4f} mm"
    )


def _add_compare(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="tool error between two models of one robot")
    p.add_argument(
        "--robot",
        required=True,
        action="append",
        type=arg.robot_path,
        help="a robot: name, YAML or URDF; give exactly two (--robot A --robot B)",
    )
    p.add_argument(
        "--poses",
        type=arg.count,
        default=_POSES,
        help="random poses within the joint limits (default %(default)s)",
    )
    p.add_argument(
        "--seed", type=arg.non_negative_int, default=0, help="seeds the poses"
    )
    p.add_argument(
        "--aligned",
        action="store_true",
        help="after the best rigid alignment of A's tool points onto B's: what "
        "plates cannot see (the base's pose) taken out, as the calibration "
        "study reports (needs --poses 3 or more)",
    )
    p.set_defaults(handler=_compare)


def _compare(args: argparse.Namespace) -> None:
    from rmdrake.kinematics.compare import (
        MIN_ALIGNED_POSES,
        aligned_poses_error,
        tool_error_stats,
    )
    from rmdrake.model.loading import load_robot

    if len(args.robot) != 2:
        raise ValueError(
            f"--robot: expected exactly two robots to compare, found {len(args.robot)}"
        )
    if args.aligned and args.poses < MIN_ALIGNED_POSES:
        raise ValueError(aligned_poses_error("--poses", args.poses))
    a, b = (load_robot(r) for r in args.robot)
    stats = tool_error_stats(
        a, b, n_poses=args.poses, seed=args.seed, aligned=args.aligned
    )
    line = _stats_line(*args.robot, stats)
    print(f"{line} (after the best rigid alignment)" if args.aligned else line)


PERTURB_COMMANDS = (_add_perturb, _add_compare)
