"""``rmdrake`` kinematic-calibration commands: simulate plate readings or
tracker points, calibrate from either (argument parsing and printing only; see
:mod:`rmdrake.cli`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from rmdrake.calibration.config import (
    CALIBRATION_METHODS,
    DEFAULT_DISTANCE_NOISE,
    MAX_DISTANCE_NOISE,
    CalibrationConfig,
)
from rmdrake.cli import options as arg
from rmdrake.cli.options import pick
from rmdrake.model.loading import load_robot

if TYPE_CHECKING:
    from rmdrake.calibration.kind import MeasurementKind


def _add_simulate_plates(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate-plates", help="simulate range-finder plate readings")
    p.add_argument("--robot", required=True, type=arg.robot_path, help="the true robot")
    p.add_argument(
        "--out", required=True, type=arg.output_path, help="measurement CSV to write"
    )
    p.add_argument("--plates", type=arg.count, default=5, help="plate locations")
    p.add_argument("--per-plate", type=arg.count, default=12, help="readings per plate")
    p.add_argument("--noise", type=arg.non_negative, default=2e-6, help="noise std, m")
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="random seed")
    p.add_argument(
        "--selection",
        choices=("d-optimal", "first"),
        default="d-optimal",
        help="readings kept per plate: the D-optimal ones of a larger pool, or "
        "the first valid ones",
    )
    p.add_argument(
        "--payload",
        type=_payloads,
        help="kg at the tool, M[,M2,...]: readings split over these payloads "
        "(an elastic robot deflects under each); writes the payload column",
    )
    arg.add_scene_options(p, "every reading's pose")
    p.set_defaults(handler=_simulate_plates)


def _payloads(text: str) -> list[float]:
    """``M[,M2,...]``: payload masses in kg, each >= 0."""
    return [arg.non_negative(v) for v in text.split(",")]


def _simulate_plates(args: argparse.Namespace) -> None:
    from rmdrake.calibration.plates.data import write_plane_measurements
    from rmdrake.calibration.plates.simulate import simulate_plates

    model = load_robot(args.robot)
    options = pick(args, "plates", "per_plate", "noise", "seed", "selection")
    options.update(pick(args, "payload"))
    options.update(arg.clearance_options(args, model))
    sim = simulate_plates(model, **options)
    path = write_plane_measurements(args.out, sim.data)
    print(f"robot '{model.name}' (seed {args.seed}): {sim.summary()}")
    print(f"wrote {path}")


def _add_simulate_points(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate-points", help="simulate tracker points on the tool")
    arg.add_robot_option(p, "the true robot")
    p.add_argument(
        "--out",
        required=True,
        type=arg.output_path,
        help="point measurement CSV to write",
    )
    p.add_argument("--poses", type=arg.count, default=50, help="robot poses")
    p.add_argument("--markers", type=arg.count, default=3, help="markers on the tool")
    p.add_argument("--noise", type=arg.non_negative, default=2e-5, help="std, m")
    p.add_argument("--seed", type=arg.non_negative_int, default=0, help="random seed")
    p.add_argument(
        "--payload",
        type=_payloads,
        help="kg at the tool, M[,M2,...]: poses split over these payloads "
        "(an elastic robot deflects under each); writes the payload column",
    )
    arg.add_scene_options(p, "every pose")
    p.set_defaults(handler=_simulate_points)


def _simulate_points(args: argparse.Namespace) -> None:
    from rmdrake.calibration.points.data import write_point_measurements
    from rmdrake.calibration.points.simulate import simulate_points

    model = arg.robot_of(args)
    options = pick(args, "poses", "markers", "noise", "seed", "payload")
    options.update(arg.clearance_options(args, model))
    sim = simulate_points(model, **options)
    path = write_point_measurements(args.out, sim.data)
    print(f"robot '{model.name}' (seed {args.seed}): {sim.summary()}")
    print(f"wrote {path}")


def _add_calibrate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="kinematic calibration -> robot YAML")
    arg.add_robot_option(p, "nominal robot")
    p.add_argument(
        "--measurements",
        required=True,
        type=arg.with_side_files(arg.input_path("measurements"), _distance_file),
        help="plane, point or socket CSV (a socket CSV's known distances are "
        "read from <stem>_distances.csv beside it)",
    )
    p.add_argument(
        "--out",
        required=True,
        type=arg.output_path,
        help="calibrated robot YAML to write",
    )
    p.add_argument(
        "--params",
        help="auto (default: chosen by cross-validation over plates, poses or "
        "placements; plates with method de: paper) | paper (plates) | base | "
        "offsets (points, sockets) | full | names",
    )
    p.add_argument(
        "--method",
        choices=CALIBRATION_METHODS,
        help="default: de+lm for plates; points: lm only",
    )
    p.add_argument(
        "--seed", type=arg.non_negative_int, default=0, help="DE's seed; CV split's"
    )
    cv = p.add_mutually_exclusive_group()
    cv.add_argument(
        "--folds",
        type=_folds,
        help="points: K-fold CV over poses (K in 2..20, at most the poses); "
        "sockets: 'placements' (leave one placement out)",
    )
    cv.add_argument(
        "--holdout", type=arg.unit_interval, help="points: fraction of poses held out"
    )
    losses = ("linear", "huber", "soft_l1", "cauchy", "arctan")
    p.add_argument("--loss", choices=losses, default="linear", help="LM loss")
    p.add_argument(
        "--f-scale", type=arg.positive, default=1e-5, help="robust loss scale, m"
    )
    p.add_argument(
        "--maxiter", type=arg.count, help="DE generations (default: the method's)"
    )
    p.add_argument("--length-bound", type=arg.positive, default=3e-3, help="DE: +-m")
    p.add_argument("--angle-bound", type=arg.positive, default=3e-3, help="DE: +-rad")
    p.add_argument("--no-progress", action="store_true", help="hide the DE progress")
    p.add_argument(
        "--compliance",
        action="store_true",
        help="also fit every joint's compliance c<j> (elastostatic; readings "
        "with and without a payload); writes compliance: {stiffness}",
    )
    p.add_argument(
        "--noise",
        type=_declared_noise,
        help="the readings' standard deviation, m (the instrument's figure), > 0 "
        "and at most 0.02: the residual is judged against it (leave it out to "
        "estimate it from the fit, which cannot tell a model that misses errors "
        "from a noisy instrument; sockets: at most 0.001)",
    )
    p.add_argument(
        "--socket-distance",
        action="append",
        default=[],
        type=_socket_distance,
        metavar="A,B,METRES",
        help="sockets: a known distance between sockets A and B, m (repeatable; "
        "adds to or replaces the distance file's)",
    )
    p.add_argument(
        "--distance-noise",
        type=arg.positive,
        help="sockets: std of a known distance, m, at most "
        f"{MAX_DISTANCE_NOISE:g} (default {DEFAULT_DISTANCE_NOISE:g})",
    )
    p.add_argument(
        "--drop-outliers",
        action="store_true",
        help="sockets: drop configurations far from their socket and refit "
        "instead of refusing",
    )
    p.add_argument(
        "--angle-noise",
        type=arg.non_negative,
        metavar="RAD",
        help="poses: the readings' angle std per axis, rad (default: estimated "
        "from the fit, as --noise)",
    )
    p.add_argument("--force", action="store_true", help=arg.FORCE_HELP)
    p.set_defaults(handler=_calibrate)


def _declared_noise(text: str) -> float:
    """``--noise``: a standard deviation in m, > 0 (0 would mean no noise at
    all, not "estimate it") and at most
    :data:`~rmdrake.calibration.sanity.POINT_MAX_NOISE` (the largest any kind
    of reading scatters; more is a figure in mm)."""
    from rmdrake.calibration.sanity import POINT_MAX_NOISE

    value = arg.non_negative(text)
    if value == 0:
        raise argparse.ArgumentTypeError(
            "expected a noise > 0 m, found 0; leave --noise out to estimate it "
            "from the fit"
        )
    if value > POINT_MAX_NOISE:
        raise argparse.ArgumentTypeError(
            f"{text} m is over the {POINT_MAX_NOISE * 1e3:g} mm any instrument's "
            "readings scatter: mm? convert to m"
        )
    return value


def _distance_file(path: str) -> Path:
    """The distance file a socket CSV has beside it, ``<stem>_distances.csv``
    (a side input of ``--measurements``, checked by
    :func:`~rmdrake.cli.options.check_paths` whatever the file's kind)."""
    from rmdrake.calibration.sockets.data import distances_path

    return distances_path(path)


def _socket_distance(text: str) -> tuple[int, int, float]:
    """``--socket-distance A,B,METRES``: two socket ids and a distance > 0."""
    from rmdrake.calibration.sockets.data import parse_socket_distance

    try:
        return parse_socket_distance(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _folds(text: str) -> int | str:
    """``--folds``: an integer in 2..:data:`~rmdrake.calibration.selection.
    MAX_FOLDS` (points, poses; at most their count, checked on the data) or
    ``placements`` (sockets)."""
    from rmdrake.calibration.selection import MAX_FOLDS

    if text == "placements":
        return text
    value = arg.count(text)
    if not 2 <= value <= MAX_FOLDS:
        raise argparse.ArgumentTypeError(
            f"expected 2..{MAX_FOLDS} folds (each refits the calibration; the cap "
            f"is {MAX_FOLDS}) or 'placements', found {text}; give 5 or 10"
        )
    return value


def _calibrate(args: argparse.Namespace) -> None:
    from rmdrake.calibration.registry import kind_of_file
    from rmdrake.pipelines.calibrate import calibrate_file

    robot = arg.robot_of(args)
    kind = kind_of_file(args.measurements)  # the header, read once
    path = calibrate_file(
        robot,
        args.measurements,
        args.out,
        config=calibration_config(args, kind),
        distances=list(args.socket_distance),
        kind=kind,
    )
    print(f"wrote {path}")


def calibration_config(
    args: argparse.Namespace, kind: MeasurementKind
) -> CalibrationConfig:
    """The :class:`~rmdrake.calibration.config.CalibrationConfig` of
    ``rmdrake calibrate``'s parsed options for measurements of ``kind``
    (:func:`rmdrake.calibration.registry.kind_of_file` of the file).

    Common: ``--params``, ``--compliance``, ``--loss``, ``--f-scale`` (m),
    ``--noise`` (m; None: estimated) and ``--force``; the method's own
    options are the kind's
    (:meth:`~rmdrake.calibration.kind.MeasurementKind.calibrator_options`:
    points ``--seed``, ``--folds``, ``--holdout``; plates ``--method`` and the
    DE's options; sockets ``--distance-noise``, ``--drop-outliers``,
    ``--folds placements``).

    Example: ``calibration_config(args, KINDS["points"]).calibrator`` is a
    :class:`~rmdrake.calibration.config.PointLMConfig`.

    Raises:
      ValueError: an option of another kind of measurements, or one the kind
        refuses (one line).
    """
    from rmdrake.calibration.registry import KINDS

    for other in KINDS.values():
        if other is not kind:
            other.refuse_foreign(args, args.measurements, kind.noun)
    return CalibrationConfig(
        **pick(args, "params", "compliance", "loss", "f_scale", "noise", "force"),
        calibrator=kind.calibrator_options(args, args.measurements),
    )


CALIBRATION_COMMANDS = (_add_simulate_plates, _add_simulate_points, _add_calibrate)
