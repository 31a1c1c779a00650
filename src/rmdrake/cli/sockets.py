"""``rmdrake`` socket-data commands: simulate a ball seated in sockets, import
MUKCa's recordings (argument parsing and printing only; see :mod:`rmdrake.cli`).
Both write a socket CSV and its distance file beside it
(:mod:`rmdrake.calibration.sockets.data`)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rmdrake.calibration.sockets.data import MUKCA_SOCKET_DISTANCE, distances_path
from rmdrake.cli import options as arg
from rmdrake.cli.options import pick

__all__ = ["SOCKET_COMMANDS"]


def _add_out(p: argparse.ArgumentParser) -> None:
    """``--out``: the socket CSV written, its distance file beside it."""
    p.add_argument(
        "--out",
        required=True,
        type=arg.with_side_files(arg.output_path, distances_path),
        help="socket CSV to write (and <stem>_distances.csv beside it)",
    )


def _add_simulate_sockets(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate-sockets", help="simulate a ball on the tool seated in sockets"
    )
    arg.add_robot_option(p, "the true robot (its tool point is the ball's centre)")
    _add_out(p)
    p.add_argument(
        "--placements", type=arg.count, default=4, help="plate placements (2 sockets)"
    )
    p.add_argument(
        "--per-socket", type=arg.count, default=25, help="configurations per socket"
    )
    p.add_argument(
        "--noise",
        type=arg.non_negative,
        default=2e-5,
        help="seating noise, std in m per coordinate",
    )
    p.add_argument(
        "--distance",
        type=arg.positive,
        default=MUKCA_SOCKET_DISTANCE,
        help="m between the two sockets of a plate (default %(default)s)",
    )
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="random seed")
    arg.add_scene_options(p, "every configuration")
    p.set_defaults(handler=_simulate_sockets)


def _simulate_sockets(args: argparse.Namespace) -> None:
    from rmdrake.calibration.sockets.data import (
        distances_path,
        write_socket_measurements,
    )
    from rmdrake.calibration.sockets.simulate import simulate_sockets

    model = arg.robot_of(args)
    options = pick(args, "placements", "per_socket", "noise", "distance", "seed")
    options.update(arg.clearance_options(args, model))
    sim = simulate_sockets(model, **options)
    path = write_socket_measurements(args.out, sim.data)
    print(f"robot '{model.name}' (seed {args.seed}): {sim.summary()}")
    print(f"wrote {path} and {distances_path(path)}")


def _placements_folder(text: str) -> Path:
    """DIR of ``import-sockets``: a folder read by
    :func:`~rmdrake.calibration.sockets.data.read_mukca_sockets` (checked
    when the command runs, not at parse time: parsing touches no file)."""
    return Path(text)


def _add_import_sockets(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "import-sockets", help="MUKCa's recordings (hole_0/1.csv) -> socket CSV"
    )
    p.add_argument(
        "folder",
        metavar="DIR",
        type=_placements_folder,
        help="one sub-folder per plate placement, each with hole_0.csv and "
        "hole_1.csv (joint angles in rad, one configuration per row)",
    )
    _add_out(p)
    p.add_argument(
        "--distance",
        type=arg.positive,
        default=MUKCA_SOCKET_DISTANCE,
        help="m between the two holes of the plate (default %(default)s)",
    )
    p.set_defaults(handler=_import_sockets)


def _import_sockets(args: argparse.Namespace) -> None:
    from rmdrake.calibration.sockets.data import (
        distances_path,
        mukca_hole_files,
        read_mukca_sockets,
        write_socket_measurements,
    )

    if not args.folder.is_dir():
        raise ValueError(f"argument DIR: {args.folder}: not a folder")
    hole = arg.input_path("measurements")
    holes = [
        hole(str(h)) for pair in mukca_hole_files(args.folder).values() for h in pair
    ]
    # every hole a regular file, and neither output over one, before any read
    arg.check_paths(argparse.Namespace(DIR=holes, out=args.out))
    data, names = read_mukca_sockets(args.folder, distance=args.distance)
    counts = np.bincount(data.socket)
    for p, name in enumerate(names):
        a, b = 2 * p, 2 * p + 1
        print(
            f"placement {name}: sockets {a} ({counts[a]} rows), {b} ({counts[b]} rows)"
        )
    path = write_socket_measurements(args.out, data)
    print(
        f"{data.n_rows} configurations of {data.n_joints} joints in "
        f"{len(names)} placements, sockets {args.distance:g} m apart"
    )
    print(f"wrote {path} and {distances_path(path)}")


SOCKET_COMMANDS = (_add_import_sockets, _add_simulate_sockets)
