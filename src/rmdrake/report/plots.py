"""Matplotlib figures of rmdrake, written as PNG files.

Every function takes arrays in SI units, draws in display units (mm, deg) and
writes a PNG atomically. Figures are built with matplotlib's object API
(``matplotlib.figure.Figure``), not pyplot, so importing this module sets no
backend and opens no window: the user's ``MPLBACKEND`` and pyplot state are
left alone.
"""

from __future__ import annotations

import io
import math
import os
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.dynamics.compliance import link_angles
from rmdrake.io.atomic import atomic_write_bytes
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:  # types only: imported where used
    import datetime

    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    from rmdrake.dynamics.history import HistoryTrend


__all__ = [
    "calibration_errors_figure",
    "coincide",
    "deflection_field_figure",
    "fitted_suptitle",
    "history_figure",
    "linear_limits",
    "log_limits",
    "magnification",
    "payload_errors_figure",
    "plot_calibration_errors",
    "plot_deflection_field",
    "plot_history",
    "plot_cartesian_path",
    "plot_joint_trajectories",
    "plot_path_tracking",
    "plot_payload_errors",
    "plan_errors_figure",
    "plot_plan_errors",
    "plot_socket_placements",
    "plot_torque_comparison",
    "save_figure",
    "series_styles",
    "socket_placements_figure",
    "wrap_title",
]


def save_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Writes ``fig`` as PNG to ``path`` atomically (120 dpi), cropped to what
    it draws plus a 0.1 inch pad (``bbox_inches="tight"``): no title, label or
    legend outside the canvas is cut."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120, bbox_inches="tight", pad_inches=0.1)
    return atomic_write_bytes(path, buf.getvalue())


def wrap_title(title: str, fig: Figure, fontsize: float) -> str:
    """``title`` with each of its lines wrapped to fit the width of ``fig`` at
    ``fontsize`` points (an average glyph taken as 0.55 em wide, 90 % of the
    width used); its own line breaks are kept."""
    width_pt = 0.9 * fig.get_figwidth() * 72.0
    chars = max(20, int(width_pt / (0.55 * fontsize)))
    return "\n".join(
        textwrap.fill(line, chars) if line else line for line in title.split("\n")
    )


def fitted_suptitle(fig: Figure, title: str, fontsize: float = 11.0) -> Text:
    """Sets ``title`` as ``fig``'s suptitle, wrapped to the figure's width
    (:func:`wrap_title`); with a constrained layout (``layout="constrained"``)
    the axes make room for it."""
    return fig.suptitle(wrap_title(title, fig, fontsize), fontsize=fontsize)


#: Two series closer than this share of their values coincide on the page.
COINCIDE_RTOL = 0.01


def coincide(a: np.ndarray, b: np.ndarray, rtol: float = COINCIDE_RTOL) -> bool:
    """Whether two series of the same length would be drawn over each other:
    every |a_i - b_i| at most ``rtol`` times max(|a_i|, |b_i|) (or both 0)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        return False
    return bool(np.all(np.abs(a - b) <= rtol * np.maximum(np.abs(a), np.abs(b))))


#: How a series that coincides with k earlier ones is drawn (k = 0, 1, 2, ...):
#: each later one with a larger open marker and another dash, so the earlier
#: ones show through it.
_COINCIDENT_STYLES: tuple[dict[str, object], ...] = (
    {"marker": "o", "ms": 3, "ls": "-", "lw": 0.8},
    {"marker": "s", "ms": 7, "ls": "--", "lw": 1.1, "mfc": "none", "mew": 1.0},
    {"marker": "^", "ms": 9, "ls": ":", "lw": 1.3, "mfc": "none", "mew": 1.0},
    {"marker": "D", "ms": 10, "ls": "-.", "lw": 1.1, "mfc": "none", "mew": 1.0},
)


def series_styles(
    series: Mapping[str, np.ndarray], *, unit: str = "", rtol: float = COINCIDE_RTOL
) -> dict[str, tuple[dict[str, object], str]]:
    """Line style (``Axes.plot`` keywords) and legend label of each series
    (label -> values, all in ``unit``): a series that :func:`coincide` s with
    earlier ones gets the next larger open marker and dash, so that both stay
    visible, and a label saying which one it coincides with and their largest
    difference (in ``unit``)."""
    out: dict[str, tuple[dict[str, object], str]] = {}
    labels = list(series)
    for k, label in enumerate(labels):
        same = [m for m in labels[:k] if coincide(series[label], series[m], rtol)]
        style = _COINCIDENT_STYLES[min(len(same), len(_COINCIDENT_STYLES) - 1)]
        text = label
        if same:
            first = same[0]
            gap = float(np.max(np.abs(np.asarray(series[label]) - series[first])))
            text = f"{label} (coincides with {first}: max diff {gap:.2g} {unit})"
        out[label] = (dict(style), text)
    return out


def log_limits(values: np.ndarray, margin: float = 0.06) -> tuple[float, float]:
    """Log-axis limits (lo, hi) holding every positive value, each end widened
    by ``margin`` of the decades spanned (at least a factor 1.3)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return 0.1, 10.0
    lo, hi = float(v.min()), float(v.max())
    pad = max(1.3, (hi / lo) ** margin)
    return lo / pad, hi * pad


