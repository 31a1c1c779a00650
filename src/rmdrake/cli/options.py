"""The ``rmdrake`` command's option types, and its rules on file paths.

Each type turns one option's text into a value or raises
``argparse.ArgumentTypeError``, which argparse prints as one line
``rmdrake: error: argument --x: ...`` (exit code 2) before any file is read or
any value reaches Drake. Rules common to all: NaN and infinities are refused;
integers are written as integers (``3``, not ``3.0`` or ``1e3``).

Every option that names a file is declared with a path type
(:func:`input_path`, :func:`robot_path`, :data:`output_path`,
:data:`output_folder`): its value is a :class:`PathArg` that carries its role
and kind, so :func:`check_paths` finds every path of every command in the
parsed arguments themselves, with no list of option names to keep up to date.
Before a command runs it refuses:

- an input that exists but is not a regular file (a folder, a FIFO,
  ``/dev/zero``, ``/dev/urandom``, a socket), or is larger than its kind's cap
  (:data:`INPUT_CAPS`: a robot YAML or URDF, a trajectory, a scenario or a
  cell 16 MiB; measurements and targets 256 MiB; a joint log CSV or NPZ
  1 GiB); no command reads stdin, so ``-`` is a (missing) file name;
- an output path that is one of the command's input files (compared resolved,
  so symbolic links and relative spellings count, and by identity, so hard
  links do too);
- the same for the side files a path implies beside it (:func:`with_side_files`:
  a socket CSV's ``<stem>_distances.csv``, read or written with it), so a
  side output never replaces an input and a side input is never a FIFO;
- an output file that could not be written
  (:func:`rmdrake.io.atomic.check_writable`: a folder, ``dir/``, a symbolic
  link loop, a write-protected file), so a long computation never ends in a
  lost result.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import stat
from collections.abc import Callable
from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rmdrake.io.atomic import check_writable
from rmdrake.io.paths import not_a_regular_file

if TYPE_CHECKING:  # imported where used: --help loads no numerics
    from rmdrake.execution import Execution, TaskRunner
    from rmdrake.model.robot import RobotModel

__all__ = [
    "FORCE_HELP",
    "INPUT_CAPS",
    "FOLDER_COMMANDS",
    "PathArg",
    "check_paths",
    "side_files",
    "with_side_files",
    "input_path",
    "output_folder",
    "output_path",
    "robot_path",
    "add_log_options",
    "add_robot_option",
    "AUTO_WORKERS",
    "add_execution_options",
    "connected",
    "execution_of",
    "scheduler_address",
    "workers",
    "count",
    "non_negative",
    "non_negative_int",
    "log_options",
    "per_joint",
    "port",
    "pick",
    "positive",
    "robot_of",
    "unit_interval",
    "vector",
]

_MIB = 2**20
#: The largest input file of each kind, bytes (:func:`check_paths`): far above
#: any real one (the RV-3SB YAML is 6 kB, a 10 min log at 1 kHz of 7 joints
#: 100 MB), far below what would exhaust memory once parsed.
INPUT_CAPS = {
    "robot": 16 * _MIB,
    "trajectory": 16 * _MIB,
    "scenario": 16 * _MIB,
    "cell": 16 * _MIB,
    "measurements": 256 * _MIB,
    "targets": 256 * _MIB,
    "log": 1024 * _MIB,
}
#: Commands whose --out is a folder of results, not a file.
FOLDER_COMMANDS = ("run", "demo", "fleet")


class PathArg(str):
    """An option's file name (the text as given) with its ``role``
    (``input``, ``output`` or ``folder``) and ``kind`` (a key of
    :data:`INPUT_CAPS` for an input)."""

    role: str = "input"
    kind: str = ""
    #: Functions of the path giving the files the command reads or writes
    #: beside it, by the same role and kind (:func:`with_side_files`).
    beside: tuple[Callable[[str], str | os.PathLike], ...] = ()


def with_side_files(
    path_type: Callable[[str], PathArg], *derive: Callable[[str], str | os.PathLike]
) -> Callable[[str], PathArg]:
    """``path_type`` (:func:`input_path`, :data:`output_path`) whose value also
    stands for the files ``derive(path)`` beside it, read or written by the
    command with it (a socket CSV's ``<stem>_distances.csv``):
    :func:`check_paths` checks each as it checks the path itself.

    Example: ``with_side_files(output_path, distances_path)``."""

    def parse(text: str) -> PathArg:
        value = path_type(text)
        value.beside = tuple(derive)
        return value

    parse.__name__ = getattr(path_type, "__name__", "path")
    return parse


def side_files(path: PathArg) -> list[PathArg]:
    """The side files of ``path`` (:func:`with_side_files`), each a
    :class:`PathArg` of ``path``'s role and kind; empty for none."""
    sides = []
    for derive in path.beside:
        side = PathArg(os.fspath(derive(str(path))))
        side.role, side.kind = path.role, path.kind
        sides.append(side)
    return sides


def _path_type(role: str, kind: str = "") -> Callable[[str], PathArg]:
    """An option type that tags the text as a :class:`PathArg`."""
    if role == "input" and kind not in INPUT_CAPS:
        raise ValueError(f"unknown input kind {kind!r}: expected {list(INPUT_CAPS)}")

    def parse(text: str) -> PathArg:
        value = PathArg(text)
        value.role, value.kind = role, kind
        return value

    parse.__name__ = f"{kind or role} path"
    return parse


def input_path(kind: str) -> Callable[[str], PathArg]:
    """The type of an option naming a file read, of ``kind`` (its size cap)."""
    return _path_type("input", kind)


#: A robot: a shipped name, a robot YAML or a URDF (a name is not a file).
robot_path = input_path("robot")
#: The type of an option naming a file written.
output_path = _path_type("output")
#: The type of an option naming a folder written (run, demo).
output_folder = _path_type("folder")

FORCE_HELP = (
    "write the result even if implausible; the reasons are recorded in the YAML"
)


def pick(args: argparse.Namespace, *names: str) -> dict[str, Any]:
    """The named options of ``args`` as keyword arguments."""
    return {name: getattr(args, name) for name in names}


def add_robot_option(p: argparse.ArgumentParser, help: str) -> None:
    """Adds ``--robot`` (a shipped name, a robot YAML or a URDF) and the
    ``--base``/``--tip`` links that pick the chain of a URDF."""
    p.add_argument(
        "--robot", required=True, type=robot_path, help=f"{help}: name, YAML or URDF"
    )
    p.add_argument("--base", help="URDF: the chain's base link")
    p.add_argument("--tip", help="URDF: the chain's tip link (the tool)")


def add_log_options(p: argparse.ArgumentParser) -> None:
    """Adds the options that prepare a joint log as ``identify`` does:
    ``--trim``, ``--rate``, ``--cutoff``, ``--derivative-cutoff`` and
    ``--coulomb-width`` (read back by :func:`log_options`)."""
    p.add_argument("--trim", help="START:END, s from each log's start (keep)")
    p.add_argument("--rate", type=positive, help="resample to Hz")
    p.add_argument("--cutoff", type=non_negative, help="low-pass Hz (0: none)")
    p.add_argument("--derivative-cutoff", type=positive, help="Hz, for qd and qdd")
    p.add_argument("--coulomb-width", type=non_negative, default=0.0, help="rad/s")


def log_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword options of :func:`add_log_options`'s arguments (the time
    window parsed)."""
    from rmdrake.dynamics.data import parse_time_window

    options = pick(args, "coulomb_width", "rate", "cutoff", "derivative_cutoff")
    if args.trim is not None:
        options["time_window"] = parse_time_window(args.trim)
    return options


def robot_of(args: argparse.Namespace) -> RobotModel:
    """The robot of the options :func:`add_robot_option` declared."""
    from rmdrake.model.loading import load_robot

    return load_robot(args.robot, base=args.base, tip=args.tip)


def add_scene_options(p: argparse.ArgumentParser, what: str) -> None:
    """``--scene`` (a robot cell YAML or shipped cell name) and ``--clearance``
    (m): ``what`` keeps that distance from the cell."""
    p.add_argument(
        "--scene",
        type=input_path("cell"),
        help="robot cell: YAML of boxes, cylinders, spheres, meshes and model "
        "files posed in the base frame, or a shipped cell name (rv3sb_table)",
    )
    p.add_argument(
        "--clearance",
        type=non_negative,
        default=0.05,
        help=f"m, with --scene: {what} keeps this distance from the cell "
        "(the links as capsules on their MDH segments; default %(default)s)",
    )
    p.add_argument(
        "--self-collision",
        action="store_true",
        help="with --scene: also keep the clearance between non-adjacent links "
        "(off by default: capsules on the MDH segments lie in one plane and "
        "overlap where a real arm's links sit side by side)",
    )


def clearance_options(args: argparse.Namespace, model: RobotModel) -> dict[str, Any]:
    """The keyword options ``checker`` (the
    :class:`~rmdrake.kinematics.clearance.ClearanceChecker` of ``--scene`` for
    ``model``) and ``clearance`` (m) of the designs and simulators that keep
    clear of a cell; empty without ``--scene``."""
    if not getattr(args, "scene", None):
        return {}
    from rmdrake.kinematics.clearance import ClearanceChecker
    from rmdrake.model.scene import load_cell

    checker = ClearanceChecker(
        model=model,
        cell=load_cell(args.scene),
        self_collision=getattr(args, "self_collision", False),
    )
    return {"checker": checker, "clearance": args.clearance}


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address, ``tcp://host:8786`` (or ``host:8786``):
    a scheme of another process (tcp, tls, ws, wss), a host and a port
    (:func:`rmdrake.clusters.scheduler_address`); whether a scheduler
    answers there is checked before the command writes anything."""
    from rmdrake.clusters import scheduler_address as checked

    try:
        return checked(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def workers(text: str) -> int:
    """Local worker processes: an integer from 0 (this process) up to the
    machine's bound (:func:`rmdrake.clusters.worker_bound`: 4 a core, and
    what its memory holds)."""
    from rmdrake.clusters import check_workers

    value = non_negative_int(text)
    try:
        return check_workers(value)
    except ValueError as error:
        raise argparse.ArgumentTypeError(
            str(error).removeprefix("--workers ")
        ) from None


AUTO_WORKERS = (
    "a local Dask cluster of one worker process per core, started when the "
    "first task, run here and timed, shows the rest takes over 10 s (start-up: "
    "3-5 s on 2 cores); the results are the same with any number"
)
"""``--help``'s words for the default execution (:class:`Execution` ``()``)."""


def add_execution_options(
    p: argparse.ArgumentParser, *, default: str = AUTO_WORKERS
) -> None:
    """``--workers N`` and ``--scheduler ADDRESS``: where the command's tasks run
    (read back by :func:`execution_of`); ``default`` says in the help what
    happens without either."""
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=workers,
        help=f"local Dask worker processes, at most 4 per core (0: in this "
        f"process, serially, for debugging; default: {default})",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        type=scheduler_address,
        help="an existing Dask cluster's scheduler (tcp://host:8786), its workers "
        "started with `dask worker ADDRESS` where rmdrake is installed; it must "
        "answer within 10 s, before anything is written",
    )


