"""``rmdrake`` robot commands: show a robot model (argument parsing and printing
only; see :mod:`rmdrake.cli`)."""

from __future__ import annotations

import argparse

from rmdrake import cli_types as arg


def _add_show(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("show", help="print a robot model; save a Meshcat HTML of it")
    arg.add_robot_option(p, "the robot")
    p.add_argument("--html", help="write a self-contained Meshcat HTML here")
    p.add_argument("--port", type=arg.port, help="Meshcat port, localhost")
    p.set_defaults(handler=_show)


def _show(args: argparse.Namespace) -> None:
    from rmdrake.studies.show import robot_summary, save_robot_html

    model = arg.robot_of(args)
    print(robot_summary(model))
    if args.html:
        path, count = save_robot_html(model, args.html, port=args.port)
        print(f"wrote {path} ({count} poses, open it in a browser)")


ROBOT_COMMANDS = (_add_show,)
