"""What a kind of calibration measurement is: the one interface that the
plates (range finder on plane plates), the points (tracker or motion-capture
points on the tool) and the sockets (a ball seated in fixed sockets) implement,
so that ``rmdrake calibrate``, :func:`rmdrake.pipelines.calibrate.
calibrate_file` and ``rmdrake plan`` hold no branch on the kind.

A kind is an object that satisfies :class:`MeasurementKind`; the registry
:data:`rmdrake.calibration.registry.KINDS` maps its ``name`` to it, and
:func:`rmdrake.calibration.registry.kind_of_file` sniffs a file's header once
and returns its kind. This module is shared by every kind and imports none of
them: a kind imports it, never the reverse.

What a new kind provides (all lengths in m, angles in rad, joint positions in
the model's units, frames as in :mod:`rmdrake.kinematics.forward`):

* ``name`` (the registry key, plural: ``plates``), ``noun`` (the word of the
  messages and of the file's kind, singular: ``plane``), ``header`` (the
  header as messages show it: ``plane,q1..qn,distance``) and
  ``sniff(header)``: True when a CSV's first line (split at commas, stripped)
  is this kind's;
* ``read(path, n_joints, distances=())`` and ``write(path, data)`` of its
  measurement file (``distances``: known socket distances, for the kinds
  that take them; any other kind refuses a non-empty tuple, one line);
* ``calibrator(config, model, progress=False)``: its estimator (an object
  with ``fit(data)`` returning itself, then ``model_``, ``sanity_``, ``names_``,
  ``result_``, ``summary()`` and ``params``; the shared LM driver is
  :func:`rmdrake.calibration.lm.solve_lm`) from a
  :class:`~rmdrake.calibration.config.CalibrationConfig`; another kind's
  method is refused with a one-line ValueError;
* ``calibrator_options(options, path)``: the ``CalibratorConfig`` of
  ``rmdrake calibrate``'s parsed options (an ``argparse.Namespace``), its
  refusals of other kinds' options one line each, and
  ``refuse_foreign(options, path, noun)``: a one-line ValueError when an
  option only this kind takes is given for ``noun`` measurements;
* ``describe(model, data, path)``: the one line ``rmdrake calibrate`` prints
  of the data it read;
* ``cross_validate(config, model, data, est)``: a :class:`CrossValidationReport`
  (the record and the lines printed) when the config asks for one, else None;

Example, a fourth kind fitted in beside the others (its modules under
``calibration/poses/``, registered in :mod:`rmdrake.calibration.registry`)::

    class PoseKind:
        name = "poses"
        noun = "pose"
        header = "pose,qx,qy,qz,qw,x,y,z,q1..qn"

        def sniff(self, header: list[str]) -> bool:
            return header[:2] == ["pose", "qx"]

        def read(self, path, n_joints=None, distances=()):
            refuse_distances(self, path, distances)
            from rmdrake.calibration.poses.data import read_pose_measurements
            return read_pose_measurements(path, n_joints)
        ...

    KINDS = {k.name: k for k in (PlateKind(), PointKind(), SocketKind(),
                                 PoseKind())}
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

__all__ = [
    "CrossValidationReport",
    "MeasurementKind",
    "read_header",
    "refuse_distances",
]


@dataclasses.dataclass(frozen=True)
class CrossValidationReport:
    """A kind's cross-validation of a whole calibration, as
    ``rmdrake calibrate`` reports it.

    Attributes:
      record: the calibration record's ``cross_validation`` entry (plain
        data; errors in m).
      lines: the lines printed, in order.
    """

    record: dict[str, Any]
    lines: tuple[str, ...]


@runtime_checkable
class MeasurementKind(Protocol):
    """One kind of calibration measurement (see the module docstring for
    what each member does, and an example)."""

    name: str
    noun: str
    header: str

    def sniff(self, header: list[str]) -> bool:
        """True when a CSV header (its first line's cells) is this kind's."""
        ...

    def read(
        self,
        path: str | os.PathLike,
        n_joints: int | None = None,
        distances: Sequence[tuple[int, int, float]] = (),
    ) -> Any:
        """The measurements of a file of this kind."""
        ...

    def write(self, path: str | os.PathLike, data: Any) -> Path:
        """Writes measurements of this kind; returns the path."""
        ...

    def calibrator(self, config: Any, model: Any, progress: bool = False) -> Any:
        """The unfitted estimator of ``config`` for ``model``."""
        ...

    def refuse_foreign(self, options: Any, path: str | os.PathLike, noun: str) -> None:
        """Refuses this kind's own options given for another kind's file."""
        ...

    def calibrator_options(self, options: Any, path: str | os.PathLike) -> Any:
        """The ``CalibratorConfig`` of ``rmdrake calibrate``'s options."""
        ...

    def describe(self, model: Any, data: Any, path: str | os.PathLike) -> str:
        """One line naming the robot and counting the data read."""
        ...

    def cross_validate(
        self, config: Any, model: Any, data: Any, est: Any
    ) -> CrossValidationReport | None:
        """The requested cross-validation of a fitted ``est``, else None."""
        ...


def read_header(path: str | os.PathLike) -> list[str]:
    """The cells of a CSV's first line, stripped (what a kind sniffs).

    Example: ``read_header("p.csv")`` -> ``["pose", "marker", "q1", ...]``.

    Raises:
      ValueError: an unreadable or non-UTF-8 file (one line).
    """
    from rmdrake.io.csv import CSV_ENCODING

    path = Path(path)
    try:
        with path.open(encoding=CSV_ENCODING) as f:
            line = f.readline()
    except OSError as e:
        raise ValueError(f"cannot read measurements '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    return [c.strip() for c in line.strip().split(",")]


def refuse_distances(
    kind: MeasurementKind,
    path: str | os.PathLike,
    distances: Sequence[tuple[int, int, float]],
) -> None:
    """Refuses known socket distances given with measurements of a kind that
    has no sockets.

    Raises:
      ValueError: ``distances`` not empty (one line naming the kind).
    """
    if distances:
        raise ValueError(
            f"{path}: --socket-distance is for socket measurements; "
            f"these are {kind.noun} measurements"
        )