def execution_of(
    args: argparse.Namespace, *, default_workers: int | None = None
) -> Execution:
    """The :class:`~rmdrake.execution.Execution` of :func:`add_execution_options`'s
    arguments; ``default_workers`` when neither is given (None: a local cluster
    of one worker process per core, started when the work outweighs it)."""
    from rmdrake.execution import Execution

    if args.scheduler is not None:
        return Execution(scheduler=args.scheduler)
    workers = default_workers if args.workers is None else args.workers
    return Execution(workers=workers)


def connected(execution: Execution) -> AbstractContextManager[Execution | TaskRunner]:
    """A context that gives what to hand a study as its ``execution``: for a
    scheduler, a :class:`~rmdrake.execution.TaskRunner` connected on entry
    (a scheduler that does not answer ends the command there, before any
    file is written; the study shares the runner), closed on exit; else the
    execution itself (its local cluster starts when the work needs it)."""
    from rmdrake.execution import TaskRunner

    if execution.scheduler is None:
        return contextlib.nullcontext(execution)
    return TaskRunner(execution, echo=print)


#: Meshcat's ports: Drake refuses the privileged ones (< 1024); TCP ends at 65535.
PORTS = (1024, 65535)


def _number(text: str) -> float:
    """A finite float, else ArgumentTypeError."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, found {text}")
    return value


def _integer(text: str) -> int:
    """An integer literal, else ArgumentTypeError."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer, found {text!r}"
        ) from None


