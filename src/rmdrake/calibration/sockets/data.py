"""Socket measurements: a ball on the tool seated in fixed sockets, the file
format and MUKCa's folder layout.

A ball fixed to the tool (the robot model's tool point) is seated by hand in a
spherical socket and the joint positions are recorded, for many arm
configurations per socket; the socket's position is unknown, so the rows of one
socket share one unknown point in the base frame B. Known distances between
sockets (two sockets on one plate, 50 mm apart in MUKCa) fix the length scale.

Files:

* ``sockets.csv``: header ``socket,q1,...,qn`` (columns in any order), one row
  per recorded configuration: ``socket`` the integer id of the socket, q in rad
  (m for a prismatic joint).
* ``sockets_distances.csv`` beside it (``<stem>_distances.csv``, optional):
  header ``socket_a,socket_b,distance``, one known distance in m per pair of
  socket ids; read with the sockets when present.

A **placement** is a connected group of sockets: two sockets joined by a known
distance are on one rigid plate, so they belong to one placement; a socket
with no known distance is a placement of its own. Placements are what
cross-validation holds out, because the rows of one placement share its
sockets. Sockets of different placements must have different ids.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.calibration.config import (
    DEFAULT_DISTANCE_NOISE as CONFIG_DISTANCE_NOISE,
)
from rmdrake.calibration.sanity import check_joint_values
from rmdrake.io.atomic import CHUNK_LINES, atomic_write_files, encode_lines
from rmdrake.io.csv import read_csv_columns
from rmdrake.io.paths import not_a_regular_file

__all__ = [
    "DEFAULT_DISTANCE_NOISE",
    "MUKCA_SOCKET_DISTANCE",
    "SocketMeasurements",
    "MAX_PLATE_DISTANCE",
    "distances_path",
    "mukca_hole_files",
    "parse_socket_distance",
    "read_mukca_sockets",
    "read_socket_measurements",
    "write_socket_measurements",
]

SOCKET_HEADER = "socket,q1..qn"
DISTANCE_HEADER = "socket_a,socket_b,distance"
MUKCA_SOCKET_DISTANCE = 0.05
"""Distance between the two sockets of MUKCa's plate, m."""

MAX_PLATE_DISTANCE = 1.0
"""m: the farthest apart two holes of one hand-placed plate are (MUKCa's
50 mm; a plate over a metre long is not moved around an arm by hand): a
larger ``distance`` of :func:`read_mukca_sockets` is one in mm."""

DEFAULT_DISTANCE_NOISE = CONFIG_DISTANCE_NOISE
"""Standard deviation of a known socket distance, m (a machined or well
printed plate; :data:`rmdrake.calibration.config.DEFAULT_DISTANCE_NOISE`)."""


