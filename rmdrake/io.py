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
from rmdrake.npz_io import read_npz_arrays

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

CSV_ENCODING = "utf-8-sig"
"""CSV files are read as UTF-8 with an optional byte-order mark (spreadsheets
save one)."""


# ---- plane-constraint measurements: plane,q1..qn,distance -------------------------
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
    """

    plane: np.ndarray
    q: np.ndarray
    distance: np.ndarray

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
        return PlaneMeasurements(self.plane[mask], self.q[mask], self.distance[mask])


def read_plane_measurements(
    path: str | os.PathLike, n_joints: int | None = None
) -> PlaneMeasurements:
    """Reads a plane-measurement CSV (``plane,q1,...,qn,distance``).

    The header is ``plane,q1,...,qn,distance``; one row per reading; plane is an
    integer plate id, joints in rad, distance in m. This checks the format only;
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
    n = len(header) - 2
    expected = ["plane"] + [f"q{j}" for j in range(1, n + 1)] + ["distance"]
    if n < 1 or header != expected:
        raise ValueError(
            f"{path}: header {','.join(header)!r} is not plane,q1,...,qn,distance"
        )
    if n_joints is not None and n != n_joints:
        raise ValueError(
            f"{path}: {n} joint columns (q1..q{n}), but the robot has {n_joints} joints"
        )
    values = np.empty((len(rows) - 1, n + 2))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != n + 2:
            raise ValueError(
                f"{path}: line {line} has {len(row)} columns, expected {n + 2} "
                f"(plane,q1..q{n},distance)"
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
    return PlaneMeasurements(values[:, 0], values[:, 1:-1], values[:, -1])


def write_plane_measurements(path: str | os.PathLike, data: PlaneMeasurements) -> Path:
    """Writes a plane-measurement CSV atomically (full precision)."""
    n = data.n_joints
    lines = [",".join(["plane", *(f"q{j}" for j in range(1, n + 1)), "distance"])]
    for p, q, d in zip(data.plane, data.q, data.distance, strict=True):
        lines.append(
            ",".join([str(int(p)), *(repr(float(v)) for v in q), repr(float(d))])
        )
    return atomic_write_text(path, "\n".join(lines) + "\n")


# ---- joint-space log: t,q1..qn,tau1..taun[,qd1..qdn,qdd1..qddn] -------------------
@dataclasses.dataclass(frozen=True)
class JointLog:
    """A joint-space log for dynamic identification.

    Attributes:
      t: (M,) sample times in s, strictly increasing.
      q: (M, n) joint positions in rad.
      tau: (M, n) joint torques in N m (what a joint-torque sensor reads: the
        actuator torque).
      qd: (M, n) joint velocities in rad/s, or None when not measured.
      qdd: (M, n) joint accelerations in rad/s^2, or None when not measured.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = as_finite_array(self.t, "t", (None,))
        q = as_finite_array(self.q, "q", (t.shape[0], None))
        n = q.shape[1]
        fields = {"t": t, "q": q, "tau": as_finite_array(self.tau, "tau", q.shape)}
        for key in ("qd", "qdd"):
            value = getattr(self, key)
            fields[key] = (
                None if value is None else as_finite_array(value, key, q.shape)
            )
        if n < 1:
            raise ValueError("q: expected at least one joint column, found none")
        if t.size > 1 and not np.all(np.diff(t) > 0):
            k = int(np.flatnonzero(np.diff(t) <= 0)[0])
            raise ValueError(
                f"t: expected strictly increasing times, found t[{k + 1}] = "
                f"{t[k + 1]} after t[{k}] = {t[k]}"
            )
        for key, value in fields.items():
            if value is not None:
                value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q.shape[1])

    @property
    def n_samples(self) -> int:
        """Number of samples M."""
        return int(self.t.shape[0])

    def columns(self) -> list[str]:
        """Column names in file order: t, q1..qn, tau1..taun[, qd.., qdd..]."""
        n = self.n_joints
        names = ["t"] + [f"q{j}" for j in range(1, n + 1)]
        names += [f"tau{j}" for j in range(1, n + 1)]
        for key in ("qd", "qdd"):
            if getattr(self, key) is not None:
                names += [f"{key}{j}" for j in range(1, n + 1)]
        return names

    def table(self) -> np.ndarray:
        """(M, 1 + 2n [+ 2n]) array in :meth:`columns` order."""
        parts = [self.t[:, None], self.q, self.tau]
        parts += [p for p in (self.qd, self.qdd) if p is not None]
        return np.hstack(parts)


def write_joint_log(path: str | os.PathLike, log: JointLog) -> Path:
    """Writes ``log`` atomically as CSV (header ``t,q1..qn,tau1..taun[,qd..,
    qdd..]``, full float precision) or, for a ``.npz`` path, as NPZ with arrays
    of the same names. Returns the path."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        buf = io.BytesIO()
        arrays = {"t": log.t, "q": log.q, "tau": log.tau}
        arrays.update(
            {k: getattr(log, k) for k in ("qd", "qdd") if getattr(log, k) is not None}
        )
        np.savez(buf, **arrays)
        return atomic_write_bytes(path, buf.getvalue())
    buf = io.StringIO()
    np.savetxt(
        buf,
        log.table(),
        fmt="%.17g",
        delimiter=",",
        header=",".join(log.columns()),
        comments="",
    )
    return atomic_write_text(path, buf.getvalue())


def read_joint_log(path: str | os.PathLike, n_joints: int | None = None) -> JointLog:
    """Reads a joint-space log (CSV with a header, or NPZ with the same names
    or the names other tools use: ``times``, ``positions``, ``torques``,
    ``velocities``, ``accelerations``).

    The CSV header must be ``t,q1..qn,tau1..taun`` optionally followed by
    ``qd1..qdn`` and/or ``qdd1..qddn``; columns may come in any order.

    Args:
      n_joints: expected joint count (for example the robot's), or None.

    Raises:
      ValueError: one line naming the file and the problem (unreadable file,
        missing or unknown columns, joint count, NaN, non-increasing time).
    """
    path = Path(path)
    try:
        if path.suffix.lower() == ".npz":
            log = _read_npz(path)
        else:
            log = _read_csv(path)
        if n_joints is not None and log.n_joints != n_joints:
            raise ValueError(
                f"log has {log.n_joints} joints, expected {n_joints} (the robot's)"
            )
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    return log


_NPZ_NDIM = {"t": 1, "q": 2, "tau": 2, "qd": 2, "qdd": 2}
_NPZ_ALIASES = {
    "times": "t",
    "positions": "q",
    "torques": "tau",
    "velocities": "qd",
    "accelerations": "qdd",
}
"""Array names other tools write, and rmdrake's name for each."""


def _read_npz(path: Path) -> JointLog:
    ndim = _NPZ_NDIM | {k: _NPZ_NDIM[v] for k, v in _NPZ_ALIASES.items()}
    arrays: dict[str, np.ndarray] = {}
    for key, value in read_npz_arrays(path, ndim).items():
        name = _NPZ_ALIASES.get(key, key)
        if name in arrays:
            raise ValueError(f"arrays '{name}' and '{key}' both given; keep one")
        arrays[name] = value
    for key in ("t", "q", "tau"):
        if key not in arrays:
            alias = next(k for k, v in _NPZ_ALIASES.items() if v == key)
            raise ValueError(f"missing array '{key}' (or '{alias}')")
    return JointLog(**arrays)


def _read_csv(path: Path) -> JointLog:
    try:
        with path.open(encoding=CSV_ENCODING) as f:
            header = f.readline().strip()
            data = np.loadtxt(f, delimiter=",", ndmin=2)
    except OSError as e:
        raise ValueError(f"cannot read log: {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    except ValueError as e:
        raise ValueError(f"not a numeric CSV below the header ({e})") from None
    names = [c.strip() for c in header.split(",")]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate columns in header '{header}'")
    if "t" not in names:
        raise ValueError(f"missing column 't' in header '{header}'")
    n = sum(1 for c in names if c.startswith("q") and c[1:].isdigit())
    if n < 1:
        raise ValueError(f"no joint columns q1..qn in header '{header}'")
    groups = {}
    for key in ("q", "tau", "qd", "qdd"):
        want = [f"{key}{j}" for j in range(1, n + 1)]
        have = [c for c in want if c in names]
        if key in ("q", "tau") or have:
            missing = [c for c in want if c not in names]
            if missing:
                raise ValueError(
                    f"missing column(s) {', '.join(missing)} for {n} joints"
                )
            groups[key] = [names.index(c) for c in want]
    known = {"t"} | {
        f"{k}{j}" for k in ("q", "tau", "qd", "qdd") for j in range(1, n + 1)
    }
    unknown = [c for c in names if c not in known]
    if unknown:
        raise ValueError(
            f"unknown column(s) {', '.join(unknown)} (expected t,q1..q{n},"
            f"tau1..tau{n}[,qd..,qdd..])"
        )
    if data.size == 0:
        raise ValueError("no data rows")
    if data.shape[1] != len(names):
        raise ValueError(f"rows have {data.shape[1]} values, header has {len(names)}")
    return JointLog(
        t=data[:, names.index("t")],
        **{k: data[:, idx] for k, idx in groups.items()},
    )


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
