"""Socket residuals: the ball's predicted positions against unknown socket
points, and the known distances between sockets; the metrics of the method.

The ball is the robot model's tool point (import the URDF with the ball's link
as the tip). Unknowns ``x = [deltas (k), s_1 .. s_S (3 S)]``: the error
parameters (rad or m, at flat indices into ``table.ravel()``) and one point per
socket in the base frame B (m, ascending socket id). Residuals, m:

* per row i: ``p_BE(q_i) - s_socket(i)`` (3 per row, row-major);
* per known distance (a, b, d): ``w (|s_a - s_b| - d)`` with ``w =
  noise / distance_noise``, so every residual is in units of the seating noise
  (scaled to m) and one least-squares sum weighs both by their stated noise.

The Jacobian is analytic: the error parameters through
:func:`rmdrake.kinematics.forward.point_jacobian`, a socket point's column
-I on its rows, a distance row ``w u^T`` and ``-w u^T`` on its two sockets
(u the unit vector from s_b to s_a).

What sockets cannot see: the socket points absorb any fixed change of the base
frame (its translation and rotation: the sockets are at unknown places), and a
rotation of the tool about the ball does not move it; without a known distance
the length scale is lost too (all lengths and socket points scaled together fit
as well), :func:`scale_column`.

Metrics (MUKCa's): per socket, the **consistency** errors are the distances of
its rows' predicted ball positions from their mean (m: mean absolute and RMS);
per known distance, the **distortion** is the distance between the two socket
means minus the known distance (m). They need no fitted socket point, so they
score held-out placements directly (:func:`socket_metrics`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.calibration.sockets.data import SocketMeasurements
from rmdrake.kinematics.forward import point_jacobian, pose_chunks, tool_points

__all__ = [
    "SocketMetrics",
    "SocketProblem",
    "scale_column",
    "socket_means",
    "socket_metrics",
]


class SocketProblem:
    """Socket residuals with the socket points as unknowns (the module
    docstring).

    Args:
      table: (n+1, 5) nominal MDH table (rad, m).
      data: the socket measurements.
      indices: (k,) flat table indices of the error parameters.
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.
      weight: w of the distance residuals (noise / distance_noise).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import SocketLM, SocketProblem, simulate_sockets
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_sockets(robot, placements=3, per_socket=6, seed=0).data
    >>> lm = SocketLM(robot, params="offsets").fit(data)
    >>> lm.sockets_.shape
    (6, 3)
    """

    def __init__(
        self,
        table: np.ndarray,
        data: SocketMeasurements,
        indices: np.ndarray,
        *,
        sigma: np.ndarray | None = None,
        weight: float = 1.0,
    ) -> None:
        self.table = np.array(table, dtype=np.float64)
        self.sigma = sigma
        self.q = np.asarray(data.q)
        self.indices = np.asarray(indices, dtype=np.intp)
        self.k = int(self.indices.size)
        self.socket = data.socket_index
        self.n_sockets = int(data.socket_ids.size)
        self.pairs = data.distance_index
        self.distance = np.asarray(data.distances[:, 2])
        self.weight = float(weight)

    @property
    def n_unknowns(self) -> int:
        """k + 3 S."""
        return self.k + 3 * self.n_sockets

    def pack(self, deltas: np.ndarray, sockets: np.ndarray) -> np.ndarray:
        """x of the deltas (k,) and socket points (S, 3), m in B."""
        return np.concatenate([np.asarray(deltas, float), np.ravel(sockets)])

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(deltas (k,), socket points (S, 3)) of x."""
        return x[: self.k], x[self.k :].reshape(self.n_sockets, 3)

    def table_of(self, deltas: np.ndarray) -> np.ndarray:
        """(n+1, 5) MDH table of the nominal plus ``deltas``."""
        flat = self.table.ravel().copy()
        flat[self.indices] += deltas
        return flat.reshape(self.table.shape)

    def predicted(self, x: np.ndarray) -> np.ndarray:
        """(N, 3) predicted ball positions in B, m."""
        return tool_points(self.table_of(self.unpack(x)[0]), self.q, sigma=self.sigma)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """(3 N + D,) row residuals (row-major), then the weighted distance
        residuals, m."""
        _, s = self.unpack(x)
        rows = (self.predicted(x) - s[self.socket]).ravel()
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        gaps = np.linalg.norm(s[a] - s[b], axis=1) - self.distance
        return np.concatenate([rows, self.weight * gaps])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(3 N + D, k + 3 S) analytic d residual / d x."""
        k, N, D = self.k, self.q.shape[0], self.pairs.shape[0]
        deltas, s = self.unpack(x)
        table = self.table_of(deltas)
        J = np.zeros((3 * N + D, self.n_unknowns))
        Jr = J[: 3 * N].reshape(N, 3, -1)
        for rows in pose_chunks(1, N) if k else ():
            Jr[rows, :, :k] = point_jacobian(
                table, self.q[rows], self.indices, sigma=self.sigma
            )
        cols = k + 3 * self.socket[:, None] + np.arange(3)  # (N, 3)
        Jr[np.arange(N)[:, None], np.arange(3)[None, :], cols] = -1.0
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        u = s[a] - s[b]
        u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
        Jd = J[3 * N :]
        for c in range(3):
            Jd[np.arange(D), k + 3 * a + c] = self.weight * u[:, c]
            Jd[np.arange(D), k + 3 * b + c] = -self.weight * u[:, c]
        return J

    def start(self, deltas: np.ndarray | None = None) -> np.ndarray:
        """x at ``deltas`` (default 0) with each socket point the mean of its
        rows' predicted ball positions (the best socket points for those
        deltas, without the distances)."""
        deltas = np.zeros(self.k) if deltas is None else np.asarray(deltas, float)
        p = tool_points(self.table_of(deltas), self.q, sigma=self.sigma)
        return self.pack(deltas, socket_means(p, self.socket, self.n_sockets))


def socket_means(p: np.ndarray, socket: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) mean of the points p (N, 3) of each socket index 0..count-1."""
    sums = np.zeros((count, 3))
    np.add.at(sums, socket, p)
    return sums / np.maximum(np.bincount(socket, minlength=count), 1)[:, None]


