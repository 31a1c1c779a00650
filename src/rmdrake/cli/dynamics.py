"""``rmdrake identify-gains``: the drive gains (N m/A or N/A, gear ratio
included) of a robot whose drives log motor currents, from a log without and a
log with a known payload (argument parsing and printing only; the method is
:mod:`rmdrake.dynamics.drive_gains`; see :mod:`rmdrake.cli`); ``rmdrake
identify-payload``: a tool payload's inertial parameters from a log of the
identified arm carrying it (:mod:`rmdrake.pipelines.identify_payload`)."""

from __future__ import annotations

import argparse
import dataclasses

from rmdrake.cli import options as arg

__all__ = ["DYNAMICS_COMMANDS"]


def _add_identify_gains(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify-gains", help="drive gains from current logs without/with a payload"
    )
    arg.add_robot_option(p, "the robot (kinematics)")
    log_help = "currents log (i1..in): --log NO_LOAD --log LOADED (in this order)"
    inertia_help = "Ixx,Iyy,Izz,Ixy,Ixz,Iyz about the centre of mass, tool axes, "
    inertia_help += "kg m^2 (default 0: a point mass)"
    p.add_argument(
        "--log",
        required=True,
        action="append",
        type=arg.input_path("log"),
        help=log_help,
    )
    p.add_argument("--payload-mass", required=True, type=arg.positive, help="kg")
    p.add_argument(
        "--payload-com",
        type=arg.vector(3, "m, tool frame"),
        default=[0.0, 0.0, 0.0],
        help="x,y,z in the tool frame, m",
    )
    p.add_argument(
        "--payload-inertia",
        type=arg.vector(6, "kg m^2"),
        default=[0.0] * 6,
        help=inertia_help,
    )
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="robot YAML with drive gains"
    )
    p.add_argument("--force", action="store_true", help=arg.FORCE_HELP)
    arg.add_log_options(p)
    p.set_defaults(handler=_identify_gains)


def _identify_gains(args: argparse.Namespace) -> None:
    from rmdrake.dynamics.drive_gains import (
        check_drive_gains,
        identify_drive_gains_from_logs,
    )
    from rmdrake.errors import ImplausibleResultError
    from rmdrake.model.robot import Payload, require_dynamics

    if len(args.log) != 2:
        raise ValueError(
            f"--log: expected two logs (without, then with the payload), found "
            f"{len(args.log)}"
        )
    options = arg.log_options(args)
    payload = Payload(args.payload_mass, args.payload_com, args.payload_inertia)
    model = arg.robot_of(args)
    require_dynamics(
        model,
        "rmdrake identify-gains",
        dynamics=False,
        remedy="they scale the check of the torques the gains give",
    )
    result = identify_drive_gains_from_logs(
        model, [args.log[0]], [args.log[1]], payload, **options
    )
    gains = ", ".join(f"{g:.6g}" for g in result.gains)
    rms = ", ".join(f"{v:.3g}" for v in result.residual_rms)
    print(f"robot '{model.name}': drive gains [N m/A or N/A]: {gains}")
    print(f"residual RMS per joint [N m or N]: {rms}; condition {result.condition:.3g}")
    old = getattr(model, "drive_gain", None)
    if old is not None:
        change = ", ".join(f"{v:+.2%}" for v in result.gains / old - 1)
        print(f"change from the robot's gains: {change}")
    reasons = check_drive_gains(result, model)
    if reasons and not args.force:
        raise ImplausibleResultError(reasons, result)
    for reason in reasons:
        print(f"warning: implausible result written (forced): {reason}")
    out = dataclasses.replace(model, drive_gain=result.gains).save(args.out)
    print(f"wrote {out}")


def _add_identify_payload(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify-payload", help="a tool payload's mass, CoM, inertia from a log"
    )
    arg.add_robot_option(p, "the identified robot (with dynamics)")
    p.add_argument("--log", required=True, action="append",
                   type=arg.input_path("log"), help="joint log of "
                   "the arm carrying the payload, CSV or NPZ")  # fmt: skip
    p.add_argument("--log-unloaded", type=arg.input_path("log"), help="joint log "
                   "of the same trajectory without the payload (cancels the arm's "
                   "model error)")  # fmt: skip
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="robot YAML with its payload"
    )
    p.add_argument("--force", action="store_true", help=arg.FORCE_HELP)
    arg.add_log_options(p)
    p.set_defaults(handler=_identify_payload)


def _identify_payload(args: argparse.Namespace) -> None:
    from rmdrake.model.robot import require_dynamics
    from rmdrake.pipelines.identify_payload import identify_payload_file

    model = arg.robot_of(args)
    require_dynamics(
        model,
        "rmdrake identify-payload",
        remedy="identify the arm (rmdrake identify, a robot with effort limits) "
        "first, then its payload",
    )
    out = identify_payload_file(
        model,
        args.log,
        args.out,
        unloaded=args.log_unloaded,
        force=args.force,
        **arg.log_options(args),
    )
    print(f"wrote {out}")


DYNAMICS_COMMANDS = (_add_identify_gains, _add_identify_payload)
