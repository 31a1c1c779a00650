"""A robot at a glance: its MDH table, limits and masses as text, and a
Meshcat scene of it moving through a few poses within its limits."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rmdrake.model.robot import DYNAMIC_KEYS, RobotModel
from rmdrake.model.scene import Cell
from rmdrake.systems.visualization import save_robot_poses_html, with_own_meshcat

__all__ = ["robot_summary", "save_robot_html"]


def robot_summary(model: RobotModel) -> str:
    """The MDH table (deg, m), each joint's type (R revolute, P prismatic),
    range and speed (deg and deg/s for a revolute joint, m and m/s for a
    prismatic one) and effort (N m or N; ``-`` where the effort limits are
    unknown), link masses (kg) and payload, as a few lines of text.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.pipelines import robot_summary
    >>> text = robot_summary(load_robot("rv3sb"))
    >>> text.splitlines()[0]
    "robot 'rv3sb': 6 revolute joints"
    """
    deg = 180.0 / np.pi
    slide = model.sigma == 1
    kinds = f"{model.n_joints - int(slide.sum())} revolute"
    if slide.any():
        where = ", ".join(str(j + 1) for j in np.flatnonzero(slide))
        kinds += f" and {int(slide.sum())} prismatic joints (prismatic: {where})"
    else:
        kinds += " joints"
    lines = [f"robot '{model.name}': {kinds}"]
    lines.append(
        f"{'row':>4} {'type':>4} {'alpha[deg]':>11} {'d[m]':>9} {'theta[deg]':>11}"
        f" {'r[m]':>9} {'beta[deg]':>10} {'q range':>20} {'speed':>13}"
        f" {'effort':>12}"
    )
    lim = model.limits
    for j, (a, d, t, r, b) in enumerate(model.table, start=1):
        kind = "" if j > model.n_joints else "P" if slide[j - 1] else "R"
        row = f"{j:>4} {kind:>4} {a * deg:11.3f} {d:9.4f} {t * deg:11.3f} {r:9.4f}"
        row += f" {b * deg:10.3f}"
        if j > model.n_joints:
            lines.append(row + "   (tool)")
            continue
        k = j - 1
        scale, unit, force = (1.0, "m", "N") if slide[k] else (deg, "deg", "N m")
        span = f"{lim.lower[k] * scale:.4g}..{lim.upper[k] * scale:.4g} {unit}"
        speed = f"{lim.velocity[k] * scale:.4g} {unit}/s"
        effort = "-" if lim.effort is None else f"{lim.effort[k]:.4g} {force}"
        lines.append(f"{row} {span:>20} {speed:>13} {effort:>12}")
    if model.dynamics is not None:
        masses = model.dynamics[:, DYNAMIC_KEYS.index("M")]
        lines.append(
            "link masses [kg]: "
            + ", ".join(f"{m:.4g}" for m in masses)
            + f"  (total {masses.sum():.4g})"
        )
    else:
        lines.append("no dynamic parameters (a kinematic-only model)")
    if not model.has_effort_limits:
        lines.append("no joint effort limits (a kinematic-only model)")
    if model.payload is not None:
        lines.append(f"payload: {model.payload.mass:.4g} kg")
    lines += _transmission_lines(model)
    return "\n".join(lines)


def _transmission_lines(model: RobotModel) -> list[str]:
    """The transmission's gear ratios and each coupled motor's speed (in
    joint-reflected units) and terms, e.g. ``motor 6 turns at 50 (qd5 +
    qd6): Iam 0.008 kg m^2, fvm 0.3 N m s/rad, fcm 0.6 N m``; none without."""
    tr = model.transmission
    if tr is None:
        return []
    out = ["gear ratios (motor/joint): " + ", ".join(f"{r:g}" for r in tr.ratio)]
    terms = model.motor_terms
    for i, m in enumerate(tr.coupled):
        c = tr.coupling[m]
        speed = " + ".join(
            f"qd{j + 1}" if c[j] == 1 else f"{c[j]:g} qd{j + 1}"
            for j in np.flatnonzero(c)
        )
        line = f"motor {m + 1} turns at {tr.ratio[m]:g} ({speed})"
        if terms is not None:
            Iam, fvm, fcm = terms[i]
            line += (
                f": Iam {Iam:.4g} kg m^2, fvm {fvm:.4g} N m s/rad, fcm {fcm:.4g} N m"
            )
        out.append(line)
    return out


def save_robot_html(
    model: RobotModel,
    path: str | os.PathLike,
    *,
    port: int | None = None,
    cell: Cell | None = None,
) -> tuple[Path, int]:
    """Writes a self-contained Meshcat HTML of the robot moving from the middle
    of its joint ranges (clipped zero) to 35 % towards the upper and then the
    lower limits and back; returns (path, number of poses).

    Args:
      port: Meshcat port on localhost (None: the first free one). The server
        lives only while the page is drawn, so its URL is not printed (it
        would be dead before anyone opened it): the saved page is the view.
      cell: the robot's cell, drawn with it (shapes posed in the base frame).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import load_robot
    >>> from rmdrake.pipelines import save_robot_html
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path, poses = save_robot_html(load_robot("rv3sb"), Path(tmp, "rv3sb.html"))
    ...     print(path.name, poses > 1)
    ...
    rv3sb.html True
    """
    lo, hi = model.limits.lower, model.limits.upper
    mid = np.clip(np.zeros(model.n_joints), lo, hi)
    poses = [mid, np.clip(mid + 0.35 * (hi - mid), lo, hi)]
    poses.append(np.clip(mid + 0.35 * (lo - mid), lo, hi))
    poses.append(mid)
    written = with_own_meshcat(
        save_robot_poses_html,
        model,
        poses,
        path,
        port=port,
        cell=cell,
    )
    return written, len(poses)
