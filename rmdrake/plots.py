"""Matplotlib figures of rmdrake (Agg backend: files only, no display needed).

Every function takes arrays in SI units, draws in display units (mm, deg) and
writes a PNG atomically.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rmdrake.io import atomic_write_bytes  # noqa: E402

__all__ = ["plot_calibration_errors", "save_figure"]


def save_figure(fig: matplotlib.figure.Figure, path: str | os.PathLike) -> Path:
    """Writes ``fig`` as PNG to ``path`` atomically and closes it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
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
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
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
