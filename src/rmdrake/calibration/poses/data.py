"""6-DoF pose measurements of a marker on the tool: the file format.

CSV with a header ``q1,...,qn,x,y,z,rx,ry,rz`` (columns in any order), one row
per robot pose: q in rad (m for a prismatic joint); ``x, y, z`` the measured
position p_IM of the marker frame M in the instrument frame I, in m;
``rx, ry, rz`` the measured orientation R_IM as a rotation vector in I, in rad
(R_IM = Exp(r), axis r / |r|, angle |r|; any angle is accepted, angles over pi
wrap). The pose X_IB of the robot base B in I and the pose X_FM of the marker
in the flange F (the MDH chain's tool frame) are unknown: the calibration
fits them (hand-eye). The reader checks the format only (the CSV rules of
:func:`rmdrake.io.csv.read_csv_columns`); the calibration's checks on the
content are :func:`rmdrake.calibration.poses.checks.check_pose_measurements`.
:func:`is_pose_header` recognises the header.

Example::

    import numpy as np
    from rmdrake.calibration.poses.data import (
        PoseMeasurements, read_pose_measurements, write_pose_measurements)
    data = PoseMeasurements(np.zeros((2, 6)), np.ones((2, 3)), np.zeros((2, 3)))
    path = write_pose_measurements("/tmp/poses.csv", data)
    assert np.array_equal(read_pose_measurements(path).p_IM, data.p_IM)
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.calibration.poses.so3 import so3_exp_many
from rmdrake.io.atomic import CHUNK_LINES, atomic_write_lines
from rmdrake.io.csv import CSV_ENCODING, read_csv_columns

__all__ = [
    "POSE_HEADER",
    "PoseMeasurements",
    "is_pose_header",
    "read_pose_header",
    "read_pose_measurements",
    "write_pose_measurements",
]

POSE_HEADER = "q1..qn,x,y,z,rx,ry,rz"
"""The header of a pose-measurement file (columns in any order)."""


@dataclasses.dataclass(frozen=True)
class PoseMeasurements:
    """Marker poses X_IM measured in the instrument frame I, one row per
    robot pose.

    Attributes:
      q: (N, n) joint positions, rad (m for a prismatic joint).
      p_IM: (N, 3) measured marker positions in I, m.
      r_IM: (N, 3) measured marker orientations R_IM = Exp(r_IM), rotation
        vectors in I, rad.

    >>> import numpy as np
    >>> data = PoseMeasurements(np.zeros((2, 6)), np.ones((2, 3)), np.zeros((2, 3)))
    >>> data.n_rows, data.n_joints
    (2, 6)
    """

    q: np.ndarray
    p_IM: np.ndarray
    r_IM: np.ndarray

    def __post_init__(self) -> None:
        q = as_finite_array(self.q, "q", (None, None))
        N = q.shape[0]
        values = {
            "q": q,
            "p_IM": as_finite_array(self.p_IM, "p_IM", (N, 3)),
            "r_IM": as_finite_array(self.r_IM, "r_IM", (N, 3)),
        }
        for key, value in values.items():
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_rows(self) -> int:
        """Number of readings N (robot poses)."""
        return int(self.q.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q.shape[1])

    @property
    def R_IM(self) -> np.ndarray:
        """(N, 3, 3) measured marker orientations in I."""
        return so3_exp_many(self.r_IM)

    def subset(self, mask: np.ndarray) -> PoseMeasurements:
        """The rows selected by a boolean mask or an index array."""
        return PoseMeasurements(self.q[mask], self.p_IM[mask], self.r_IM[mask])


def read_pose_header(path: str | os.PathLike) -> list[str]:
    """The stripped cells of a CSV's first line.

    Raises:
      ValueError: an unreadable or non-UTF-8 file (one line).
    """
    path = Path(path)
    try:
        with path.open(encoding=CSV_ENCODING) as f:
            line = f.readline()
    except OSError as e:
        raise ValueError(f"cannot read measurements '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    return [c.strip() for c in line.strip().split(",")]


def is_pose_header(header: list[str]) -> bool:
    """Whether a CSV header is that of pose measurements: joint columns
    ``q<j>``, ``x,y,z`` and ``rx,ry,rz``, nothing else."""
    q = [c for c in header if c[:1] == "q" and c[1:].isdigit()]
    rest = sorted(c for c in header if c not in q)
    return bool(q) and rest == ["rx", "ry", "rz", "x", "y", "z"]


def _groups(header: list[str]) -> dict[str, list[str]]:
    n = sum(1 for c in header if c[:1] == "q" and c[1:].isdigit())
    return {
        "q": [f"q{j}" for j in range(1, n + 1)],
        "p": ["x", "y", "z"],
        "r": ["rx", "ry", "rz"],
    }


def read_pose_measurements(
    path: str | os.PathLike, n_joints: int | None = None
) -> PoseMeasurements:
    """Reads a pose-measurement CSV (``q1..qn,x,y,z,rx,ry,rz``, columns in any
    order; m and rad).

    Raises:
      ValueError: one line naming the file, line and column: missing, unknown
        or duplicate column, wrong column count, a value that is not a finite
        number (NaN included), no data row, a joint count other than
        ``n_joints``.

    >>> import tempfile, numpy as np
    >>> from rmdrake.model.loading import load_robot
    >>> from rmdrake.calibration.poses.simulate import simulate_poses
    >>> sim = simulate_poses(load_robot("rv3sb"), poses=5, seed=1)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_pose_measurements(f"{tmp}/poses.csv", sim.data)
    ...     back = read_pose_measurements(path, 6)
    >>> bool(np.array_equal(back.r_IM, sim.data.r_IM)), back.n_rows
    (True, 5)
    """
    path = Path(path)
    cols = read_csv_columns(path, "pose measurements", _groups)
    n = 0 if cols["q"] is None else cols["q"].shape[1]
    if n == 0 or cols["p"] is None or cols["r"] is None:
        missing = "q1..qn" if n == 0 else "x,y,z" if cols["p"] is None else "rx,ry,rz"
        raise ValueError(
            f"{path}: line 1: missing column(s) {missing}: expected the header "
            f"{POSE_HEADER}"
        )
    if n_joints is not None and n != n_joints:
        raise ValueError(
            f"{path}: {n} joint columns (q1..q{n}), but the robot has {n_joints} joints"
        )
    return PoseMeasurements(cols["q"], cols["p"], cols["r"])


def write_pose_measurements(path: str | os.PathLike, data: PoseMeasurements) -> Path:
    """Writes a pose-measurement CSV atomically, in full precision (reads back
    bit for bit).

    >>> import tempfile, numpy as np
    >>> data = PoseMeasurements(np.zeros((1, 2)), [[1.0, 2, 3]], [[0.0, 0, 0.1]])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_pose_measurements(f"{tmp}/p.csv", data)
    ...     print(path.read_text().splitlines()[0])
    q1,q2,x,y,z,rx,ry,rz
    """
    n = data.n_joints
    names = [*(f"q{j}" for j in range(1, n + 1)), "x", "y", "z", "rx", "ry", "rz"]
    values = np.column_stack([data.q, data.p_IM, data.r_IM])

    def lines() -> Iterable[str]:
        yield ",".join(names)
        for a in range(0, data.n_rows, CHUNK_LINES):  # .tolist() chunk by chunk
            for row in values[a : a + CHUNK_LINES].tolist():
                yield ",".join(map(repr, row))

    return atomic_write_lines(path, lines())
