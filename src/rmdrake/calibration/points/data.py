"""Point measurements of a laser tracker or motion capture: the file format.

CSV with a header ``pose,marker,q1,...,qn,x,y,z`` and an optional ``payload``
column: ``pose`` is the integer id of a robot configuration,
``marker`` the integer id of a target fixed to the tool, q in rad (m for a
prismatic joint), ``x, y, z`` the measured point in m in the instrument frame I
(whose pose relative to the robot base B is unknown), ``payload`` in kg at the
tool when the point was measured (0 kg without the column; an elastostatic
calibration, :mod:`rmdrake.calibration.elastostatic`, bends the joints under
it). The reader checks the format only (the CSV rules of
:func:`rmdrake.io.csv.read_csv_columns`: header, column counts, finite numbers,
integer ids, payloads >= 0); the calibration's checks on the content are
:func:`rmdrake.calibration.points.checks.check_point_measurements`.
:func:`rmdrake.calibration.registry.kind_of_file` tells the kinds' files
apart by their headers.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.io.atomic import CHUNK_LINES, atomic_write_lines
from rmdrake.io.csv import read_csv_columns

__all__ = [
    "PointMeasurements",
    "read_point_measurements",
    "write_point_measurements",
]

POINT_HEADER = "pose,marker,q1..qn,x,y,z[,payload]"


@dataclasses.dataclass(frozen=True)
class PointMeasurements:
    """Points on the tool measured in the instrument frame I, one row per
    (pose, marker).

    Attributes:
      pose: (N,) integer id of the robot configuration of each row.
      marker: (N,) integer id of the target on the tool.
      q: (N, n) joint positions, rad (m for a prismatic joint).
      p_I: (N, 3) measured points in I, m.
      payload: (N,) kg at the tool, or None.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import PointMeasurements
    >>> data = PointMeasurements(pose=np.array([0, 0, 1]), marker=np.array([0, 1, 0]),
    ...                      q=np.zeros((3, 6)), p_I=np.zeros((3, 3)))
    ...
    >>> data.q.shape, data.p_I.shape
    ((3, 6), (3, 3))
    """

    pose: np.ndarray
    marker: np.ndarray
    q: np.ndarray
    p_I: np.ndarray
    payload: np.ndarray | None = None

    def __post_init__(self) -> None:
        q = as_finite_array(self.q, "q", (None, None))
        N = q.shape[0]
        p_I = as_finite_array(self.p_I, "p_I", (N, 3))
        values = {"q": q, "p_I": p_I}
        for key in ("pose", "marker"):
            ids = as_finite_array(getattr(self, key), key, (N,))
            if np.any(ids != np.round(ids)) or np.any(np.abs(ids) >= 2**53):
                raise ValueError(f"{key}: expected integer ids below 2^53")
            values[key] = ids.astype(np.int64)
        if self.payload is not None:
            values["payload"] = as_finite_array(self.payload, "payload", (N,))
            if np.any(values["payload"] < 0):
                raise ValueError(
                    "payload: expected masses >= 0 kg, found "
                    f"{values['payload'].min():g}"
                )
        for key, value in values.items():
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_rows(self) -> int:
        """Number of measured points N."""
        return int(self.q.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q.shape[1])

    @property
    def payload_masses(self) -> np.ndarray:
        """(N,) payload per point, kg (zeros without a ``payload`` column)."""
        if self.payload is None:
            return np.zeros(self.n_rows)
        return np.array(self.payload)

    @property
    def pose_ids(self) -> np.ndarray:
        """Sorted unique pose ids."""
        return np.unique(self.pose)

    @property
    def marker_ids(self) -> np.ndarray:
        """Sorted unique marker ids."""
        return np.unique(self.marker)

    @property
    def marker_index(self) -> np.ndarray:
        """(N,) index 0..M-1 of each row's marker into :attr:`marker_ids`."""
        return np.searchsorted(self.marker_ids, self.marker)

    @property
    def pose_index(self) -> np.ndarray:
        """(N,) index 0..P-1 of each row's pose into :attr:`pose_ids`."""
        return np.searchsorted(self.pose_ids, self.pose)

    def subset(self, mask: np.ndarray) -> PointMeasurements:
        """The rows selected by a boolean mask or an index array."""
        payload = None if self.payload is None else self.payload[mask]
        return PointMeasurements(
            self.pose[mask], self.marker[mask], self.q[mask], self.p_I[mask], payload
        )

    def of_poses(self, pose_ids: np.ndarray) -> PointMeasurements:
        """The rows of the given pose ids (all their markers), in file order."""
        return self.subset(np.isin(self.pose, pose_ids))


