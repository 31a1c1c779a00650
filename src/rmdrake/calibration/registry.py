"""The measurement kinds by name: the one module that imports every kind
(:class:`~rmdrake.calibration.kind.MeasurementKind`), so that the pipeline,
the planner and the CLI look a kind up instead of branching on it. No module
at the root of :mod:`rmdrake.calibration` imports it.

Two vocabularies name a kind: the plural ``name`` (``plates``, ``points``,
``sockets``; ``rmdrake plan``'s and the registry's key) and the singular
``noun`` of the file and its messages (``plane``, ``point``, ``socket``).
:func:`kind_named` accepts both.

Example::

    kind = kind_of_file("points.csv")  # the header, read once
    kind.name  # "points"
    data = kind.read("points.csv", 6)
"""

from __future__ import annotations

import os
from pathlib import Path

from rmdrake.calibration.kind import MeasurementKind, read_header
from rmdrake.calibration.plates.kind import PlateKind
from rmdrake.calibration.points.kind import PointKind
from rmdrake.calibration.poses.kind import PoseKind
from rmdrake.calibration.sockets.kind import SocketKind

__all__ = ["KINDS", "kind_named", "kind_of_file", "measurement_kind"]

KINDS: dict[str, MeasurementKind] = {
    k.name: k for k in (PlateKind(), PointKind(), SocketKind(), PoseKind())
}
"""Every measurement kind by its ``name``, in the order of the messages."""


def kind_named(name: str) -> MeasurementKind:
    """The kind of ``name`` or ``noun`` (``plates`` or ``plane``, ...).

    Raises:
      ValueError: an unknown name (one line listing the known ones).

    Example:

    >>> from rmdrake.calibration import kind_named
    >>> kind_named("points").name
    'points'
    """
    for kind in KINDS.values():
        if name in (kind.name, kind.noun):
            return kind
    raise ValueError(
        f"unknown measurement kind '{name}': expected one of {', '.join(KINDS)}"
    )


def kind_of_file(path: str | os.PathLike) -> MeasurementKind:
    """The kind of a measurement CSV, from its header (read once).

    Raises:
      ValueError: a header no kind claims (one line naming every kind's
        header), or an unreadable file.

    Example:

    >>> from rmdrake import load_robot, write_point_measurements
    >>> from rmdrake.calibration import kind_of_file, simulate_points
    >>> data = simulate_points(load_robot("rv3sb"), poses=6, seed=0).data
    >>> kind_of_file(write_point_measurements("points.csv", data)).name
    'points'
    """
    header = read_header(path)
    for kind in KINDS.values():
        if kind.sniff(header):
            return kind
    *others, last = [f"{k.noun} measurements ({k.header})" for k in KINDS.values()]
    raise ValueError(
        f"{Path(path)}: header {','.join(header)!r} is neither "
        f"{', '.join(others)} nor {last}"
    )


def measurement_kind(path: str | os.PathLike) -> str:
    """``plane``, ``point`` or ``socket``: the ``noun`` of a measurement
    CSV's kind (:func:`kind_of_file`).

    Raises:
      ValueError: as :func:`kind_of_file`.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import measurement_kind, simulate_sockets
    >>> from rmdrake.calibration import write_socket_measurements
    >>> data = simulate_sockets(load_robot("rv3sb"), placements=2, seed=0).data
    >>> measurement_kind(write_socket_measurements("sockets.csv", data))
    'socket'
    """
    return kind_of_file(path).noun
