"""Synthetic 6-DoF measurements: a marker frame on the tool of a (true) robot
measured in an instrument frame I a few metres away.

:func:`simulate_poses`, all from one seeded ``numpy.random.default_rng(seed)``:

1. the instrument X_IB: its origin at a random direction and a distance
   uniform in ``distance`` (m) from the base origin, a uniformly random
   orientation;
2. the marker X_FM: a uniformly random orientation, its origin uniform in a
   ball of radius ``marker_radius`` (m) about the flange origin, in F;
3. poses: joint positions uniform in the middle 80 % of every joint range,
   away from singularities
   (:func:`~rmdrake.calibration.points.simulate.random_point_poses`);
   ``selection="first"`` keeps the first P drawn, ``"d-optimal"`` draws
   ``pool`` x P and keeps P by
   :func:`~rmdrake.calibration.poses.pose_selection.select_d_optimal_poses`
   (planned with ``planning_model`` and the X_FM of step 2);
4. Gaussian noise: ``noise_p`` (m) on each position coordinate, and the
   measured orientation R_IM Exp(n) with n of ``noise_r`` (rad) per component
   (a rotation error in the marker frame M).

Example::

    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.loading import load_robot
    sim = simulate_poses(load_robot("rv3sb"), poses=20, seed=1)
    print(sim.summary())
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.pose_selection import select_d_optimal_poses
from rmdrake.calibration.poses.problem import predict_poses
from rmdrake.calibration.poses.so3 import so3_exp_many, so3_log_many
from rmdrake.calibration.simulate import MAX_NOISE_SHARE, random_point_poses
from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.kinematics.clearance import ClearanceChecker

__all__ = ["MAX_POSES", "SimulatedPoses", "simulate_poses"]

MAX_ANGLE_NOISE = 0.1
"""rad: the largest simulated orientation noise std (6 degrees)."""
MAX_POSES = 100_000
"""The most poses simulated (``poses``): 100 times a large campaign of 6-DoF
readings, about 10 s to draw; 1e7 ran for minutes and took gigabytes."""


@dataclasses.dataclass(frozen=True)
class SimulatedPoses:
    """Output of :func:`simulate_poses`.

    Attributes:
      data: the noisy measurements.
      X_IB: (4, 4) the true pose of the base B in I, m.
      X_FM: (4, 4) the true pose of the marker M in the flange F, m.
      X_IM: (N, 4, 4) the noise-free readings, m.

    >>> from rmdrake.model.loading import load_robot
    >>> sim = simulate_poses(load_robot("rv3sb"), poses=4, seed=1)
    >>> sim.data.n_rows, sim.X_IB.shape, sim.X_IM.shape
    (4, (4, 4), (4, 4, 4))
    """

    data: PoseMeasurements
    X_IB: np.ndarray
    X_FM: np.ndarray
    X_IM: np.ndarray

    def summary(self) -> str:
        """One line: readings, instrument distance, sample noises."""
        d = self.data
        dp = np.std(d.p_IM - self.X_IM[:, :3, 3])
        R = np.swapaxes(self.X_IM[:, :3, :3], -1, -2) @ d.R_IM
        dr = np.std(so3_log_many(R))
        return (
            f"{d.n_rows} poses; instrument {np.linalg.norm(self.X_IB[:3, 3]):.2f} m "
            f"from the base; noise {dp * 1e6:.3g} um, {dr * 1e6:.3g} urad (sample)"
        )


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation (a normalised Gaussian quaternion)."""
    w, x, y, z = (u := rng.standard_normal(4)) / np.linalg.norm(u)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def simulate_poses(
    model: RobotModel,
    *,
    poses: int = 40,
    noise_p: float = 2e-5,
    noise_r: float = 5e-5,
    seed: int = 0,
    distance: tuple[float, float] = (2.0, 5.0),
    marker_radius: float = 0.1,
    selection: str = "first",
    pool: int = 4,
    planning_model: RobotModel | None = None,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
) -> SimulatedPoses:
    """Simulates 6-DoF measurements of a marker on ``model``'s flange (see the
    module docstring; ``noise_p``, ``distance`` and ``marker_radius`` in m,
    ``noise_r`` in rad; ``checker`` and ``clearance``: the robot's cell and
    the distance in m every pose keeps from it, as
    :func:`~rmdrake.calibration.points.simulate.simulate_points`'s).

    Raises:
      ValueError: a count or pool below 1, an unknown ``selection``, a
        negative noise, a position noise over
        :data:`~rmdrake.calibration.simulate.MAX_NOISE_SHARE` of the
        reach or an angle noise over :data:`MAX_ANGLE_NOISE`.

    >>> from rmdrake.model.loading import load_robot
    >>> sim = simulate_poses(load_robot("rv3sb"), poses=10, noise_p=2e-5, seed=2)
    >>> sim.data.p_IM.shape, sim.data.r_IM.shape
    ((10, 3), (10, 3))
    """
    if poses < 1 or pool < 1:
        raise ValueError(
            f"poses, pool: expected positive counts, found {poses}, {pool}"
        )
    if poses > MAX_POSES:
        raise ValueError(
            f"poses: {poses} is over the cap of {MAX_POSES} poses (a campaign "
            "measures hundreds); give fewer"
        )
    if selection not in ("first", "d-optimal"):
        raise ValueError(
            f"selection: expected 'first' or 'd-optimal', found {selection!r}"
        )
    if noise_p < 0 or noise_r < 0:
        raise ValueError(f"noise: expected >= 0, found {noise_p} m, {noise_r} rad")
    reach = robot_reach(model)
    if noise_p > MAX_NOISE_SHARE * reach or noise_r > MAX_ANGLE_NOISE:
        raise ValueError(
            f"noise: {noise_p:g} m, {noise_r:g} rad is over {MAX_NOISE_SHARE:g} of "
            f"the reach of robot '{model.name}' ({reach:.3g} m) or over "
            f"{MAX_ANGLE_NOISE:g} rad: noises are standard deviations in m and rad"
        )
    rng = np.random.default_rng(seed)
    direction = rng.standard_normal(3)
    X_IB = np.eye(4)
    X_IB[:3, 3] = -rng.uniform(*distance) * direction / np.linalg.norm(direction)
    X_IB[:3, :3] = _random_rotation(rng)
    X_FM = np.eye(4)
    X_FM[:3, :3] = _random_rotation(rng)
    u = rng.standard_normal(3)
    X_FM[:3, 3] = u / np.linalg.norm(u) * marker_radius * rng.uniform() ** (1 / 3)
    if selection == "d-optimal":
        q = random_point_poses(
            model, pool * poses, rng, checker=checker, clearance=clearance
        )
        keep = select_d_optimal_poses(
            planning_model or model,
            q,
            X_FM,
            poses,
            sigma_p=max(noise_p, 1e-9),
            sigma_r=max(noise_r, 1e-9),
        )
        q = q[keep]
    else:
        q = random_point_poses(model, poses, rng, checker=checker, clearance=clearance)
    X = predict_poses(model.table, q, X_IB, X_FM, sigma=model.sigma)
    p = X[:, :3, 3] + noise_p * rng.standard_normal((poses, 3))
    R = X[:, :3, :3] @ so3_exp_many(noise_r * rng.standard_normal((poses, 3)))
    data = PoseMeasurements(q, p, so3_log_many(R))
    return SimulatedPoses(data, X_IB, X_FM, X)