def positive(text: str) -> float:
    """A finite number > 0 (rates, times, tolerances, scales)."""
    value = _number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, found {text}")
    return value


def non_negative(text: str) -> float:
    """A finite number >= 0 (noise levels, widths; 0 where documented as off)."""
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, found {text}")
    return value


def unit_interval(text: str) -> float:
    """A number strictly between 0 and 1 (a relative accuracy)."""
    value = _number(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected 0 < value < 1, found {text}")
    return value


def count(text: str) -> int:
    """An integer >= 1 (plates, readings, harmonics, generations, a step)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, found {text}")
    return value


def non_negative_int(text: str) -> int:
    """An integer >= 0 (a random seed)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, found {text}")
    return value


def port(text: str) -> int:
    """A TCP port in 1024..65535 (Drake refuses lower ones; higher do not exist)."""
    value = _integer(text)
    if not PORTS[0] <= value <= PORTS[1]:
        raise argparse.ArgumentTypeError(
            f"expected a port in {PORTS[0]}..{PORTS[1]}, found {text}"
        )
    return value


def per_joint(text: str) -> float | list[float]:
    """``0.05`` or a comma list ``0.1,0.1,0.05,...`` (one per joint), each a
    finite number >= 0; the joint count is checked against the robot later."""
    items = text.split(",")
    try:
        [float(v) for v in items]
    except ValueError:
        raise argparse.ArgumentTypeError(
            "expected a number or a comma-separated list (one per joint) of "
            f"numbers >= 0, found {text!r}"
        ) from None
    values = [non_negative(v) for v in items]
    return values[0] if len(values) == 1 else values


def vector(size: int, what: str) -> Callable[[str], list[float]]:
    """An option type: ``size`` comma-separated finite numbers (``what`` names
    their unit and frame in the message)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            values = []
        if len(values) != size or not all(map(math.isfinite, values)):
            raise argparse.ArgumentTypeError(
                f"expected {size} comma-separated numbers ({what}), found {text!r}"
            )
        return values

    return parse


def check_paths(args: argparse.Namespace) -> None:
    """Refuses, before a command runs, what the module docstring lists: every
    :class:`PathArg` among ``args`` and its side files (:func:`side_files`) is
    checked (inputs first, then outputs).

    Raises:
      ValueError: one line naming the path and the option, e.g.
        ``--out PATH: is also the input --log; ...`` or
        ``PATH: is a FIFO, not a regular file: --log reads a file``.
    """
    given = [  # an upper-case key is a positional argument's metavar (DIR)
        (key if key.isupper() else f"--{_option(key)}", value)
        for key, v in vars(args).items()
        for value in (v if isinstance(v, list) else [v])
        if isinstance(value, PathArg) and value
    ]
    given += [
        (f"{label} (side file)", side)
        for label, value in list(given)
        for side in side_files(value)
    ]
    for label, path in given:
        if path.role == "input":
            _check_input(path, label)
    for out_label, out in given:
        if out.role == "input":
            continue
        for in_label, source in given:
            if source.role == "input" and _same(Path(out), Path(source)):
                raise ValueError(
                    f"{out_label} {out}: is also the input {in_label}; refusing "
                    "to overwrite an input, choose another output"
                )
        if out.role == "output":
            check_writable(out)


def _check_input(path: PathArg, option: str) -> None:
    """Refuses an existing input that is not a regular file or is over its
    kind's cap; a missing one is left to its reader (a robot may be a name).
    ``option``: how the message names it (``--log``)."""
    try:
        info = os.stat(path)
    except OSError:
        return
    if stat.S_ISREG(info.st_mode):
        cap = INPUT_CAPS[path.kind]
        if info.st_size > cap:
            raise ValueError(
                f"{path}: {info.st_size / _MIB:.4g} MiB is over the {cap // _MIB} "
                f"MiB cap of a {path.kind} file ({option}); give the right file "
                "or split it"
            )
        return
    why = not_a_regular_file(path)
    raise ValueError(f"{path}: {why}; {option} reads a regular file")


def _same(a: Path, b: Path) -> bool:
    """Whether two paths name one file: resolved alike, or the same inode."""
    try:
        if not b.exists() or a.resolve() == b.resolve():
            return b.exists()
        return a.exists() and os.path.samefile(a, b)
    except (OSError, RuntimeError):  # a symbolic link loop: check_writable's
        return False


def _option(key: str) -> str:
    return key.replace("_", "-")
