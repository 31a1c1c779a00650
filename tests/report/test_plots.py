"""Figures: each plot function writes a non-empty PNG atomically, draws what it
is given, and leaves matplotlib's global state (backend, pyplot) alone."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from rmdrake.report import plots

PNG = b"\x89PNG\r\n\x1a\n"


def test_import_sets_no_backend():
    code = (
        "import matplotlib, rmdrake.report.plots, sys; "
        "sys.exit('matplotlib.pyplot' in sys.modules)"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_every_figure_is_a_png(tmp_path):
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 200)
    q = np.sin(np.outer(t, np.arange(1, 4)))
    written = [
        plots.plot_calibration_errors(
            np.abs(rng.normal(1e-3, 3e-4, 50)),
            {"LM": np.abs(rng.normal(2e-5, 5e-6, 50))},
            tmp_path / "fig3.png",
            title="test",
            reference={"paper after": 3e-4},
        ),
        plots.plot_joint_trajectories(
            t, q, tmp_path / "fig4.png", lower=-np.ones(3), upper=np.ones(3)
        ),
        plots.plot_cartesian_path(t, np.c_[q[:, :2], t / 10], tmp_path / "fig6.png"),
        plots.plot_torque_comparison(t, q, {"ols": q + 0.01}, tmp_path / "fig7.png"),
    ]
    for path in written:
        data = path.read_bytes()
        assert data[:8] == PNG and len(data) > 5_000, path
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fig3.png",
        "fig4.png",
        "fig6.png",
        "fig7.png",
    ]  # no temporary file left behind