@dataclasses.dataclass(frozen=True)
class SocketMeasurements:
    """Configurations of the arm with its ball seated in sockets.

    Attributes:
      socket: (N,) integer id of the socket of each row.
      q: (N, n) joint positions, rad (m for a prismatic joint).
      distances: (D, 3) known distances: rows ``[socket_a, socket_b,
        distance]`` (ids, m); (0, 3) when none is known.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import SocketMeasurements
    >>> data = SocketMeasurements(socket=np.array([0, 0, 1, 1]), q=np.zeros((4, 6)))
    >>> data.q.shape, data.distances.shape
    ((4, 6), (0, 3))
    """

    socket: np.ndarray
    q: np.ndarray
    distances: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        q = as_finite_array(self.q, "q", (None, None))
        N = q.shape[0]
        ids = as_finite_array(self.socket, "socket", (N,))
        if np.any(ids != np.round(ids)) or np.any(np.abs(ids) >= 2**53):
            raise ValueError("socket: expected integer ids below 2^53")
        d = as_finite_array(self.distances, "distances", (None, 3))
        pairs = d[:, :2]
        if np.any(pairs != np.round(pairs)):
            raise ValueError("distances: expected integer socket ids")
        if np.any(d[:, 2] <= 0):
            raise ValueError(
                f"distances: expected positive distances in m, found "
                f"{d[np.argmax(d[:, 2] <= 0), 2]:g}"
            )
        if np.any(pairs[:, 0] == pairs[:, 1]):
            raise ValueError("distances: a socket's distance to itself")
        ordered = np.sort(pairs, axis=1)
        _, first, times = np.unique(
            ordered, axis=0, return_index=True, return_counts=True
        )
        if np.any(times > 1):
            a, b = ordered[first[np.argmax(times > 1)]].astype(np.int64)
            given = d[np.all(ordered == (a, b), axis=1), 2]
            raise ValueError(
                f"distances: sockets {a} and {b} have {given.size} known distances "
                f"({', '.join(f'{v:g}' for v in given)} m): give one per pair"
            )
        unknown = np.setdiff1d(pairs, ids)
        if unknown.size:
            raise ValueError(
                f"distances: socket {int(unknown[0])} has a known distance but no rows"
            )
        for key, value in (
            ("q", q),
            ("socket", ids.astype(np.int64)),
            ("distances", d),
        ):
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_rows(self) -> int:
        """Number of recorded configurations N."""
        return int(self.q.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q.shape[1])

    @property
    def socket_ids(self) -> np.ndarray:
        """Sorted unique socket ids."""
        return np.unique(self.socket)

    @property
    def socket_index(self) -> np.ndarray:
        """(N,) index 0..S-1 of each row's socket into :attr:`socket_ids`."""
        return np.searchsorted(self.socket_ids, self.socket)

    @property
    def distance_index(self) -> np.ndarray:
        """(D, 2) indices into :attr:`socket_ids` of each known distance's
        sockets."""
        return np.searchsorted(self.socket_ids, self.distances[:, :2].astype(np.int64))

    @property
    def placement_of_socket(self) -> np.ndarray:
        """(S,) placement 0..P-1 of each socket (ascending socket id): the
        connected groups of sockets joined by known distances, numbered in the
        order of their lowest socket id."""
        import scipy.sparse  # here: the file format's readers need no scipy
        import scipy.sparse.csgraph

        S = self.socket_ids.size
        a, b = self.distance_index.T
        graph = scipy.sparse.coo_matrix((np.ones(a.size), (a, b)), shape=(S, S))
        # Labels in order of each group's first (lowest-index) socket.
        return scipy.sparse.csgraph.connected_components(graph, directed=False)[1]

    @property
    def placement(self) -> np.ndarray:
        """(N,) placement 0..P-1 of each row (:attr:`placement_of_socket`)."""
        return self.placement_of_socket[self.socket_index]

    @property
    def n_placements(self) -> int:
        """Number of placements P."""
        return int(self.placement_of_socket.max() + 1) if self.n_rows else 0

    def subset(self, mask: np.ndarray) -> SocketMeasurements:
        """The rows selected by a boolean mask or an index array, with the
        known distances between the sockets left."""
        socket = self.socket[mask]
        keep = np.all(np.isin(self.distances[:, :2], socket), axis=1)
        return SocketMeasurements(socket, self.q[mask], self.distances[keep])

    def of_placements(self, placements: Sequence[int]) -> SocketMeasurements:
        """The rows of the given placements (0..P-1), in file order."""
        return self.subset(np.isin(self.placement, np.asarray(placements)))


def distances_path(path: str | os.PathLike) -> Path:
    """The distance file beside a socket CSV: ``<stem>_distances.csv``."""
    path = Path(path)
    return path.with_name(f"{path.stem}_distances.csv")


def parse_socket_distance(text: str) -> tuple[int, int, float]:
    """``a,b,d`` (socket ids and a distance in m) of ``--socket-distance``.

    Raises:
      ValueError: not two integer ids and a positive distance.
    """
    parts = [p.strip() for p in str(text).split(",")]
    try:
        if len(parts) != 3:
            raise ValueError
        a, b, d = int(parts[0]), int(parts[1]), float(parts[2])
    except ValueError:
        raise ValueError(
            f"socket distance {text!r}: expected SOCKET_A,SOCKET_B,METRES "
            "(e.g. 0,1,0.05)"
        ) from None
    if not np.isfinite(d) or d <= 0:
        raise ValueError(f"socket distance {text!r}: expected a positive distance in m")
    return a, b, d


def _socket_groups(header: list[str]) -> dict[str, list[str]]:
    n = sum(1 for c in header if c[:1] == "q" and c[1:].isdigit())
    return {"socket": ["socket"], "q": [f"q{j}" for j in range(1, n + 1)]}


def _distance_groups(header: list[str]) -> dict[str, list[str]]:
    return {"d": ["socket_a", "socket_b", "distance"]}


