"""Matplotlib figures of rmdrake, written as PNG files.

Every function takes arrays in SI units, draws in display units (mm, deg) and
writes a PNG atomically. Figures are built with matplotlib's object API
(``matplotlib.figure.Figure``), not pyplot, so importing this module sets no
backend and opens no window: the user's ``MPLBACKEND`` and pyplot state are
left alone.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rmdrake.dynamics.compliance import link_angles
from rmdrake.io.atomic import atomic_write_bytes
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.robot import RobotModel

__all__ = [
    "magnification",
    "plot_calibration_errors",
    "plot_deflection_field",
    "plot_cartesian_path",
    "plot_joint_trajectories",
    "plot_path_tracking",
    "plot_payload_errors",
    "plot_torque_comparison",
    "save_figure",
]


def save_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Writes ``fig`` as PNG to ``path`` atomically (120 dpi)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    return atomic_write_bytes(path, buf.getvalue())


def plot_calibration_errors(
    before: np.ndarray,
    after: Mapping[str, np.ndarray],
    path: str | os.PathLike,
    *,
    title: str = "Tool position error before and after calibration",
    reference: Mapping[str, float] | None = None,
) -> Path:
    """Paper Fig. 3: per-pose tool position error before and after calibration.

    Args:
      before: (N,) errors of the nominal model at N held-out poses, m.
      after: method label -> (N,) errors of its calibrated model, m.
      path: PNG file to write.
      title: figure title.
      reference: optional label -> level (m) drawn as dashed lines (e.g. the
        paper's 1.6 mm before and 0.3 mm after).

    Returns:
      The written path.
    """
    before = np.asarray(before) * 1e3
    fig = Figure(figsize=(8, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    idx = np.arange(1, before.size + 1)
    top, bottom = axes
    top.plot(idx, before, "o-", ms=3, lw=0.8, color="tab:red", label="before")
    colours = ("tab:green", "tab:blue", "tab:purple", "tab:orange")
    for (label, err), c in zip(after.items(), colours, strict=False):
        top.plot(idx, np.asarray(err) * 1e3, "o-", ms=3, lw=0.8, color=c, label=label)
        bottom.plot(
            idx, np.asarray(err) * 1e3, "o-", ms=3, lw=0.8, color=c, label=label
        )
    for label, level in (reference or {}).items():
        top.axhline(level * 1e3, ls="--", lw=0.8, color="0.4")
        top.text(idx[0], level * 1e3, f"{label} ", va="bottom", ha="left", fontsize=8)
    top.set_ylabel("position error [mm]")
    top.set_title(title)
    top.legend(loc="upper right", fontsize=8, ncol=2, framealpha=0.9)
    top.grid(alpha=0.3)
    bottom.set_yscale("log")
    bottom.set_ylabel("after calibration [mm], log")
    bottom.set_xlabel("held-out pose")
    bottom.legend(loc="upper right", fontsize=8, ncol=3, framealpha=0.9)
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_joint_trajectories(
    t: np.ndarray,
    q: np.ndarray,
    path: str | os.PathLike,
    *,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    sigma: np.ndarray | None = None,
    title: str = "Joint position excitation trajectories (paper Fig. 4)",
) -> Path:
    """Paper Fig. 4: q_j(t) of every joint (deg; a prismatic joint, ``sigma``
    1, in mm) with the joint limits dashed.

    Args:
      t: (N,) time, s; q: (N, n) joint positions, rad or m; lower, upper: (n,)
      rad or m; sigma: (n,) joint types (None: all revolute).
    """
    fig = Figure(figsize=(8, 4.5))
    ax = fig.subplots()
    slide = np.zeros(q.shape[1], bool) if sigma is None else np.asarray(sigma) == 1
    for j in range(q.shape[1]):
        scale = 1e3 if slide[j] else 180.0 / np.pi
        unit = "mm" if slide[j] else "deg"
        (line,) = ax.plot(t, scale * q[:, j], label=f"q{j + 1} [{unit}]")
        if lower is not None and upper is not None:
            for lim in (lower[j], upper[j]):
                ax.axhline(scale * lim, color=line.get_color(), ls=":", lw=0.7)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(
        "joint position [deg or mm]" if slide.any() else "joint position [deg]"
    )
    ax.set_title(title)
    ax.legend(ncol=min(q.shape[1], 7), fontsize=8, loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_cartesian_path(
    t: np.ndarray,
    p_BE: np.ndarray,
    path: str | os.PathLike,
    *,
    title: str = "End-effector Cartesian position (paper Fig. 6)",
) -> Path:
    """Paper Fig. 6: the tool-frame origin p_BE(t) (mm) as x, y, z against time
    and as a 3-D path.

    Args:
      t: (N,) time, s; p_BE: (N, 3) tool position in the base frame, m.
    """
    fig = Figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1)
    for k, name in enumerate("xyz"):
        ax.plot(t, 1e3 * p_BE[:, k], label=name)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position [mm]")
    ax.legend()
    ax.grid(alpha=0.3)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.plot(*(1e3 * p_BE.T), lw=1.0)
    ax3.scatter(*(1e3 * p_BE[0]), color="k", s=12, label="start")
    ax3.set_xlabel("x [mm]")
    ax3.set_ylabel("y [mm]")
    ax3.set_zlabel("z [mm]")
    ax3.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_torque_comparison(
    t: np.ndarray,
    measured: np.ndarray,
    estimated: Mapping[str, np.ndarray],
    path: str | os.PathLike,
    *,
    title: str = "Estimated vs measured joint torques (paper Fig. 7)",
    sigma: np.ndarray | None = None,
) -> Path:
    """Paper Fig. 7: measured torque and each method's estimate, per joint.

    Args:
      t: (N,) time, s; measured: (N, n) N m (N on a prismatic joint, ``sigma``
        1); estimated: label -> (N, n), the same units; sigma: (n,) joint types
        (None: all revolute).
    """
    n = measured.shape[1]
    rows = int(np.ceil(n / 2))
    fig = Figure(figsize=(11, 2.2 * rows))
    axes = fig.subplots(rows, 2, sharex=True)
    for j, ax in enumerate(np.ravel(axes)):
        if j >= n:
            ax.set_visible(False)
            continue
        ax.plot(t, measured[:, j], color="0.6", lw=1.6, label="measured")
        for label, tau in estimated.items():
            ax.plot(t, tau[:, j], lw=0.9, label=label)
        slide = sigma is not None and sigma[j] == 1
        ax.set_ylabel(f"f{j + 1} [N]" if slide else f"tau{j + 1} [N m]")
        ax.grid(alpha=0.3)
    np.ravel(axes)[0].legend(fontsize=7, ncol=2)
    for ax in np.ravel(axes)[-2:]:
        ax.set_xlabel("time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def magnification(extent: float, deviation: float) -> float:
    """The factor 1, 2 or 5 times a power of ten that makes ``deviation``
    (m) at most 20 % of ``extent`` (m), as large as possible: how much to
    magnify a path's deviations to draw them on the path."""
    raw = 0.2 * extent / max(deviation, 1e-12)
    power = 10.0 ** np.floor(np.log10(raw))
    return float(power * max(f for f in (1.0, 2.0, 5.0) if f * power <= raw))


def plot_path_tracking(
    panels: Mapping[str, tuple[np.ndarray, np.ndarray, Mapping[str, np.ndarray]]],
    path: str | os.PathLike,
    *,
    title: str,
) -> Path:
    """Commanded vs attained tool paths (top row) and the error along each
    path (bottom row, log scale), one column per panel.

    Args:
      panels: title -> (u (K,) fraction of the path done; target (K, 3) the
        commanded points in the path's frame P (x, y in its plane, z out of
        it), m; label -> (K, 3) the attained points in P, m). The top row
        draws x, y with each attained point's deviation from its target
        magnified so that the largest spans 20 % of the path's extent (a
        factor 1, 2 or 5 times a power of ten, stated in the panel's title);
        the bottom row the 3-D distance.
      path: PNG file to write.
    """
    fig = Figure(figsize=(5.5 * len(panels), 9.0))
    axes = np.reshape(fig.subplots(2, len(panels), squeeze=False), (2, -1))
    colours = ("tab:red", "tab:orange", "tab:olive", "tab:cyan", "tab:purple")
    colours += ("tab:green", "k")  # the last two: full compensation, oracle
    for col, (name, (u, target, attained)) in enumerate(panels.items()):
        top, bottom = axes[0, col], axes[1, col]
        worst = max(np.abs(p - target).max() for p in attained.values())
        magnify = magnification(np.ptp(target[:, :2], axis=0).max(), worst)
        top.plot(*(1e3 * target[:, :2].T), color="0.6", lw=3.0, label="commanded")
        for (label, p), c in zip(attained.items(), colours, strict=False):
            shown = target + magnify * (p - target)
            top.plot(*(1e3 * shown[:, :2].T), lw=0.9, color=c, label=label)
            error = np.linalg.norm(p - target, axis=1)
            bottom.semilogy(u, 1e3 * np.maximum(error, 1e-9), lw=0.9, color=c)
        top.set_aspect("equal")
        top.set_title(f"{name}\n(deviations x{magnify:g})", fontsize=9)
        top.set_xlabel("path plane x [mm]")
        top.set_ylabel("path plane y [mm]")
        top.grid(alpha=0.3)
        bottom.set_xlabel("fraction of the path")
        bottom.set_ylabel("tool path error [mm]")
        bottom.grid(alpha=0.3, which="both")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle(title)
    fig.tight_layout(rect=(0.0, 0.06, 1.0, 1.0))
    return save_figure(fig, path)


def plot_payload_errors(
    errors: Mapping[str, Mapping[float, np.ndarray]],
    path: str | os.PathLike,
    *,
    title: str = "Static tool error per target, by model and payload",
    floor: float = 1e-4,
) -> Path:
    """Tool position error per target for each model (label) and payload.

    Args:
      errors: label -> payload mass (kg) -> (K,) errors at K targets, m.
      path: PNG file to write.
      floor: smallest error drawn, mm (round-off sits on it).
    """
    masses = sorted({m for by_mass in errors.values() for m in by_mass})
    fig = Figure(figsize=(8, 2.6 * len(masses) + 0.6))
    axes = np.atleast_1d(fig.subplots(len(masses), 1, sharex=True, squeeze=False))[:, 0]
    colours = ("tab:red", "tab:orange", "tab:green", "tab:blue", "tab:purple")
    for ax, mass in zip(axes, masses, strict=True):
        for (label, by_mass), c in zip(errors.items(), colours, strict=False):
            if mass in by_mass:
                e = np.maximum(np.asarray(by_mass[mass]) * 1e3, floor)
                idx = np.arange(1, e.size + 1)
                ax.plot(idx, e, "o-", ms=3, lw=0.8, color=c, label=label)
        ax.set_yscale("log")
        ax.set_ylim(bottom=0.5 * floor)
        ax.set_ylabel("error [mm], log")
        ax.set_title(f"payload {mass:g} kg", fontsize=9)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(loc="lower left", fontsize=7, ncol=2, framealpha=0.9)
    axes[-1].set_xlabel("held-out target")
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_deflection_field(
    model: RobotModel, payload_mass: float, path: str | os.PathLike, *, grid: int = 41
) -> Path:
    """Tool deflection of an elastic robot (``model.compliance``) holding
    ``payload_mass`` kg over its gravity-loaded joints: joints 2 and 3 over
    their ranges (deg), the others at 0 (clipped to their limits); the colour is
    the distance (mm) from the rigid tool position at those motor angles to
    where the tool rests."""
    lo, hi = model.limits.lower, model.limits.upper
    a, b = np.meshgrid(np.linspace(lo[1], hi[1], grid), np.linspace(lo[2], hi[2], grid))
    q = np.tile(np.clip(np.zeros(model.n_joints), lo, hi), (a.size, 1))
    q[:, 1], q[:, 2] = a.ravel(), b.ravel()
    p = tool_points(model.table, q, sigma=model.sigma)
    rest = tool_points(
        model.table, link_angles(model, q, payload_mass), sigma=model.sigma
    )
    d = (np.linalg.norm(rest - p, axis=1) * 1e3).reshape(a.shape)
    fig = Figure(figsize=(7, 5.5))
    ax = fig.subplots()
    art = ax.contourf(np.rad2deg(a), np.rad2deg(b), d, levels=20, cmap="viridis")
    fig.colorbar(art, ax=ax, label="tool deflection [mm]")
    ax.set_xlabel("joint 2 [deg]")
    ax.set_ylabel("joint 3 [deg]")
    ax.set_title(
        f"{model.name}: tool deflection holding {payload_mass:g} kg "
        f"(mean {d.mean():.0f} mm, max {d.max():.0f} mm)"
    )
    fig.tight_layout()
    return save_figure(fig, path)
