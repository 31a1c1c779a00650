"""Random Fourier trajectories that start at rest inside a robot's limits
(paper eq. 17): starting points, tests and benches, not optimised excitations.
Units: rad, rad/s, rad/s^2 (m, m/s, m/s^2 for a prismatic joint: its limits
are in m, so the same per-joint scaling applies), Hz."""

from __future__ import annotations

import math

import numpy as np

from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.model.robot import RobotModel

__all__ = ["random_fourier_trajectory"]


def random_fourier_trajectory(
    model: RobotModel,
    *,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    fill: float = 0.5,
    seed: int = 0,
) -> FourierTrajectory:
    """A random trajectory that satisfies the paper's eq. 17 (tests, benches,
    starting points; not an optimised excitation).

    Per joint: coefficients uniform in [-1, 1], projected onto the equalities of
    eq. 17 (sum_l a_l = 0, sum_l b_l/(omega_f l) = 0, sum_l omega_f l b_l = 0: the
    motion starts at rest at q0 = the middle of the joint range), then scaled so
    that the eq. 17 bounds on position excursion, velocity and acceleration are
    ``fill`` times the robot's half range, velocity limit and acceleration limit
    (those bounds are sums of amplitudes, so the actual peaks are lower).

    Args:
      harmonics: N >= 3 (two equalities constrain b).
      base_frequency: f in Hz.
      fill: fraction of the limits to use, 0 < fill <= 1.
      seed: seed of the coefficients.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> robot = load_robot("rv3sb")
    >>> traj = random_fourier_trajectory(robot, harmonics=5, base_frequency=0.1, seed=3)
    >>> traj.a.shape, traj.period
    ((6, 5), 10.0)
    """
    if harmonics < 3:
        raise ValueError(f"harmonics: expected >= 3, found {harmonics}")
    if not 0.0 < fill <= 1.0:
        raise ValueError(f"fill: expected 0 < fill <= 1, found {fill}")
    rng = np.random.default_rng(seed)
    n, N = model.n_joints, harmonics
    wl = 2.0 * math.pi * base_frequency * np.arange(1, N + 1)  # omega_f l, 1/s
    a = rng.uniform(-1.0, 1.0, (n, N))
    b = rng.uniform(-1.0, 1.0, (n, N))
    a -= a.mean(axis=1, keepdims=True)
    C = np.vstack([1.0 / wl, wl])  # (2, N): the two equalities on b
    b -= (b @ C.T) @ np.linalg.solve(C @ C.T, C)
    lim = model.limits
    q0 = 0.5 * (lim.lower + lim.upper)
    amp = np.hypot(a, b)
    bounds = np.stack([(amp / wl).sum(1), amp.sum(1), (amp * wl).sum(1)])
    room = np.stack([0.5 * (lim.upper - lim.lower), lim.velocity, lim.acceleration])
    scale = fill * np.min(room / bounds, axis=0)
    return FourierTrajectory(
        base_frequency=base_frequency,
        q0=q0,
        a=a * scale[:, None],
        b=b * scale[:, None],
    )
