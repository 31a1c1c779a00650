"""Plane-constraint measurements: range-finder readings on plates, and their CSV
file ``plane,q1..qn,distance[,payload]``."""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.io.atomic import atomic_write_lines
from rmdrake.io.csv import CSV_ENCODING, MAX_COLUMNS, csv_rows
from rmdrake.progress import progress_iter

__all__ = [
    "PlaneMeasurements",
    "read_plane_measurements",
    "write_plane_measurements",
]


@dataclasses.dataclass(frozen=True)
class PlaneMeasurements:
    """Range-finder readings on a flat plate put at several unknown locations.

    One entry per reading: the plate location id, the joint angles and the
    reading. The measured point is ``p_BM = p_BE(q) + distance * z_BE(q)`` (the
    reading adds to the tool r, see :mod:`rmdrake.kinematics`).

    Attributes:
      plane: (N,) integer id of the plate location of each reading.
      q: (N, n) joint angles, rad.
      distance: (N,) range-finder readings along the tool z axis, m.
      payload: (N,) mass at the tool when the reading was taken, kg, or None
        (no ``payload`` column: readings taken without a payload, 0 kg). Only
        an elastic calibration uses it (the joint torques that bend the arm).

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import PlaneMeasurements
    >>> data = PlaneMeasurements(plane=np.array([0, 0, 1, 1]), q=np.zeros((4, 6)),
    ...                      distance=np.full(4, 0.05))
    ...
    >>> data.q.shape, data.distance.shape
    ((4, 6), (4,))
    """

    plane: np.ndarray
    q: np.ndarray
    distance: np.ndarray
    payload: np.ndarray | None = None

    def __post_init__(self) -> None:
        q = as_finite_array(self.q, "q", (None, None))
        N = q.shape[0]
        distance = as_finite_array(self.distance, "distance", (N,))
        plane_f = as_finite_array(self.plane, "plane", (N,))
        if np.any(plane_f != np.round(plane_f)):
            raise ValueError("plane: expected integer plate ids")
        for key, value in (("plane", plane_f.astype(np.int64)), ("q", q)):
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        distance.flags.writeable = False
        object.__setattr__(self, "distance", distance)
        if self.payload is not None:
            payload = as_finite_array(self.payload, "payload", (N,))
            if np.any(payload < 0):
                raise ValueError(
                    f"payload: expected masses >= 0 kg, found {payload.min():g}"
                )
            payload.flags.writeable = False
            object.__setattr__(self, "payload", payload)

    @property
    def n_readings(self) -> int:
        """Number of readings N."""
        return int(self.q.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n (columns of q)."""
        return int(self.q.shape[1])

    @property
    def plate_ids(self) -> np.ndarray:
        """Sorted unique plate ids."""
        return np.unique(self.plane)

    @property
    def plate_index(self) -> np.ndarray:
        """(N,) index 0..P-1 of each reading's plate into :attr:`plate_ids`."""
        return np.searchsorted(self.plate_ids, self.plane)

    def subset(self, mask: np.ndarray) -> PlaneMeasurements:
        """The readings selected by a boolean mask or an index array."""
        payload = None if self.payload is None else self.payload[mask]
        return PlaneMeasurements(
            self.plane[mask], self.q[mask], self.distance[mask], payload
        )

    @property
    def payload_masses(self) -> np.ndarray:
        """(N,) payload per reading, kg (zeros without a ``payload`` column)."""
        if self.payload is None:
            return np.zeros(self.n_readings)
        return np.array(self.payload)


def read_plane_measurements(
    path: str | os.PathLike, n_joints: int | None = None
) -> PlaneMeasurements:
    """Reads a plane-measurement CSV (``plane,q1,...,qn,distance[,payload]``).

    The header is ``plane,q1,...,qn,distance``, optionally followed by
    ``payload``; one row per reading; plane is an integer plate id, joints in
    rad (m on a slide), distance in m, payload the mass at the tool in kg when
    the reading was taken (no column: 0 kg). This checks the format only;
    see :func:`rmdrake.calibration.plates.checks.check_plane_measurements` for the
    calibration's checks.

    Raises:
      ValueError: one line naming the file, line and column of the problem
        (missing file, bad header, wrong column count, non-numeric or NaN value).

    Example:

    >>> from rmdrake import load_robot, read_plane_measurements
    >>> from rmdrake import write_plane_measurements
    >>> from rmdrake.calibration import simulate_plates
    >>> data = simulate_plates(load_robot("rv3sb"), plates=3, per_plate=4, seed=0).data
    >>> back = read_plane_measurements(write_plane_measurements("plates.csv", data))
    >>> back.q.shape, bool((back.plane == data.plane).all())
    ((12, 6), True)
    """
    path = Path(path)
    try:
        text = path.read_text(encoding=CSV_ENCODING)
    except OSError as e:
        raise ValueError(f"cannot read measurements '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    rows = [r for _, r in csv_rows(text, path)]
    if not rows:
        raise ValueError(f"{path}: empty file, expected a header plane,q1..qn,distance")
    header = [c.strip() for c in rows[0]]
    if len(header) > MAX_COLUMNS:
        raise ValueError(
            f"{path}: line 1: {len(header)} columns, over the {MAX_COLUMNS} a "
            "plate measurements file may have"
        )
    has_payload = header[-1:] == ["payload"]
    n = len(header) - 2 - has_payload
    expected = ["plane"] + [f"q{j}" for j in range(1, n + 1)] + ["distance"]
    if n < 1 or header[: n + 2] != expected:
        raise ValueError(
            f"{path}: header {','.join(header)!r} is not "
            "plane,q1,...,qn,distance[,payload]"
        )
    if n_joints is not None and n != n_joints:
        raise ValueError(
            f"{path}: {n} joint columns (q1..q{n}), but the robot has {n_joints} joints"
        )
    width = len(header)
    values = np.empty((len(rows) - 1, width))
    # 10 s for 200 000 rows: shown when the process has been silent an interval
    rows_read = progress_iter(rows[1:], desc=f"{path.name}: rows read", lazy=True)
    for i, row in enumerate(rows_read):
        line = i + 2
        if len(row) != width:
            raise ValueError(
                f"{path}: line {line} has {len(row)} columns, expected {width} "
                f"({','.join(header[:2])}..q{n},{','.join(header[n + 1 :])})"
            )
        for c, cell in enumerate(row):
            try:
                v = float(cell)
            except ValueError:
                raise ValueError(
                    f"{path}: line {line}, column {header[c]}: {cell.strip()!r} is "
                    f"not a number"
                ) from None
            if not math.isfinite(v):  # a float's: 20x faster than numpy's
                raise ValueError(
                    f"{path}: line {line}, column {header[c]}: {cell.strip()} is "
                    f"not a finite number"
                )
            values[i, c] = v
    bad = np.flatnonzero(values[:, 0] != np.round(values[:, 0]))
    if bad.size:
        raise ValueError(
            f"{path}: line {bad[0] + 2}, column plane: {values[bad[0], 0]:g} is not "
            f"an integer plate id"
        )
    if has_payload and np.any(values[:, -1] < 0):
        k = int(np.flatnonzero(values[:, -1] < 0)[0])
        raise ValueError(
            f"{path}: line {k + 2}, column payload: {values[k, -1]:g} kg is negative"
        )
    payload = values[:, -1] if has_payload else None
    return PlaneMeasurements(
        values[:, 0], values[:, 1 : n + 1], values[:, n + 1], payload
    )


def write_plane_measurements(path: str | os.PathLike, data: PlaneMeasurements) -> Path:
    """Writes a plane-measurement CSV atomically (full precision); the
    ``payload`` column only when the readings carry one.

    Example:

    >>> from rmdrake import load_robot, write_plane_measurements
    >>> from rmdrake.calibration import simulate_plates
    >>> data = simulate_plates(load_robot("rv3sb"), plates=3, per_plate=4, seed=0).data
    >>> write_plane_measurements("plates.csv", data).read_text().splitlines()[0]
    'plane,q1,q2,q3,q4,q5,q6,distance'
    """
    n = data.n_joints
    head = ["plane", *(f"q{j}" for j in range(1, n + 1)), "distance"]
    extra = [] if data.payload is None else ["payload"]
    pay = np.zeros(data.n_readings) if data.payload is None else data.payload

    def lines() -> Iterable[str]:
        yield ",".join(head + extra)
        for p, q, d, m in zip(data.plane, data.q, data.distance, pay, strict=True):
            cells = [str(int(p)), *(repr(float(v)) for v in q), repr(float(d))]
            yield ",".join(cells + [repr(float(m))] * len(extra))

    return atomic_write_lines(path, lines())
