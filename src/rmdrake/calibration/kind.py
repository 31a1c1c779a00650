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
* for ``rmdrake plan``: ``plan_option`` (the option that picks it:
  ``plates``; each kind's is its own option of ``rmdrake plan``),
  ``plan_extra`` (its second size option: ``per_plate``), ``plan_word``
  (``plate``) and ``plan(size, extra=None)``: a :class:`PlanSizing` of that
  many locations, poses or placements (the kind's ``plan.py``: its readings,
  how a count of readings divides into it, its ``plan.yaml`` and
  ``summary.yaml`` fields, its noise span, its simulation on a true arm, its
  LM fit of the drawn parameters, the tool point it is scored on, and the
  note when it is too small).

The registry tries the kinds' ``sniff`` in its order and takes the first that
claims a header, so a kind claims its own header only
(``tests/calibration/test_kinds.py`` checks every kind against every other's
file). A kind imports the root of :mod:`rmdrake.calibration` (this module,
:mod:`~rmdrake.calibration.config`, :mod:`~rmdrake.calibration.lm`: the LM
driver and the loss check, :mod:`~rmdrake.calibration.sanity`: the bounds,
the report and the kind-free checks, :mod:`~rmdrake.calibration.
identifiability`: the column analysis, :mod:`~rmdrake.calibration.simulate`:
pose draws and the noise share, :mod:`~rmdrake.calibration.selection`,
:mod:`~rmdrake.calibration.d_optimal`, :mod:`~rmdrake.calibration.
validation`), never another kind; the root imports no kind.

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
    "PlanSizing",
    "plan_count",
    "reach_span",
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

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import KINDS, CalibrationConfig, PointLM, PointLMConfig
    >>> from rmdrake.calibration import simulate_points
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=12, seed=0).data
    >>> config = CalibrationConfig(params="offsets", calibrator=PointLMConfig(folds=3))
    >>> lm = PointLM(robot, params="offsets").fit(data)
    >>> report = KINDS["points"].cross_validate(config, robot, data, lm)
    >>> type(report).__name__, len(report.lines) > 0, "rms" in str(report.record)
    ('CrossValidationReport', True, True)
    """

    record: dict[str, Any]
    lines: tuple[str, ...]


@runtime_checkable
class MeasurementKind(Protocol):
    """One kind of calibration measurement (see the module docstring for
    what each member does, and an example).

    Example:

    >>> from rmdrake.calibration import KINDS, MeasurementKind
    >>> sorted(KINDS)
    ['plates', 'points', 'poses', 'sockets']
    >>> isinstance(KINDS["plates"], MeasurementKind)
    True
    """

    name: str
    noun: str
    header: str
    plan_option: str
    plan_extra: str
    plan_word: str

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

    def plan(self, size: int, extra: int | None = None) -> PlanSizing:
        """The plan of ``--<plan_option> size`` and ``--<plan_extra> extra``."""
        ...


@runtime_checkable
class PlanSizing(Protocol):
    """One size of a kind's calibration plan for ``rmdrake plan``: what is
    measured on each true arm, how it is simulated and fitted. Frozen;
    :meth:`sized` gives the plan of another count of readings.

    Example: ``PlatePlan(plates=5, per_plate=12).sized(120).describe()`` ->
    ``"120 readings (5 plates x 24)"``.
    """

    kind: str

    @property
    def readings(self) -> int:
        """The readings in all (plates: readings; points: poses; sockets:
        configurations)."""
        ...

    @property
    def per_reading(self) -> int:
        """Values measured per reading (points: one per marker)."""
        ...

    def sized(self, readings: int) -> PlanSizing:
        """This plan with ``readings`` in all (a one-line ValueError when
        they do not divide into it)."""
        ...

    def describe(self) -> str:
        """``60 readings (5 plates x 12)``."""
        ...

    def record(self) -> dict[str, Any]:
        """Its fixed size in ``plan.yaml`` (``{"plates": 5}``)."""
        ...

    def summary(self) -> dict[str, Any]:
        """Its size fields in ``summary.yaml``
        (``{"plates": 5, "per_plate": 12}``)."""
        ...

    def check(self, poses_from: str) -> None:
        """Refuses a pose choice the plan cannot take (one line)."""
        ...

    def noise_span(self, robot: Any) -> tuple[float, str]:
        """(m, what): the span a plausible noise std is a small share of."""
        ...

    def simulate(
        self, robot: Any, noise: float, seed: int, poses_from: str, nominal: Any
    ) -> Any:
        """The readings of the true ``robot`` (D-optimal poses planned with
        ``nominal``)."""
        ...

    def calibrator(
        self, nominal: Any, sim: Any, names: list[str], params: str, noise: Any
    ) -> Any:
        """The unfitted LM estimator of the drawn ``names`` on ``sim``."""
        ...

    def tool_points(self, est: Any, sim: Any) -> dict[str, Any]:
        """Keyword arguments of the held-out tool-point error (points: the
        markers' centroid)."""
        ...

    def too_few(self, unknowns: int, dof: int) -> str | None:
        """A note when this size cannot fit ``unknowns`` parameters with
        ``dof`` degrees of freedom to check the fit, else None."""
        ...


def reach_span(robot: Any) -> tuple[float, str]:
    """(m, what): the robot's reach, the span a tracker's, a socket plate's or
    a 6-DoF instrument's noise std is a small share of
    (:meth:`PlanSizing.noise_span` of those kinds).

    >>> from rmdrake.model.loading import load_robot
    >>> span, what = reach_span(load_robot("rv3sb"))
    >>> span > 0.5, what
    (True, "the reach of robot 'rv3sb'")
    """
    from rmdrake.kinematics.forward import robot_reach

    return robot_reach(robot), f"the reach of robot '{robot.name}'"


def plan_count(value: Any, what: str) -> int:
    """``value`` as an int >= 1 (a plan's count: plates, poses, markers).

    Example: ``plan_count(5, "plates")`` -> 5.

    Raises:
      ValueError: not an integer >= 1 (one line naming ``what``).
    """
    import numpy as np

    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{what}: expected an integer >= 1, found {value!r}")
    if value < 1:
        raise ValueError(f"{what}: expected an integer >= 1, found {value}")
    return int(value)


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
