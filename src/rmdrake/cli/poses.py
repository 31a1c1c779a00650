"""``rmdrake`` pose-data commands: simulate 6-DoF readings of a marker on the
tool (argument parsing and printing only; see :mod:`rmdrake.cli`). The file
is a pose CSV (:mod:`rmdrake.calibration.poses.data`) that ``rmdrake
calibrate`` reads once the pose kind is registered."""

from __future__ import annotations

import argparse

from rmdrake.cli import options as arg
from rmdrake.cli.options import pick

__all__ = ["POSE_COMMANDS"]


def _add_simulate_poses(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate-poses", help="simulate 6-DoF readings of a marker on the tool"
    )
    arg.add_robot_option(p, "the true robot")
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="pose CSV to write"
    )
    p.add_argument("--poses", type=arg.count, default=40, help="robot poses")
    p.add_argument(
        "--noise", type=arg.non_negative, default=2e-5, help="position std, m"
    )
    p.add_argument(
        "--angle-noise", type=arg.non_negative, default=5e-5, help="angle std, rad"
    )
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="random seed")
    p.add_argument(
        "--selection",
        choices=("first", "d-optimal"),
        default="first",
        help="the first poses drawn, or a D-optimal choice from 4x as many",
    )
    arg.add_scene_options(p, "every pose")
    p.set_defaults(handler=_simulate_poses)


def _simulate_poses(args: argparse.Namespace) -> None:
    from rmdrake.calibration.poses.data import write_pose_measurements
    from rmdrake.calibration.poses.simulate import simulate_poses

    model = arg.robot_of(args)
    options = pick(args, "poses", "seed", "selection")
    options.update(arg.clearance_options(args, model))
    sim = simulate_poses(model, noise_p=args.noise, noise_r=args.angle_noise, **options)
    path = write_pose_measurements(args.out, sim.data)
    print(f"robot '{model.name}' (seed {args.seed}): {sim.summary()}")
    print(f"wrote {path}")


POSE_COMMANDS = (_add_simulate_poses,)
"""simulate-poses."""