def scale_column(
    table: np.ndarray, data: SocketMeasurements, *, sigma: np.ndarray | None = None
) -> np.ndarray:
    """(3 N,) the row residuals' change under a common scaling of every length
    (d, r of the table and the socket points) by 1 + e, per unit e, after the
    socket points absorb what they can: the predicted ball positions minus
    their socket means (m). Without a known distance this direction is not
    fixed by the data beyond the residual it leaves (it is exactly absorbed at
    a perfect fit), so it is treated as a nuisance column."""
    p = tool_points(table, data.q, sigma=sigma)
    S = int(data.socket_ids.size)
    return (p - socket_means(p, data.socket_index, S)[data.socket_index]).ravel()


@dataclasses.dataclass(frozen=True)
class SocketMetrics:
    """MUKCa's metrics of one model on socket measurements, m.

    Attributes:
      socket_ids: (S,) the sockets.
      errors: (N,) each row's distance from its socket's mean.
      consistency_mean, consistency_rms: (S,) per socket, mean absolute and
        RMS of ``errors``.
      distortion: (D,) per known distance, the distance of the two socket
        means minus the known distance.
    """

    socket_ids: np.ndarray
    errors: np.ndarray
    consistency_mean: np.ndarray
    consistency_rms: np.ndarray
    distortion: np.ndarray

    @property
    def mean_abs(self) -> float:
        """Mean over rows of ``errors``, m (MUKCa's mean absolute error)."""
        return float(np.mean(self.errors))

    @property
    def rms(self) -> float:
        """RMS over rows of ``errors``, m."""
        return float(np.sqrt(np.mean(self.errors**2)))

    @property
    def max_abs_distortion(self) -> float:
        """Largest |distortion|, m (0 without a known distance)."""
        return float(np.max(np.abs(self.distortion), initial=0.0))


def socket_metrics(
    table: np.ndarray, data: SocketMeasurements, *, sigma: np.ndarray | None = None
) -> SocketMetrics:
    """Consistency and distortion (the module docstring) of the MDH ``table``
    on ``data``.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_sockets, socket_metrics
    >>> robot = load_robot("rv3sb")
    >>> sim = simulate_sockets(robot, placements=2, per_socket=6, noise=0.0, seed=0)
    >>> data = sim.data
    >>> metrics = socket_metrics(robot.table, data)
    >>> bool(metrics.rms < 1e-9)
    True
    """
    p = tool_points(table, data.q, sigma=sigma)
    S, idx = int(data.socket_ids.size), data.socket_index
    means = socket_means(p, idx, S)
    e = np.linalg.norm(p - means[idx], axis=1)
    count = np.maximum(np.bincount(idx, minlength=S), 1)
    mean = np.bincount(idx, e, minlength=S) / count
    rms = np.sqrt(np.bincount(idx, e**2, minlength=S) / count)
    a, b = data.distance_index.T
    dist = np.linalg.norm(means[a] - means[b], axis=1) - data.distances[:, 2]
    return SocketMetrics(data.socket_ids, e, mean, rms, dist)
