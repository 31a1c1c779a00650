"""Synthetic socket data: a ball on the tool of a (true) robot seated by hand in
sockets on plates placed around the arm (MUKCa's method).

:func:`simulate_sockets`, all from one seeded ``numpy.random.default_rng(seed)``;
per placement p of the plate:

1. socket 2p: of the tool points (the ball's centre) of ``CANDIDATES``
   random well conditioned, collision-free configurations
   (:func:`~rmdrake.calibration.simulate.random_point_poses`), in the
   base frame B (m), the one farthest from the sockets already placed: the
   plates spread over the workspace as a user moves the plate around the arm;
2. socket 2p + 1: ``distance`` (m) from it in a uniformly random direction,
   the direction drawn again when that socket cannot be seated (step 3), the
   whole plate drawn again when socket 2p cannot;
3. seating, per socket: ``pool`` x ``per_socket`` random starts (random
   redundancy and wrist orientation, drawn by ``random_point_poses`` without
   the cell), each with its own target: the socket plus Gaussian seating noise
   of std ``noise`` (m) per coordinate (the ball sits that far off the
   socket's centre; the encoders record q exactly); one batched position-only
   IK (:func:`~rmdrake.kinematics.ik.solve_tool_ik`, 3 DOF) from all starts
   at once; kept: the solutions within ``IK_TOLERANCE`` (m) of their target,
   inside the joint limits, well conditioned (the scaled 6 x n tool Jacobian's
   6th singular value, the last when fewer joints, above ``min_singular``
   times its first, as ``random_point_poses`` requires) and, with a cell
   (``checker``), ``clearance`` (m) away from it; the first ``per_socket``
   kept, in start order. Up to ``MAX_BATCHES`` batches per socket; none more
   once a batch has no solution at all (the socket is out of reach).

Rows are ordered by socket (2p, then 2p + 1, placement by placement); the
known distances are the rows ``[2p, 2p + 1, distance]``. The joints are taken
as rigid: an elastic robot's compliance is not simulated (q is the link side).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.calibration.simulate import (
    MAX_NOISE_SHARE,
    random_point_poses,
    well_conditioned,
)
from rmdrake.calibration.sockets.data import MUKCA_SOCKET_DISTANCE, SocketMeasurements
from rmdrake.kinematics.forward import robot_reach, tool_points
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.kinematics.clearance import ClearanceChecker

__all__ = [
    "MAX_CONFIGURATIONS",
    "MAX_PLACEMENTS",
    "SimulatedSockets",
    "check_socket_counts",
    "simulate_sockets",
]

IK_TOLERANCE = 1e-9
"""m: a seated configuration puts the ball within this of its target."""

MAX_BATCHES = 4
"""Batches of ``pool`` x ``per_socket`` IK starts tried per socket."""

MAX_DIRECTIONS = 8
"""Directions of socket 2p + 1 tried per plate before the plate is drawn
again."""

CANDIDATES = 8
"""Random tool points drawn per plate; the one farthest from the sockets
already placed holds its first socket."""

MAX_PLATES = 10
"""Plates drawn per placement before the simulation gives up."""

MAX_PLACEMENTS = 100
"""The most placements of a simulation (MUKCa's real data: 8; a calibration
of 100 fits 600 socket coordinates besides the parameters)."""

MAX_CONFIGURATIONS = 20_000
"""The most configurations of a simulation, placements x 2 x per_socket
(MUKCa's: 497; 20 000 take minutes to seat and a calibration's Jacobian of
them hundreds of MB)."""


@dataclasses.dataclass(frozen=True)
class SimulatedSockets:
    """Output of :func:`simulate_sockets`.

    Attributes:
      data: the measurements (exact joint positions, seated off centre).
      sockets: (S, 3) true socket centres in B, m (row s: socket id s).
      p_B: (N, 3) true ball centres of the rows in B, m (the socket plus the
        row's seating offset).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_sockets
    >>> sim = simulate_sockets(load_robot("rv3sb"), placements=2, per_socket=5, seed=0)
    >>> sim.data.q.shape, sim.sockets.shape
    ((20, 6), (4, 3))
    """

    data: SocketMeasurements
    sockets: np.ndarray
    p_B: np.ndarray

    def summary(self) -> str:
        """One line: rows, placements, sockets, their distance (mm) and the
        sample seating noise (um per coordinate)."""
        d = self.data
        offsets = self.p_B - self.sockets[d.socket_index]
        spacing = ", ".join(f"{v * 1e3:g}" for v in np.unique(d.distances[:, 2]))
        return (
            f"{d.n_rows} configurations: {d.n_placements} placements x 2 sockets "
            f"({spacing} mm apart), {d.n_rows // max(d.socket_ids.size, 1)} per "
            f"socket; seating noise {np.std(offsets) * 1e6:.3g} um (sample)"
        )


def check_socket_counts(placements: int, per_socket: int) -> None:
    """Refuses more than :data:`MAX_PLACEMENTS` placements or
    :data:`MAX_CONFIGURATIONS` configurations (placements x 2 x per_socket),
    before any work.

    Raises:
      ValueError: one line naming the count and its bound.
    """
    if placements > MAX_PLACEMENTS:
        raise ValueError(
            f"placements: {placements} is over the bound of {MAX_PLACEMENTS} "
            "placements of a plate"
        )
    rows = 2 * placements * per_socket
    if rows > MAX_CONFIGURATIONS:
        raise ValueError(
            f"placements x 2 sockets x per_socket = {rows} configurations, over "
            f"the bound of {MAX_CONFIGURATIONS}: fewer placements or per socket"
        )


def _check_arguments(
    model: RobotModel, placements: int, per_socket: int, noise: float, distance: float
) -> None:
    if placements < 1 or per_socket < 1:
        raise ValueError("placements and per_socket: expected positive counts")
    check_socket_counts(placements, per_socket)
    if not np.isfinite(distance) or distance <= 0:
        raise ValueError(f"distance: expected a positive m, found {distance}")
    if not np.isfinite(noise) or noise < 0:
        raise ValueError(f"noise: expected >= 0 m, found {noise}")
    reach = robot_reach(model)
    if noise > MAX_NOISE_SHARE * reach:
        raise ValueError(
            f"noise: {noise:g} m is over {MAX_NOISE_SHARE:g} of the reach of robot "
            f"'{model.name}' ({reach:.3g} m): the noise is a standard deviation "
            "in m"
        )
    if distance > reach:
        raise ValueError(
            f"distance: {distance:g} m is over the reach of robot '{model.name}' "
            f"({reach:.3g} m): the distance between two sockets is in m"
        )


class _Seating:
    """Seats the ball at a socket (step 3 of the module docstring):
    ``seat(s_B, count, rng)`` -> (<= count, n) configurations, rad or m."""

    def __init__(
        self,
        model: RobotModel,
        noise: float,
        pool: int,
        min_singular: float,
        checker: ClearanceChecker | None,
        clearance: float,
        reach: float,
    ) -> None:
        self.model = model
        self.noise = noise
        self.pool = pool
        self.min_singular = min_singular
        self.checker = checker
        self.clearance = clearance
        self.reach = reach

    def __call__(
        self, s_B: np.ndarray, count: int, rng: np.random.Generator
    ) -> np.ndarray:
        model = self.model
        kept = np.zeros((0, model.n_joints))
        for _ in range(MAX_BATCHES):
            starts = random_point_poses(
                model, self.pool * count, rng, min_singular=self.min_singular
            )
            targets = s_B + self.noise * rng.standard_normal((starts.shape[0], 3))
            ik = solve_tool_ik(model, starts, targets)  # q within the limits
            q = ik.q
            good = ik.residual <= IK_TOLERANCE  # |p_E(q) - target|, position only
            good[good] = well_conditioned(model, q[good], self.reach, self.min_singular)
            q = q[good]
            if self.checker is not None and q.shape[0]:
                q = q[self.checker.clear(q, self.clearance)]
            kept = np.vstack([kept, q])
            if kept.shape[0] >= count:
                break
        return kept[:count]


def _farthest(candidates: np.ndarray, placed: list[np.ndarray]) -> np.ndarray:
    """The candidate point (m) farthest from the sockets already placed (the
    first one when none is): plates spread over the workspace, as a user moves
    the plate around the arm."""
    if not placed:
        return candidates[0]
    gaps = np.linalg.norm(candidates[:, None] - np.array(placed)[None], axis=2)
    return candidates[int(np.argmax(gaps.min(axis=1)))]


def _failure(
    p: int,
    best: np.ndarray,
    per_socket: int,
    distance: float,
    checker: ClearanceChecker | None,
    clearance: float,
) -> str:
    """The one-line error of a placement p that found at most ``best`` (2,)
    configurations for its sockets."""
    kind = "seated, well conditioned configurations"
    if checker is not None:
        kind += f" {clearance:g} m clear of the cell"
    if best[0] < per_socket:
        where = f"socket {2 * p}: at most {best[0]} of {per_socket} {kind}"
    else:
        where = (
            f"socket {2 * p + 1}, {distance:g} m from socket {2 * p}: at most "
            f"{best[1]} of {per_socket} {kind} in {MAX_DIRECTIONS} directions"
        )
    return (
        f"placement {p}: {where}, from each of {MAX_PLATES} plates drawn: out of "
        "reach, or ask for fewer configurations per socket"
    )


def simulate_sockets(
    model: RobotModel,
    *,
    placements: int = 4,
    per_socket: int = 25,
    noise: float = 2e-5,
    distance: float = MUKCA_SOCKET_DISTANCE,
    seed: int = 0,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
    pool: int = 2,
    min_singular: float = 0.05,
) -> SimulatedSockets:
    """Simulates a ball on ``model``'s tool point seated in two sockets
    ``distance`` (m) apart per placement of a plate (the module docstring).

    Args:
      model: the true robot; its tool point is the ball's centre.
      placements: plate placements P (sockets 0..2P-1).
      per_socket: seated configurations K per socket.
      noise: seating noise, std in m per coordinate.
      distance: distance between the two sockets of a plate, m.
      seed: seeds every draw.
      checker, clearance: the robot's cell and the distance (m) every
        configuration keeps from it; None: no cell.
      pool: IK starts per configuration wanted, per batch.
      min_singular: the conditioning threshold of ``random_point_poses``.

    Raises:
      ValueError: (one line) a count below 1, over :data:`MAX_PLACEMENTS`
        placements or :data:`MAX_CONFIGURATIONS` configurations, a distance
        not positive or over
        the reach, a negative noise or one over
        :data:`~rmdrake.calibration.simulate.MAX_NOISE_SHARE` of the
        reach; a placement that cannot get ``per_socket`` configurations in
        both its sockets after ``MAX_PLATES`` plates.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_sockets
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_sockets(robot, placements=4, per_socket=25, seed=0).data
    >>> data.q.shape, data.distances.shape
    ((200, 6), (4, 3))
    """
    _check_arguments(model, placements, per_socket, noise, distance)
    if pool < 1:
        raise ValueError(f"pool: expected a positive count, found {pool}")
    rng = np.random.default_rng(seed)
    reach = robot_reach(model)
    seat = _Seating(
        model, float(noise), int(pool), min_singular, checker, clearance, reach
    )
    q_all, sockets = [], []
    for p in range(placements):
        best = np.zeros(2, dtype=np.int64)  # most configurations of each socket
        for _ in range(MAX_PLATES):
            q0 = random_point_poses(
                model,
                CANDIDATES,
                rng,
                min_singular=min_singular,
                checker=checker,
                clearance=clearance,
            )
            s_a = _farthest(tool_points(model.table, q0, sigma=model.sigma), sockets)
            q_a = seat(s_a, per_socket, rng)
            best[0] = max(best[0], q_a.shape[0])
            if q_a.shape[0] < per_socket:
                continue
            for _ in range(MAX_DIRECTIONS):
                u = rng.standard_normal(3)
                s_b = s_a + distance * u / np.linalg.norm(u)
                q_b = seat(s_b, per_socket, rng)
                best[1] = max(best[1], q_b.shape[0])
                if q_b.shape[0] == per_socket:
                    break
            else:
                continue
            break
        else:
            failure = _failure(p, best, per_socket, distance, checker, clearance)
            raise ValueError(failure)
        q_all += [q_a, q_b]
        sockets += [s_a, s_b]
    socket = np.repeat(np.arange(2 * placements), per_socket)
    q = np.vstack(q_all)
    pairs = np.arange(2 * placements).reshape(-1, 2)
    dist = np.column_stack([pairs, np.full(placements, float(distance))])
    data = SocketMeasurements(socket, q, dist)
    p_B = tool_points(model.table, q, sigma=model.sigma)
    return SimulatedSockets(data, np.array(sockets), p_B)
