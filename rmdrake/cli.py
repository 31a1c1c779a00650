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
    from pathlib import Path

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"== rmdrake demo: the study of Wang et al. (SOFT 2016) into {out}/")
    print("\n== 1. The robot")
    _run_show(
        argparse.Namespace(robot="rv3sb", html=str(out / "rv3sb.html"), port=None)
    )


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rmdrake",
        description="Accuracy for large manipulators in Drake (Wang et al. 2016).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_add_show, _add_demo):
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
