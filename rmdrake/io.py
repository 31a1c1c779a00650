"""File I/O shared by every part of rmdrake: the file formats and their checks.

Every file rmdrake writes goes through :func:`~rmdrake.atomic.atomic_write_text`
or :func:`~rmdrake.atomic.atomic_write_bytes` (re-exported here), so a crash or
a bad input never leaves a half-written or truncated result behind.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.atomic import atomic_write_bytes, atomic_write_text
from rmdrake.joint_log import (  # the joint-space log lives there, re-exported
    CSV_ENCODING,
    JointLog,
    read_joint_log,
    write_joint_log,
)

__all__ = [
    "JointLog",
    "PlaneMeasurements",
    "atomic_write_bytes",
    "atomic_write_text",
    "read_csv_columns",
    "read_joint_log",
    "read_plane_measurements",
    "write_csv_columns",
    "write_joint_log",
    "write_plane_measurements",
]


# ---- plane-constraint measurements: plane,q1..qn,distance[,payload] ---------------
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
    see :func:`rmdrake.calibration.readings.check_plane_measurements` for the
    calibration's checks.

    Raises:
      ValueError: one line naming the file, line and column of the problem
        (missing file, bad header, wrong column count, non-numeric or NaN value).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding=CSV_ENCODING)
    except OSError as e:
        raise ValueError(f"cannot read measurements '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    rows = list(csv.reader(io.StringIO(text)))
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ValueError(f"{path}: empty file, expected a header plane,q1..qn,distance")
    header = [c.strip() for c in rows[0]]
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
    for i, row in enumerate(rows[1:]):
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
            if not np.isfinite(v):
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
    ``payload`` column only when the readings carry one."""
    n = data.n_joints
    head = ["plane", *(f"q{j}" for j in range(1, n + 1)), "distance"]
    extra = [] if data.payload is None else ["payload"]
    lines = [",".join(head + extra)]
    pay = np.zeros(data.n_readings) if data.payload is None else data.payload
    for p, q, d, m in zip(data.plane, data.q, data.distance, pay, strict=True):
        cells = [str(int(p)), *(repr(float(v)) for v in q), repr(float(d))]
        lines.append(",".join(cells + [repr(float(m))] * len(extra)))
    return atomic_write_text(path, "\n".join(lines) + "\n")


# ---- numeric CSV with named columns (tool targets, joint programs) -----------------
def read_csv_columns(
    path: str | os.PathLike,
    what: str,
    groups_of: Callable[[list[str]], dict[str, list[str]]],
) -> dict[str, np.ndarray | None]:
    """Reads a numeric CSV whose header names each column once, in any order:
    {group: (M, k) values in the group's column order, or None if absent};
    ``groups_of(header)`` gives {group: column names}, the first group required,
    each other one all or nothing; ``what`` names the content in messages.

    Raises:
      ValueError: one line naming the file, line and column: a missing, unknown
        or duplicate column, a wrong column count, a value that is not a finite
        number, a column ``t`` that is not strictly increasing.
    """
    path = Path(path)
    try:
        reader = csv.reader(io.StringIO(path.read_text(encoding=CSV_ENCODING)))
    except OSError as e:
        raise ValueError(f"cannot read {what} '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    rows = [(reader.line_num, r) for r in reader if any(c.strip() for c in r)]
    header = [c.strip() for c in rows[0][1]] if rows else []
    groups = groups_of(header)
    out: dict[str, list[int] | None] = {}
    for key, cols in groups.items():
        have = [c for c in cols if c in header]
        if (have or not out) and have != cols:
            missing = ",".join(c for c in cols if c not in header)
            raise ValueError(f"{path}: line 1: missing column(s) {missing}")
        out[key] = [header.index(c) for c in cols] if have else None
    known = [c for cols in groups.values() for c in cols]
    for c in header:
        if c not in known or header.count(c) > 1:
            why = "duplicate" if c in known else "unknown"
            raise ValueError(f"{path}: line 1: {why} column {c!r}")
    if len(rows) < 2:
        raise ValueError(f"{path}: no data rows below the header")
    values = np.full((len(rows) - 1, len(header)), np.nan)
    for i, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ValueError(
                f"{path}: line {line}: {len(row)} columns, not {len(header)}"
            )
        for c, cell in enumerate(row):
            try:
                values[i, c] = float(cell)
            except ValueError:
                pass
            if not np.isfinite(values[i, c]):
                raise ValueError(
                    f"{path}: line {line}, column {header[c]}: {cell.strip()!r} is "
                    f"not a finite number"
                )
    if "t" in header and np.any(np.diff(t := values[:, header.index("t")]) <= 0):
        line = rows[int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2][0]
        raise ValueError(f"{path}: line {line}, column t: time not after the last")
    return {k: None if c is None else values[:, c] for k, c in out.items()}


def write_csv_columns(
    path: str | os.PathLike, columns: Mapping[str, np.ndarray | None]
) -> Path:
    """Writes {name: (M,) values, or None to leave the column out} atomically as
    CSV with a header, in full precision (repr: reads back bit for bit)."""
    names = [k for k, v in columns.items() if v is not None]
    rows = np.column_stack([columns[k] for k in names]).tolist()
    text = "\n".join([",".join(names)] + [",".join(map(repr, r)) for r in rows])
    return atomic_write_text(path, text + "\n")
