"""Synthetic laser-tracker data: markers on the tool of a (true) robot measured
in an instrument frame I a few metres away.

:func:`simulate_points`, all from one seeded ``numpy.random.default_rng(seed)``:

1. the instrument: its origin at a random direction and a distance uniform in
   ``distance`` (m) from the base origin, its orientation a uniformly random
   rotation (a tracker on a tripod is upright, but nothing in the fit assumes
   it);
2. markers: uniform in a ball of radius ``marker_radius`` (m) about the tool
   origin, in E;
3. poses: joint positions uniform in the middle 80 % of every joint range,
   refused when nearly singular: the 6 x n tool Jacobian (linear rows divided
   by the robot's reach, so rad and m compare) must have its smallest singular
   value above ``min_singular`` times its largest; every marker is measured at
   every pose (pose ids 0..P-1, marker ids 1..M). ``selection="first"`` keeps
   the first P drawn; ``"d-optimal"`` draws ``pool`` x P and keeps P by
   :func:`~rmdrake.calibration.points.pose_selection.select_d_optimal_poses`
   (planned with ``planning_model`` and the markers of step 2);
4. Gaussian noise of standard deviation ``noise`` (m) on each coordinate.

A robot cell (``checker``, :class:`rmdrake.kinematics.clearance.ClearanceChecker`)
also refuses in step 3 the poses closer than ``clearance`` (m) to it; the
draws are the same with or without it, so without a cell the output is
unchanged.

Payloads and elastic joints: with ``payload`` masses (kg) pose i carries the
(i mod M)-th of the M masses (so the poses split about evenly over them, the
draws of 1-4 unchanged) and the points a ``payload`` column. The poses of step
3 are the encoder (motor-side) angles q_m the file records; an elastic true
robot (``compliance``) turns its link side to q_l = q_m + C tau(q_l) under the
pose's payload (:func:`rmdrake.dynamics.compliance.link_angles`), and the markers are
where q_l puts them. Rigid robot: q_l = q_m.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.pose_selection import select_d_optimal_poses
from rmdrake.calibration.points.problem import predict_points
from rmdrake.calibration.simulate import (
    MAX_NOISE_SHARE,
    random_point_poses,
    well_conditioned,
)
from rmdrake.dynamics.compliance import link_angles, payload_choices
from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.kinematics.clearance import ClearanceChecker

__all__ = [
    "MAX_MARKERS",
    "MAX_POINTS",
    "SimulatedPoints",
    "check_point_counts",
    "random_point_poses",
    "simulate_points",
    "well_conditioned",
]


MAX_MARKERS = 100
"""The most markers on the tool (``markers``): a tracker's reflectors or a
motion-capture rigid body carry a few (TIAGo's has 4); each adds 3 unknowns
to every calibration, so 1e6 markers ran out of memory."""
MAX_POINTS = 100_000
"""The most points (``poses`` x ``markers``) simulated: 100 times a large
tracker campaign (hundreds of poses x a few markers), a file of about 20 MB
that ``calibrate`` fits in minutes; 1e7 poses took gigabytes."""


def check_point_counts(poses: int, markers: int) -> None:
    """Refuses counts below 1 or over :data:`MAX_MARKERS` markers or
    :data:`MAX_POINTS` points, before anything is drawn.

    >>> check_point_counts(50, 3)

    Raises:
      ValueError: one line naming the count and its cap.
    """
    if poses < 1 or markers < 1:
        raise ValueError("poses and markers: expected positive counts")
    if markers > MAX_MARKERS:
        raise ValueError(
            f"markers: {markers} is over the cap of {MAX_MARKERS} markers on the "
            "tool (each adds 3 unknowns to the calibration); give a few"
        )
    if float(poses) * markers > MAX_POINTS:
        raise ValueError(
            f"poses x markers: {poses} x {markers} = {float(poses) * markers:.3g} "
            f"points is over the cap of {MAX_POINTS} points (a tracker campaign "
            "measures hundreds of poses); give fewer poses or markers"
        )


@dataclasses.dataclass(frozen=True)
class SimulatedPoints:
    """Output of :func:`simulate_points`.

    Attributes:
      data: the noisy measurements.
      R_IB, p_IB: the true instrument pose (pose of B in I), m.
      markers: (M, 3) true markers in E, m (marker ids 1..M).
      p_I: (N, 3) noise-free readings, m.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_points
    >>> sim = simulate_points(load_robot("rv3sb"), poses=4, markers=3, seed=0)
    >>> sim.markers.shape, sim.R_IB.shape, sim.p_I.shape
    ((3, 3), (3, 3), (12, 3))
    """

    data: PointMeasurements
    R_IB: np.ndarray
    p_IB: np.ndarray
    markers: np.ndarray
    p_I: np.ndarray

    def summary(self) -> str:
        """One line: rows, poses, markers, instrument distance, sample noise,
        payloads (kg)."""
        d = self.data
        noise = np.std(d.p_I - self.p_I)
        loads = ""
        if d.payload is not None:
            loads = f"; payloads {', '.join(f'{m:g}' for m in np.unique(d.payload))} kg"
        return (
            f"{d.n_rows} points: {d.pose_ids.size} poses x {d.marker_ids.size} "
            f"markers; instrument {np.linalg.norm(self.p_IB):.2f} m from the base; "
            f"noise {noise * 1e6:.3g} um (sample){loads}"
        )


def simulate_points(
    model: RobotModel,
    *,
    poses: int = 50,
    markers: int = 3,
    noise: float = 2e-5,
    seed: int = 0,
    distance: tuple[float, float] = (2.0, 5.0),
    marker_radius: float = 0.1,
    payload: float | Sequence[float] | None = None,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
    selection: str = "first",
    pool: int = 4,
    planning_model: RobotModel | None = None,
) -> SimulatedPoints:
    """Simulates tracker measurements of markers on ``model``'s tool (see the
    module docstring; ``distance`` and ``marker_radius`` in m).

    Args:
      payload: kg at the tool, one mass or several (the poses split over them);
        None: no payload column (0 kg).
      checker, clearance: the robot's cell and the distance (m) every pose
        keeps from it; None: no cell.
      selection: ``first``: the first ``poses`` valid poses drawn (plain
        random poses); ``d-optimal``: ``pool`` x ``poses`` drawn, ``poses``
        kept by :func:`~rmdrake.calibration.points.pose_selection.
        select_d_optimal_poses` planned with ``planning_model`` (default
        ``model``; the nominal, as on a real robot).

    Raises:
      ValueError: an unknown ``selection``, a pool below 1, a count below 1
        or over its cap (:func:`check_point_counts`), a negative noise or one over
        :data:`~rmdrake.calibration.simulate.MAX_NOISE_SHARE` of the
        robot's reach, a negative payload or one on a robot without a
        ``payload`` entry.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_points
    >>> data = simulate_points(load_robot("rv3sb"), poses=50, markers=3, seed=0).data
    >>> data.q.shape, data.p_I.shape
    ((150, 6), (150, 3))
    """
    from scipy.spatial.transform import Rotation

    check_point_counts(poses, markers)
    if selection not in ("first", "d-optimal"):
        raise ValueError(
            f"selection: expected 'first' or 'd-optimal', found {selection!r}"
        )
    if pool < 1:
        raise ValueError(f"pool: expected a positive count, found {pool}")
    if noise < 0:
        raise ValueError(f"noise: expected >= 0 m, found {noise}")
    reach = robot_reach(model)
    if noise > MAX_NOISE_SHARE * reach:
        raise ValueError(
            f"noise: {noise:g} m is over {MAX_NOISE_SHARE:g} of the reach of robot "
            f"'{model.name}' ({reach:.3g} m): the points would scatter "
            "beyond the arm; the noise is a standard deviation in m"
        )
    masses = payload_choices(model, payload)
    rng = np.random.default_rng(seed)
    direction = rng.standard_normal(3)
    p_IB = -rng.uniform(*distance) * direction / np.linalg.norm(direction)
    R_IB = Rotation.random(random_state=rng).as_matrix()
    u = rng.standard_normal((markers, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    p_EM = u * marker_radius * rng.uniform(0, 1, (markers, 1)) ** (1 / 3)
    if selection == "d-optimal":
        q = random_point_poses(
            model, pool * poses, rng, checker=checker, clearance=clearance
        )
        q = q[select_d_optimal_poses(planning_model or model, q, p_EM, poses)]
    else:
        q = random_point_poses(model, poses, rng, checker=checker, clearance=clearance)
    pose = np.repeat(np.arange(poses), markers)
    marker = np.tile(np.arange(markers), poses)
    qs = q[pose]
    mass = None if masses is None else masses[pose % masses.size]
    q_l = link_angles(model, qs, 0.0 if mass is None else mass)
    p_I = predict_points(model.table, q_l, p_EM[marker], R_IB, p_IB, sigma=model.sigma)
    measured = p_I + noise * rng.standard_normal(p_I.shape)
    data = PointMeasurements(pose, marker + 1, qs, measured, mass)
    return SimulatedPoints(data, R_IB, p_IB, p_EM, p_I)
