"""A robot at a glance: its MDH table, limits and masses as text, and a
Meshcat scene of it moving through a few poses within its limits."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rmdrake.robot import DYNAMIC_KEYS, RobotModel
from rmdrake.systems.visualization import MakeMeshcat, save_robot_poses_html

__all__ = ["robot_summary", "save_robot_html"]


def robot_summary(model: RobotModel) -> str:
    """The MDH table (deg, m), joint ranges (deg), speeds (deg/s), efforts (N m),
    link masses (kg) and payload, as a few lines of text."""
    deg = 180.0 / np.pi
    lines = [f"robot '{model.name}': {model.n_joints} revolute joints"]
    lines.append(
        f"{'row':>4} {'alpha[deg]':>11} {'d[m]':>9} {'theta[deg]':>11} {'r[m]':>9}"
        f" {'beta[deg]':>10} {'q range[deg]':>17} {'v[deg/s]':>9} {'effort[Nm]':>11}"
    )
    for j, (a, d, t, r, b) in enumerate(model.table, start=1):
        row = (
            f"{j:>4} {a * deg:11.3f} {d:9.4f} {t * deg:11.3f} {r:9.4f} {b * deg:10.3f}"
        )
        if j <= model.n_joints:
            lo, hi = model.limits.lower[j - 1] * deg, model.limits.upper[j - 1] * deg
            row += (
                f" {lo:8.1f}..{hi:<7.1f} {model.limits.velocity[j - 1] * deg:9.1f}"
                f" {model.limits.effort[j - 1]:11.4g}"
            )
        else:
            row += "   (tool)"
        lines.append(row)
    if model.dynamics is not None:
        masses = model.dynamics[:, DYNAMIC_KEYS.index("M")]
        lines.append(
            "link masses [kg]: "
            + ", ".join(f"{m:.4g}" for m in masses)
            + f"  (total {masses.sum():.4g})"
        )
    else:
        lines.append("no dynamic parameters")
    if model.payload is not None:
        lines.append(f"payload: {model.payload.mass:.4g} kg")
    return "\n".join(lines)


def save_robot_html(
    model: RobotModel, path: str | os.PathLike, *, port: int | None = None
) -> tuple[Path, int]:
    """Writes a self-contained Meshcat HTML of the robot moving from the middle
    of its joint ranges (clipped zero) to 35 % towards the upper and then the
    lower limits and back; returns (path, number of poses).

    Args:
      port: Meshcat port on localhost (None: the first free one).
    """
    lo, hi = model.limits.lower, model.limits.upper
    mid = np.clip(np.zeros(model.n_joints), lo, hi)
    poses = [mid, np.clip(mid + 0.35 * (hi - mid), lo, hi)]
    poses.append(np.clip(mid + 0.35 * (lo - mid), lo, hi))
    poses.append(mid)
    written = save_robot_poses_html(model, poses, path, meshcat=MakeMeshcat(port))
    return written, len(poses)