def read_socket_measurements(
    path: str | os.PathLike,
    n_joints: int | None = None,
    *,
    distances: Iterable[tuple[int, int, float]] = (),
) -> SocketMeasurements:
    """Reads a socket CSV (``socket,q1..qn``) and the distance file beside it
    (:func:`distances_path`) when present; ``distances`` (``(a, b, d)``, m)
    are added, replacing the file's distance of the same pair (two different
    distances of one pair in the file, or in ``distances``, are refused).

    Raises:
      ValueError: one line naming the file, line and column: a missing,
        unknown or duplicate column, a wrong column count, a value that is not
        a finite number, a socket id that is not an integer, a joint count
        other than ``n_joints``, a distance for a socket with no rows; a
        distance file that is not a regular file (a FIFO, a device, a folder,
        a link that loops or points nowhere), has more rows than pairs of
        sockets or two different distances for one pair.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import read_socket_measurements, simulate_sockets
    >>> from rmdrake.calibration import write_socket_measurements
    >>> data = simulate_sockets(load_robot("rv3sb"), placements=2, seed=0).data
    >>> back = read_socket_measurements(write_socket_measurements("sockets.csv", data))
    >>> back.q.shape == data.q.shape
    True
    """
    path = Path(path)
    cols = read_csv_columns(path, "socket measurements", _socket_groups)
    n = 0 if cols["q"] is None else cols["q"].shape[1]
    if n == 0:
        raise ValueError(f"{path}: line 1: expected the header {SOCKET_HEADER}")
    if n_joints is not None and n != n_joints:
        raise ValueError(
            f"{path}: {n} joint columns (q1..q{n}), but the robot has {n_joints} joints"
        )
    ids = cols["socket"][:, 0]
    bad = np.flatnonzero((ids != np.round(ids)) | (np.abs(ids) >= 2**53))
    if bad.size:
        raise ValueError(
            f"{path}: row {bad[0] + 1}, column socket: {ids[bad[0]]:g} is not an "
            "integer id"
        )
    known = _read_distances(distances_path(path), path, np.unique(ids).size)
    given: dict[tuple[int, int], float] = {}
    for a, b, dist in distances:
        pair = (min(a, b), max(a, b))
        if pair in given and given[pair] != float(dist):
            raise ValueError(
                f"socket distance {a},{b}: given as {given[pair]:g} and {dist:g} m: "
                "give one per pair"
            )
        given[pair] = float(dist)
    known.update(given)
    rows = [[a, b, d] for (a, b), d in sorted(known.items())]
    try:
        return SocketMeasurements(ids, cols["q"], np.reshape(rows, (-1, 3)))
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def _read_distances(
    side: Path, path: Path, sockets: int
) -> dict[tuple[int, int], float]:
    """{(a, b): m} of the distance file ``side`` beside the socket CSV
    ``path`` of ``sockets`` sockets; empty when there is none.

    Raises:
      ValueError: one line naming ``side``: a name that is not a regular file
        (a FIFO, a device, a folder, a symbolic link that loops or points
        nowhere), more rows than pairs of sockets, ids that are not integers,
        two different distances for one pair.
    """
    if not os.path.lexists(side):
        return {}
    why = not_a_regular_file(side)
    if why:
        raise ValueError(f"{side}: {why}; the distance file beside {path} is read")
    pairs = sockets * (sockets - 1) // 2
    with open(side, "rb") as f:
        lines = sum(1 for line in f if line.strip()) - 1
    if lines > pairs:
        raise ValueError(
            f"{side}: {lines} distances for the {sockets} sockets of {path}, over "
            f"the {pairs} pairs they make (one distance per pair): the wrong file?"
        )
    d = read_csv_columns(side, "socket distances", _distance_groups)["d"]
    known: dict[tuple[int, int], float] = {}
    for row, (a, b, dist) in enumerate(d.tolist(), start=1):
        if a != round(a) or b != round(b):
            raise ValueError(f"{side}: socket ids {a:g}, {b:g}: not integers")
        pair = (min(int(a), int(b)), max(int(a), int(b)))
        if pair in known and known[pair] != dist:
            raise ValueError(
                f"{side}: row {row}: sockets {pair[0]} and {pair[1]} {dist:g} m "
                f"apart, but an earlier row says {known[pair]:g} m: give one "
                "distance per pair"
            )
        known[pair] = dist
    return known


def write_socket_measurements(
    path: str | os.PathLike, data: SocketMeasurements
) -> Path:
    """Writes a socket CSV in full precision (reads back bit for bit), and
    its distance file (:func:`distances_path`) when ``data`` has known
    distances or one is there already (then with the header alone when it has
    none, so old distances are never read with new rows): both atomically
    and together (:func:`~rmdrake.io.atomic.atomic_write_files`: a failure
    replaces neither). Returns the socket CSV's path.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_sockets, write_socket_measurements
    >>> data = simulate_sockets(load_robot("rv3sb"), placements=2, seed=0).data
    >>> write_socket_measurements("sockets.csv", data).read_text().splitlines()[0]
    'socket,q1,q2,q3,q4,q5,q6'
    """
    names = ["socket", *(f"q{j}" for j in range(1, data.n_joints + 1))]

    def lines() -> Iterable[str]:
        yield ",".join(names)
        for a in range(0, data.n_rows, CHUNK_LINES):
            rows = slice(a, a + CHUNK_LINES)
            for s, row in zip(
                data.socket[rows].tolist(), data.q[rows].tolist(), strict=True
            ):
                yield ",".join([str(s), *map(repr, row)])

    files = {path: encode_lines(lines())}
    side = distances_path(path)
    if data.distances.shape[0] or os.path.lexists(side):  # no stale distances
        files[side] = encode_lines(
            [DISTANCE_HEADER]
            + [f"{int(a)},{int(b)},{d!r}" for a, b, d in data.distances.tolist()]
        )
    return atomic_write_files(files)[0]