def linear_limits(values: np.ndarray, margin: float = 0.05) -> tuple[float, float]:
    """Linear-axis limits (lo, hi) holding every finite value, each end widened
    by ``margin`` of the span (of 1 when all values are equal)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    pad = margin * ((hi - lo) or max(abs(hi), 1.0))
    return lo - pad, hi + pad


def calibration_errors_figure(
    before: np.ndarray,
    after: Mapping[str, np.ndarray],
    *,
    title: str = "Tool position error before and after calibration",
    reference: Mapping[str, float] | None = None,
) -> Figure:
    """The figure of :func:`plot_calibration_errors` (same arguments), not
    written: top, every series (mm, linear); bottom, the calibrated ones (mm,
    log). The axis limits hold every point with a margin; one legend, outside
    the axes on the right, names each series, and a series that coincides with
    another (:func:`coincide`) is drawn with a larger open marker and another
    dash and says so in the legend (difference in mm)."""
    from matplotlib.figure import Figure

    series = {"before": np.asarray(before, float) * 1e3}
    series.update({k: np.asarray(v, float) * 1e3 for k, v in after.items()})
    styles = series_styles(series, unit="mm")
    colours = ("tab:red", "tab:green", "tab:blue", "tab:purple", "tab:orange")
    colour = dict(zip(series, colours, strict=False))
    n = max(v.size for v in series.values())
    idx_all = np.arange(1, n + 1)
    calibrated = [v for k, v in series.items() if k != "before"]
    lo, hi = log_limits(np.concatenate(calibrated)) if calibrated else (0.1, 10.0)
    zeros = any(np.any(v <= 0) for v in calibrated)
    fig = Figure(figsize=(10.5, 6.5), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    for label, values in series.items():
        style, text = styles[label]
        idx = idx_all[: values.size]
        top.plot(idx, values, color=colour.get(label), label=text, **style)
        if label == "before":
            continue
        positive = values > 0
        bottom.plot(idx[positive], values[positive], color=colour.get(label), **style)
        if not positive.all():  # a log axis cannot draw 0: at its floor, said so
            bottom.plot(
                idx[~positive],
                np.full(int((~positive).sum()), lo),
                "v",
                ms=6,
                color=colour.get(label),
                label=f"{label}: 0 (exact), drawn at the floor {lo:.2g} mm",
            )
    levels = [1e3 * float(v) for v in (reference or {}).values()]
    for label, level in zip((reference or {}), levels, strict=True):
        top.axhline(level, ls="--", lw=0.8, color="0.4")
        top.text(idx_all[0], level, f"{label} ", va="bottom", ha="left", fontsize=8)
    top.set_xlim(*linear_limits(np.array([1.0, float(n)]), margin=0.02))
    everything = np.concatenate([*series.values(), levels, [0.0]])
    top.set_ylim(*linear_limits(everything))
    bottom.set_yscale("log")
    bottom.set_ylim(lo / 2.0 if zeros else lo, hi)
    top.set_ylabel("position error [mm]")
    top.grid(alpha=0.3)
    bottom.set_ylabel("after calibration [mm], log")
    bottom.set_xlabel("held-out pose")
    bottom.grid(alpha=0.3)
    handles, labels = top.get_legend_handles_labels()
    extra_h, extra_l = bottom.get_legend_handles_labels()
    fig.legend(
        handles + extra_h,
        [textwrap.fill(t, 30) for t in labels + extra_l],
        loc="outside right upper",
        fontsize=8,
    )
    fitted_suptitle(fig, title)
    return fig


def plot_calibration_errors(
    before: np.ndarray,
    after: Mapping[str, np.ndarray],
    path: str | os.PathLike,
    *,
    title: str = "Tool position error before and after calibration",
    reference: Mapping[str, float] | None = None,
) -> Path:
    """Paper Fig. 3: per-pose tool position error before and after calibration
    (:func:`calibration_errors_figure`).

    Args:
      before: (N,) errors of the nominal model at N held-out poses, m.
      after: method label -> (N,) errors of its calibrated model, m.
      path: PNG file to write.
      title: figure title (wrapped to the figure's width).
      reference: optional label -> level (m) drawn as dashed lines (e.g. the
        paper's 1.6 mm before and 0.3 mm after).

    Returns:
      The written path.
    """
    fig = calibration_errors_figure(before, after, title=title, reference=reference)
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
    from matplotlib.figure import Figure

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
    from matplotlib.figure import Figure

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
    from matplotlib.figure import Figure

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
    from matplotlib.figure import Figure

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


def payload_errors_figure(
    errors: Mapping[str, Mapping[float, np.ndarray]],
    *,
    title: str = "Static tool error per target, by model and payload",
    floor: float = 1e-4,
) -> Figure:
    """The figure of :func:`plot_payload_errors` (same arguments), not written.

    A log axis cannot draw 0: an error below ``floor`` mm (an exact 0, or
    round-off) is drawn as a downward triangle on the floor (a dotted line,
    named in the legend), and the legend says so: "0 (exact), drawn at the
    floor" when every such error of that series is exactly 0, "< floor
    (largest ...), drawn at the floor" otherwise; a series only on the floor
    has no other entry. The legend sits outside the axes, on the right; the
    limits hold every point."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    masses = sorted({m for by_mass in errors.values() for m in by_mass})
    fig = Figure(figsize=(10, 2.6 * len(masses) + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(masses), 1, sharex=True, squeeze=False))[:, 0]
    colours = ("tab:red", "tab:orange", "tab:green", "tab:blue", "tab:purple")
    colour = dict(zip(errors, colours, strict=False))
    drawn: list[str] = []  # the labels drawn, in order
    above: set[str] = set()  # the labels with an error drawn above the floor
    floored: dict[str, float] = {}  # label -> its largest error < floor, mm
    for ax, mass in zip(axes, masses, strict=True):
        top = floor
        n = 1
        for label, by_mass in errors.items():
            if mass not in by_mass:
                continue
            e = np.asarray(by_mass[mass], float) * 1e3
            idx = np.arange(1, e.size + 1)
            n = max(n, e.size)
            low = e < floor
            shown = np.where(low, floor, e)
            top = max(top, float(shown.max(initial=floor)))
            c = colour[label]
            ax.plot(idx, shown, "-", lw=0.8, color=c)
            ax.plot(idx[~low], shown[~low], "o", ms=3, color=c)
            if not low.all():
                above.add(label)
            if low.any():
                ax.plot(idx[low], shown[low], "v", ms=6, color=c)
                floored[label] = max(floored.get(label, 0.0), float(e[low].max()))
            if label not in drawn:
                drawn.append(label)
        ax.axhline(floor, ls=":", lw=0.8, color="0.3")
        ax.set_yscale("log")
        ax.set_ylim(floor / 2.0, log_limits(np.array([floor, top]))[1])
        ax.set_xlim(*linear_limits(np.array([1.0, float(n)]), margin=0.03))
        ax.set_ylabel("error [mm], log")
        ax.set_title(f"payload {mass:g} kg", fontsize=9)
        ax.grid(alpha=0.3, which="both")
    handles: list[Line2D] = []
    labels: list[str] = []
    for label in drawn:
        c = colour[label]
        if label in above:
            handles.append(Line2D([], [], marker="o", ms=3, lw=0.8, color=c))
            labels.append(label)
        if label in floored:
            handles.append(Line2D([], [], marker="v", ms=6, lw=0.8, color=c))
            worst = floored[label]
            note = (
                "0 (exact)"
                if worst == 0.0
                else f"< {floor:g} mm (largest {worst:.1g} mm)"
            )
            labels.append(f"{label}: {note}, drawn at the floor")
    handles.append(Line2D([], [], ls=":", lw=0.8, color="0.3"))
    labels.append(f"floor of the log axis, {floor:g} mm (0 cannot be drawn)")
    fig.legend(
        handles,
        [textwrap.fill(t, 28) for t in labels],
        loc="outside right upper",
        fontsize=8,
    )
    axes[-1].set_xlabel("held-out target")
    fitted_suptitle(fig, title)
    return fig


def plot_payload_errors(
    errors: Mapping[str, Mapping[float, np.ndarray]],
    path: str | os.PathLike,
    *,
    title: str = "Static tool error per target, by model and payload",
    floor: float = 1e-4,
) -> Path:
    """Tool position error per target for each model (label) and payload
    (:func:`payload_errors_figure`).

    Args:
      errors: label -> payload mass (kg) -> (K,) errors at K targets, m.
      path: PNG file to write.
      title: figure title (wrapped to the figure's width).
      floor: smallest error drawn, mm: smaller ones (an exact 0, round-off) are
        drawn on it as triangles, and the legend says which are exactly 0.
    """
    return save_figure(payload_errors_figure(errors, title=title, floor=floor), path)


def deflection_field_figure(
    model: RobotModel, payload_mass: float, *, grid: int = 41
) -> Figure:
    """The figure of :func:`plot_deflection_field` (same arguments), not
    written; its title is the figure's suptitle, wrapped to fit its width
    (:func:`fitted_suptitle`) with a constrained layout."""
    from matplotlib.figure import Figure

    lo, hi = model.limits.lower, model.limits.upper
    a, b = np.meshgrid(np.linspace(lo[1], hi[1], grid), np.linspace(lo[2], hi[2], grid))
    q = np.tile(np.clip(np.zeros(model.n_joints), lo, hi), (a.size, 1))
    q[:, 1], q[:, 2] = a.ravel(), b.ravel()
    p = tool_points(model.table, q, sigma=model.sigma)
    rest = tool_points(
        model.table, link_angles(model, q, payload_mass), sigma=model.sigma
    )
    d = (np.linalg.norm(rest - p, axis=1) * 1e3).reshape(a.shape)
    fig = Figure(figsize=(7, 5.5), layout="constrained")
    ax = fig.subplots()
    art = ax.contourf(np.rad2deg(a), np.rad2deg(b), d, levels=20, cmap="viridis")
    fig.colorbar(art, ax=ax, label="tool deflection [mm]")
    ax.set_xlabel("joint 2 [deg]")
    ax.set_ylabel("joint 3 [deg]")
    fitted_suptitle(
        fig,
        f"{model.name}: tool deflection holding {payload_mass:g} kg\n"
        f"(mean {d.mean():.0f} mm, max {d.max():.0f} mm)",
    )
    return fig


def plot_deflection_field(
    model: RobotModel, payload_mass: float, path: str | os.PathLike, *, grid: int = 41
) -> Path:
    """Tool deflection of an elastic robot (``model.compliance``) holding
    ``payload_mass`` kg over its gravity-loaded joints: joints 2 and 3 over
    their ranges (deg, ``grid`` values each), the others at 0 (clipped to their
    limits); the colour is the distance (mm) from the rigid tool position at
    those motor angles to where the tool rests
    (:func:`deflection_field_figure`)."""
    fig = deflection_field_figure(model, payload_mass, grid=grid)
    return save_figure(fig, path)


def _two_five(value: float, _: object) -> str:
    """A log axis's minor tick label: 2 and 5 times a power of ten only."""
    if value <= 0:
        return ""
    mantissa = value / 10 ** math.floor(math.log10(value) + 1e-9)
    return f"{value:g}" if round(mantissa) in (2, 5) else ""


def plan_errors_figure(
    errors: Mapping[str, np.ndarray],
    target: float,
    *,
    failed: Mapping[str, int] | None = None,
    title: str = "Mean held-out tool error per arm",
) -> Figure:
    """The figure of :func:`plot_plan_errors` (same arguments), not written:
    per plan a box of the arms' errors (mm, log axis; whiskers 5th to 95th
    percentile) over the arms themselves as jittered dots (a fixed jitter
    seed: the same data draw the same figure), the target as a dashed line,
    and under each plan the share of its arms at or under the target (failed
    arms counted as not) and its failed arms."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    labels = list(errors)
    values = [np.asarray(errors[k], float) * 1e3 for k in labels]
    failed = dict(failed or {})
    level = float(target) * 1e3
    every = np.concatenate([*values, [level]])
    lo, hi = log_limits(every)
    fig = Figure(figsize=(max(6.0, 1.8 * len(labels) + 2.5), 5.0), layout="constrained")
    ax = fig.subplots()
    rng = np.random.default_rng(0)
    ticks = []
    for i, (label, v) in enumerate(zip(labels, values, strict=True), start=1):
        shown = np.maximum(v, lo)  # a log axis cannot draw 0: at its floor
        if v.size:
            ax.boxplot(
                [shown],
                positions=[i],
                widths=0.5,
                whis=(5, 95),
                showfliers=False,
                medianprops={"color": "tab:red"},
            )
            x = i + rng.uniform(-0.18, 0.18, v.size)
            ax.plot(x, shown, "o", ms=2.5, alpha=0.45, color="tab:blue")
        elif failed.get(label):
            ax.text(
                i, math.sqrt(lo * hi), "every arm\nfailed", ha="center", va="center"
            )
        n = v.size + failed.get(label, 0)
        meeting = int(np.sum(v <= level))
        share = f"{100 * meeting / n:.1f} % <= target" if n else "no arm"
        extra = f"\n{failed[label]} failed" if failed.get(label) else ""
        ticks.append(f"{label}\n{share}{extra}")
    ax.axhline(level, ls="--", lw=1.0, color="0.3")
    ax.text(0.5, level, f" target {level:g} mm", va="bottom", ha="left", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylim(lo, hi)
    ax.set_xlim(0.4, len(labels) + 0.6)
    wrapped = ["\n".join(textwrap.fill(x, 28) for x in t.split("\n")) for t in ticks]
    ax.set_xticks(range(1, len(labels) + 1), wrapped)
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(FuncFormatter(_two_five))
    ax.tick_params(axis="x", labelsize=8)
    ax.set_ylabel("mean held-out tool error per arm [mm], log")
    ax.grid(alpha=0.3, which="both", axis="y")
    fitted_suptitle(fig, title)
    return fig


def plot_plan_errors(
    errors: Mapping[str, np.ndarray],
    target: float,
    path: str | os.PathLike,
    *,
    failed: Mapping[str, int] | None = None,
    title: str = "Mean held-out tool error per arm",
) -> Path:
    """A calibration plan tried on many arms: the distribution of the arms'
    mean held-out tool error per plan (:func:`plan_errors_figure`).

    Args:
      errors: plan label -> (N,) each arm's mean held-out tool-point error, m
        (the arms that were calibrated).
      target: m, the error an arm must reach (a dashed line).
      path: PNG file to write.
      failed: plan label -> arms that failed (not in ``errors``).
      title: figure title (wrapped to the figure's width).

    Returns:
      The written path.
    """
    fig = plan_errors_figure(errors, target, failed=failed, title=title)
    return save_figure(fig, path)


def socket_placements_figure(
    names: list[str],
    before: np.ndarray,
    training: np.ndarray,
    held_out: np.ndarray,
    *,
    title: str = "Socket consistency per placement",
) -> Figure:
    """Per placement, the mean consistency error (distance of the predicted
    ball positions from their socket's mean) of the nominal model and of the
    calibrated one, trained on every placement (training) and with this
    placement left out (held out), as grouped bars on a log axis in mm.

    Args:
      names: (P,) placement labels.
      before, training, held_out: (P,) mean consistency errors, m.
      title: figure title (wrapped to the figure's width).
    """
    from matplotlib.figure import Figure

    P = len(names)
    fig = Figure(figsize=(max(6.0, 0.9 * P + 2.0), 4.2))
    ax = fig.add_subplot()
    x = np.arange(P)
    width = 0.27
    series = (
        ("nominal", before, "0.6", None),
        ("calibrated, training (all placements)", training, "tab:blue", None),
        ("calibrated, held out (placement left out)", held_out, "tab:orange", "//"),
    )
    for i, (label, values, color, hatch) in enumerate(series):
        ax.bar(
            x + (i - 1) * width,
            np.asarray(values) * 1e3,
            width,
            label=label,
            color=color,
            hatch=hatch,
            edgecolor="k",
            linewidth=0.4,
        )
    ax.set_yscale("log")
    values = np.concatenate([before, training, held_out]) * 1e3
    top = float(np.max(values[values > 0], initial=1.0))
    low = float(np.min(values[values > 0], initial=1.0))
    ax.set_ylim(low / 2, top * 30)  # head room for the legend
    ax.set_xticks(x, names, rotation=30, ha="right")
    ax.set_ylabel("mean consistency error [mm]")
    ax.grid(axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", ncol=3)
    fitted_suptitle(fig, title)
    fig.tight_layout()
    return fig


def plot_socket_placements(
    names: list[str],
    before: np.ndarray,
    training: np.ndarray,
    held_out: np.ndarray,
    path: str | os.PathLike,
    *,
    title: str = "Socket consistency per placement",
) -> Path:
    """Writes :func:`socket_placements_figure` as a PNG (errors in m)."""
    fig = socket_placements_figure(names, before, training, held_out, title=title)
    return save_figure(fig, path)


#: The parameters :func:`history_figure` draws when none is flagged.
HISTORY_UNFLAGGED = 3


def history_figure(
    trend: HistoryTrend, dates: Sequence[datetime.date], *, title: str | None = None
) -> Figure:
    """The figure of :func:`plot_history` (same arguments), not written: one
    panel per flagged parameter (else the :data:`HISTORY_UNFLAGGED` with the
    largest trends in sigma), its fits over the dates with +-1 std error bars
    (SI) and the fitted trend line, titled with the parameter in words, its
    trend per year and sigma."""
    from matplotlib.figure import Figure

    from rmdrake.dynamics.fleet import parameter_unit, parameter_words

    flags = [trend.names.index(f.name) for f in trend.flagged]
    shown = flags or [
        int(k) for k in np.argsort(-np.abs(trend.z), kind="stable")[:HISTORY_UNFLAGGED]
    ]
    cols = min(2, len(shown))
    rows = math.ceil(len(shown) / cols)
    fig = Figure(figsize=(5.2 * cols, 3.2 * rows + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    when = np.array(dates, dtype="datetime64[D]")
    for ax, k in zip(axes, shown, strict=False):
        name, unit = trend.names[k], parameter_unit(trend.names[k])
        ax.errorbar(
            when, trend.values[:, k], yerr=trend.std[:, k], fmt="o", ms=4,
            capsize=3, color="tab:blue", label="fits, +-1 std",
        )  # fmt: skip
        label = f"trend {trend.trend[k]:+.3g} +- {trend.trend_std[k]:.2g} {unit}/year"
        ends = when[[0, -1]]
        ax.plot(ends, [trend.first[k], trend.last[k]], "-", color="tab:red",
                lw=1.2, label=label)  # fmt: skip
        flag = "flagged, " if k in flags else ""
        ax.set_title(
            f"{parameter_words(name)}\n{flag}{abs(trend.z[k]):.1f} sigma", fontsize=9
        )
        ax.set_ylabel(f"{name} [{unit}]")
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
        ax.tick_params(axis="x", labelsize=7, rotation=30)
    for ax in axes[len(shown) :]:
        ax.set_visible(False)
    if title is None:
        head = f"{len(flags)} flagged" if flags else "none flagged, the largest trends"
        title = (
            f"One arm over {len(dates)} fits: {head} (beyond "
            f"{trend.threshold:.3g} sigma)"
        )
    fitted_suptitle(fig, title)
    return fig


def plot_history(
    trend: HistoryTrend,
    dates: Sequence[datetime.date],
    path: str | os.PathLike,
    *,
    title: str | None = None,
) -> Path:
    """One arm's base parameters over time (:func:`history_figure`).

    Args:
      trend: :func:`~rmdrake.dynamics.history.compare_history`'s result.
      dates: (n,) the date of each of its fits, in its order.
      path: PNG file to write.
      title: figure title (default: the fits and the flags).

    Returns:
      The written path.
    """
    return save_figure(history_figure(trend, dates, title=title), path)
