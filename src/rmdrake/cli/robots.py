"""``rmdrake`` robot commands: show a robot model, import one from a URDF,
export one as a URDF (argument parsing and printing only; see
:mod:`rmdrake.cli`)."""

from __future__ import annotations

import argparse

from rmdrake.cli import options as arg
from rmdrake.cli.perturb import PERTURB_COMMANDS


def _add_show(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("show", help="print a robot model; save a Meshcat HTML of it")
    arg.add_robot_option(p, "the robot")
    p.add_argument(
        "--html", type=arg.output_path, help="write a self-contained Meshcat HTML here"
    )
    p.add_argument("--port", type=arg.port, help="Meshcat port, localhost")
    p.add_argument(
        "--scene",
        type=arg.input_path("cell"),
        help="draw this robot cell (YAML or shipped name)",
    )
    p.set_defaults(handler=_show)


def _show(args: argparse.Namespace) -> None:
    from rmdrake.pipelines.show import robot_summary, save_robot_html

    model = arg.robot_of(args)
    print(robot_summary(model))
    if model.base_frame is not None:
        bf = model.base_frame
        print(
            f"base frame B in link '{bf.link}': xyz {bf.xyz.tolist()} m, rpy "
            f"{bf.rpy.tolist()} rad (targets and gravity are in B)"
        )
    cell = None
    if args.scene:
        from rmdrake.model.scene import load_cell

        cell = load_cell(args.scene)
        print(f"cell '{cell.name}': {len(cell.shapes())} shapes")
    if args.html:
        path, count = save_robot_html(model, args.html, port=args.port, cell=cell)
        print(f"wrote {path} ({count} poses, open it in a browser)")


def _add_import_urdf(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("import-urdf", help="a URDF's serial chain -> robot YAML")
    p.add_argument("urdf", metavar="URDF", type=arg.robot_path, help="the URDF file")
    p.add_argument("--base", help="the chain's base link (omit for a single chain)")
    p.add_argument("--tip", help="the chain's tip link, the tool (idem)")
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="robot YAML to write"
    )
    p.add_argument("--name", help="the robot's name (default: the URDF's)")
    p.add_argument(
        "--exclude",
        action="append",
        default=[],
        metavar="LINK",
        help="leave out this link and every link below it, e.g. a hand beyond "
        "the tip that is not mounted (repeatable; default: bodies beyond the tip "
        "are lumped into the last link)",
    )
    p.set_defaults(handler=_import_urdf)


def _import_urdf(args: argparse.Namespace) -> None:
    from rmdrake.model.urdf.importer import robot_from_urdf

    model = robot_from_urdf(
        args.urdf, base=args.base, tip=args.tip, name=args.name, exclude=args.exclude
    )
    kinds = ", ".join("P" if s else "R" for s in model.sigma)
    print(f"robot '{model.name}': {model.n_joints} joints ({kinds}; R revolute, "
          "P prismatic)")  # fmt: skip
    if model.base_frame is not None:
        print(f"base frame B: {model.base_frame.xyz.tolist()} m in the base link")
    masses = "none (no dynamics)"
    if model.dynamics is not None:
        masses = ", ".join(f"{m:.4g}" for m in model.dynamics[:, 9])
    print(f"link masses (kg): {masses}")
    if not model.has_effort_limits:
        print("effort limits: none")
    print(f"wrote {model.save(args.out)}")


def _add_export_urdf(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export-urdf", help="a robot model -> URDF (Drake, Pinocchio)")
    arg.add_robot_option(p, "the robot")
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="URDF file to write"
    )
    p.set_defaults(handler=_export_urdf)


def _export_urdf(args: argparse.Namespace) -> None:
    from rmdrake.io.atomic import atomic_write_text
    from rmdrake.model.urdf.export import robot_to_urdf

    model = arg.robot_of(args)
    path = atomic_write_text(args.out, robot_to_urdf(model))
    print(f"robot '{model.name}': {model.n_joints} joints, links base, link1.."
          f"link{model.n_joints}, tool")  # fmt: skip
    print(f"wrote {path}")


ROBOT_COMMANDS = (_add_show, _add_import_urdf, _add_export_urdf, *PERTURB_COMMANDS)
