"""Excitation design and random trajectories on an arm with prismatic joints:
limits in m on the slides (joints 1 and 4 of the ``boom`` arm) are held."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake import random_fourier_trajectory
from rmdrake.excitation.design import design_excitation


def _inside(trajectory, model) -> None:
    t = np.linspace(0.0, 1.0 / trajectory.base_frequency, 4001)
    lim = model.limits
    q = trajectory.q(t)
    assert np.all(q >= lim.lower) and np.all(q <= lim.upper)
    assert np.all(np.abs(trajectory.qd(t)) <= lim.velocity)
    assert np.all(np.abs(trajectory.qdd(t)) <= lim.acceleration)
    trajectory.check_limits(model)


def test_design_holds_the_slides_limits_in_metres(boom):
    kw = dict(design_samples=40, popsize=4, maxiter=3, n_random=4, progress=False)
    result = design_excitation(boom, seed=3, **kw)
    traj = result.trajectory
    _inside(traj, boom)
    # The slides are used, not frozen: each sweeps over 30 % of its range (m).
    q = traj.q(np.linspace(0.0, 10.0, 2001))
    span = boom.limits.upper - boom.limits.lower
    assert np.all(np.ptp(q, axis=0)[[0, 3]] > 0.3 * span[[0, 3]])
    assert np.isfinite(result.cond) and result.cond < 1e6


def test_random_trajectory_holds_the_slides_limits(boom):
    _inside(random_fourier_trajectory(boom, seed=4, fill=1.0), boom)


def test_q0_outside_a_slide_names_metres(boom):
    with pytest.raises(ValueError, match=r"q0: joint 4 at 0.7 m is not strictly"):
        design_excitation(boom, q0=[0.4, 0, 0, 0.7, 0, 0], progress=False)
