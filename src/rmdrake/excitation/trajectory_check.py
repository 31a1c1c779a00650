"""Does a joint log follow the excitation it is said to follow?

``identify --trajectory T.yaml`` names the Fourier excitation a log was
recorded on. The log's positions q(t) are compared with the trajectory's q at
the log's time stamps, after the time base is aligned: the log may start
anywhere (Unix time stamps, a standstill cut, ``--trim``), so the trajectory
is shifted by the offset in [0, one period) of least squared difference
(a grid of :data:`OFFSET_STEPS` offsets over the period, then a grid ten times
finer around the best). Each joint's RMS difference at that offset must stay
within its tolerance: :data:`MAX_FOLLOW_SHARE` of the trajectory's motion on
that joint (its RMS about its mean), at least :data:`FOLLOW_FLOOR` (rad, or
:data:`FOLLOW_FLOOR_PRISMATIC` m).

Tuned on: the Drake-simulated logs of rv3sb and demo_rh (a controller model
with 50 % wrong dynamics, torque noise, encoder steps) and of
demo_rh_elastic (motor side, low bandwidth) follow their trajectory within
0.2-2 % of the motion; the real KUKA LWR4+ runs 1 and 2 (one trajectory run
twice, FloBaRoID) are 0.1 % apart, while run 3 (another trajectory) is 120-170
% from run 1. Another rate (0.1 Hz logged against a 0.25 Hz design), a
100x amplitude or an all-zero trajectory are 100 % and more.
"""

from __future__ import annotations

import numpy as np

from rmdrake.excitation.trajectory import FourierTrajectory

__all__ = [
    "FOLLOW_FLOOR",
    "FOLLOW_FLOOR_PRISMATIC",
    "MAX_FOLLOW_SHARE",
    "OFFSET_STEPS",
    "check_follows",
    "follow_error",
]

MAX_FOLLOW_SHARE = 0.1
"""The largest RMS difference between the logged and the designed q of a
joint, as a share of the joint's designed motion (RMS about its mean)."""
FOLLOW_FLOOR = 0.01
"""rad: the tolerance of a revolute joint that hardly moves (tracking error
and encoder offsets of a joint held still)."""
FOLLOW_FLOOR_PRISMATIC = 0.005
"""m: the same for a prismatic joint."""
OFFSET_STEPS = 400
"""Time offsets tried over one period (then ten times finer around the
best)."""
_COMPARED = 2000  # samples compared at most, evenly spaced


def follow_error(
    trajectory: FourierTrajectory, t: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, float]:
    """(per joint RMS difference (n,) rad or m, the time offset s) between the
    logged ``q`` (N, n) at times ``t`` (N,) s and ``trajectory``'s q at
    ``t - t[0] + offset``, for the offset in [0, one period) that minimises
    the summed squared difference (module docstring)."""
    t = np.asarray(t, dtype=np.float64).ravel()
    q = np.asarray(q, dtype=np.float64)
    keep = np.unique(np.linspace(0, t.size - 1, min(t.size, _COMPARED)).astype(int))
    t, q = t[keep] - t[0], q[keep]
    period = trajectory.period

    def cost(offsets: np.ndarray) -> np.ndarray:
        out = np.empty(offsets.size)
        for i, tau in enumerate(offsets):
            out[i] = float(np.sum((trajectory.q(t + tau) - q) ** 2))
        return out

    coarse = np.arange(OFFSET_STEPS) * (period / OFFSET_STEPS)
    best = float(coarse[int(np.argmin(cost(coarse)))])
    step = period / OFFSET_STEPS
    fine = best + np.linspace(-step, step, 21)
    best = float(fine[int(np.argmin(cost(fine)))]) % period
    diff = np.sqrt(np.mean((trajectory.q(t + best) - q) ** 2, axis=0))
    return diff, best


def check_follows(
    trajectory: FourierTrajectory,
    t: np.ndarray,
    q: np.ndarray,
    *,
    sigma: object = None,
    what: str = "log",
    source: str = "trajectory",
) -> None:
    """Refuses a log ``q`` (N, n) at times ``t`` (N,) s that does not follow
    ``trajectory`` (module docstring); ``sigma`` (n,): 1 for a prismatic
    joint (m); ``what`` names the log and ``source`` the trajectory in the
    message.

    Raises:
      ValueError: one line: another joint count, or the joint furthest over
        its tolerance with its RMS difference, the tolerance and the time
        offset.
    """
    q = np.asarray(q, dtype=np.float64)
    n = q.shape[1]
    if trajectory.n_joints != n:
        raise ValueError(
            f"{source}: {trajectory.n_joints} joints, the {what} {n}: not the "
            "excitation of this log"
        )
    diff, offset = follow_error(trajectory, t, q)
    ts = np.arange(OFFSET_STEPS) * (trajectory.period / OFFSET_STEPS)
    motion = trajectory.q(ts).std(axis=0)
    slide = np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1
    floor = np.where(slide, FOLLOW_FLOOR_PRISMATIC, FOLLOW_FLOOR)
    tolerance = np.maximum(MAX_FOLLOW_SHARE * motion, floor)
    over = diff / tolerance
    j = int(np.argmax(over))
    if over[j] > 1.0:
        unit = "m" if slide[j] else "rad"
        why = f"{100 * MAX_FOLLOW_SHARE:g} % of its {motion[j]:.3g} {unit} motion"
        if tolerance[j] == floor[j]:
            why = f"a joint moving {motion[j]:.3g} {unit}: the floor"
        raise ValueError(
            f"{what} does not follow {source}: joint {j + 1} differs by "
            f"{diff[j]:.3g} {unit} RMS from its designed q (tolerance "
            f"{tolerance[j]:.3g} {unit}, {why}; best time offset {offset:.3g} s); "
            "another excitation, rate or amplitude: give the trajectory the log "
            "was recorded on"
        )