def _groups(header: list[str]) -> dict[str, list[str]]:
    n = sum(1 for c in header if c[:1] == "q" and c[1:].isdigit())
    return {
        "ids": ["pose", "marker"],
        "q": [f"q{j}" for j in range(1, n + 1)],
        "p": ["x", "y", "z"],
        "payload": ["payload"],
    }


def read_point_measurements(
    path: str | os.PathLike, n_joints: int | None = None
) -> PointMeasurements:
    """Reads a point-measurement CSV (``pose,marker,q1..qn,x,y,z[,payload]``,
    columns in any order).

    Raises:
      ValueError: one line naming the file, line and column: missing, unknown
        or duplicate column, wrong column count, a value that is not a finite
        number (NaN included), a pose or marker id that is not an integer, a
        negative payload, a joint count other than ``n_joints``.

    Example:

    >>> from rmdrake import load_robot, read_point_measurements
    >>> from rmdrake import write_point_measurements
    >>> from rmdrake.calibration import simulate_points
    >>> data = simulate_points(load_robot("rv3sb"), poses=5, markers=2, seed=0).data
    >>> back = read_point_measurements(write_point_measurements("points.csv", data))
    >>> back.q.shape, back.p_I.shape
    ((10, 6), (10, 3))
    """
    path = Path(path)
    cols = read_csv_columns(path, "point measurements", _groups)
    n = 0 if cols["q"] is None else cols["q"].shape[1]
    if n == 0 or cols["p"] is None:
        raise ValueError(f"{path}: line 1: expected the header {POINT_HEADER}")
    if n_joints is not None and n != n_joints:
        raise ValueError(
            f"{path}: {n} joint columns (q1..q{n}), but the robot has {n_joints} joints"
        )
    ids = cols["ids"]
    for c, name in enumerate(("pose", "marker")):
        bad = np.flatnonzero((ids[:, c] != np.round(ids[:, c])) | (ids[:, c] >= 2**53))
        if bad.size:
            raise ValueError(
                f"{path}: row {bad[0] + 1}, column {name}: {ids[bad[0], c]:g} is "
                f"not an integer id"
            )
    payload = None if cols["payload"] is None else cols["payload"][:, 0]
    if payload is not None and np.any(payload < 0):
        k = int(np.argmax(payload < 0))
        raise ValueError(
            f"{path}: row {k + 1}, column payload: {payload[k]:g} kg is negative"
        )
    return PointMeasurements(ids[:, 0], ids[:, 1], cols["q"], cols["p"], payload)


def write_point_measurements(path: str | os.PathLike, data: PointMeasurements) -> Path:
    """Writes a point-measurement CSV atomically, in full precision (reads back
    bit for bit); ids as integers.

    Example:

    >>> from rmdrake import load_robot, write_point_measurements
    >>> from rmdrake.calibration import simulate_points
    >>> data = simulate_points(load_robot("rv3sb"), poses=5, markers=2, seed=0).data
    >>> write_point_measurements("points.csv", data).read_text().splitlines()[0]
    'pose,marker,q1,q2,q3,q4,q5,q6,x,y,z'
    """
    n = data.n_joints
    names = ["pose", "marker", *(f"q{j}" for j in range(1, n + 1)), "x", "y", "z"]
    values = np.column_stack([data.q, data.p_I])
    if data.payload is not None:
        names.append("payload")
        values = np.column_stack([values, data.payload])

    def lines() -> Iterable[str]:
        yield ",".join(names)
        for a in range(0, data.n_rows, CHUNK_LINES):  # .tolist() chunk by chunk
            rows = slice(a, a + CHUNK_LINES)
            pose, marker = data.pose[rows].tolist(), data.marker[rows].tolist()
            for p, m, row in zip(pose, marker, values[rows].tolist(), strict=True):
                yield ",".join([str(p), str(m), *map(repr, row)])

    return atomic_write_lines(path, lines())