def mukca_hole_files(folder: str | os.PathLike) -> dict[str, tuple[Path, Path]]:
    """{placement name: (hole_0.csv, hole_1.csv)} of MUKCa's folder layout,
    sorted by name: every sub-folder with a ``hole_0.csv`` or ``hole_1.csv``
    entry of any kind (a FIFO or a dangling link is a placement, for its
    reader to refuse, not one to skip).

    Raises:
      ValueError: not a folder, or no placement in it (one line).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder of MUKCa placements")
    holes = {}
    for p in sorted(folder.iterdir(), key=lambda p: p.name):
        pair = (p / "hole_0.csv", p / "hole_1.csv")
        if p.is_dir() and any(os.path.lexists(h) for h in pair):
            holes[p.name] = pair
    if not holes:
        raise ValueError(
            f"{folder}: no placement folder with hole_0.csv and hole_1.csv in it"
        )
    return holes


def read_mukca_sockets(
    folder: str | os.PathLike,
    *,
    distance: float = MUKCA_SOCKET_DISTANCE,
    n_joints: int | None = None,
) -> tuple[SocketMeasurements, list[str]]:
    """Reads MUKCa's recordings: one sub-folder per placement of the plate
    (sorted by name), each with ``hole_0.csv`` and ``hole_1.csv`` (one
    configuration per row, no header, joint angles in rad). Placement p's
    holes become sockets 2p and 2p + 1, ``distance`` (m) apart.

    Returns:
      (the measurements, the placement names in placement order).

    Raises:
      ValueError: a folder without placements, a placement without both
        holes, a hole that is not a regular file (a FIFO, a device, a folder, a
        link that loops or points nowhere), an unreadable or non-numeric file,
        rows of different lengths, angles in degrees (beyond 2 pi + 0.5 rad),
        a ``distance`` not in (0, :data:`MAX_PLATE_DISTANCE`] m.

    Example:

    >>> import pathlib
    >>> import numpy as np
    >>> from rmdrake.calibration import read_mukca_sockets
    >>> place = pathlib.Path("mukca", "p1"); place.mkdir(parents=True)
    >>> for hole in ("hole_0.csv", "hole_1.csv"):
    ...     np.savetxt(place / hole, np.zeros((2, 6)), delimiter=",")
    ...
    >>> data, files = read_mukca_sockets("mukca")
    >>> data.q.shape, files
    ((4, 6), ['p1'])
    """
    holes = mukca_hole_files(folder)
    if not np.isfinite(distance) or not 0 < distance <= MAX_PLATE_DISTANCE:
        raise ValueError(
            f"distance {distance:g} m between the holes of a plate: expected more "
            f"than 0 and at most {MAX_PLATE_DISTANCE:g} m: mm? convert to m"
        )
    names = list(holes)
    socket, q, dist = [], [], []
    for p, name in enumerate(names):
        for hole, path in enumerate(holes[name]):
            why = not_a_regular_file(path)
            if why:
                raise ValueError(f"{path}: {why}; placement {name} needs its holes")
            try:
                rows = np.loadtxt(path, delimiter=",", ndmin=2)
            except (OSError, ValueError) as e:
                raise ValueError(f"{path}: cannot read joint angles: {e}") from None
            if rows.shape[0] == 0:
                raise ValueError(f"{path}: no configuration")
            check_joint_values(rows, None, None, source=str(path))
            if n_joints is not None and rows.shape[1] != n_joints:
                raise ValueError(
                    f"{path}: {rows.shape[1]} columns, but the robot has "
                    f"{n_joints} joints"
                )
            if q and rows.shape[1] != q[0].shape[1]:
                raise ValueError(
                    f"{path}: {rows.shape[1]} columns, the first file had "
                    f"{q[0].shape[1]}"
                )
            q.append(rows)
            socket.append(np.full(rows.shape[0], 2 * p + hole))
        dist.append([2 * p, 2 * p + 1, distance])
    return SocketMeasurements(
        np.concatenate(socket), np.vstack(q), np.array(dist)
    ), names
