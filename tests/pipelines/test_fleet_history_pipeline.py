"""`rmdrake fleet --history`'s pipeline on one simulated RV-3SB arm over
months: its own 3 % draw, run in Drake (the independent oracle) along one
20 s excitation at 100 Hz with 0.5 % torque noise, logged on the 15th of 8
months whose joint 3 viscous friction grows by 36 % of itself a year; and
the same arm logged on 5 dates with nothing changing. The oracle: the
growing arm's only flag is fv3, its trend within 3 of its stds of the
injected one; the constant arm flags nothing; the tables and the figure are
written."""

from __future__ import annotations

import csv
import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.dynamics.history import DAYS_PER_YEAR
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.execution import Execution, TaskRunner
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.pipelines.history import (
    HISTORY_CSV,
    HISTORY_FITS_CSV,
    HISTORY_PNG,
    run_history,
)
from rmdrake.pipelines.simulate import simulate_file

GROWTH = 0.36  # of fv3, per year
START = dt.date(2026, 1, 15)
GROWING = [dt.date(2026, month, 15) for month in range(1, 9)]
CONSTANT = [dt.date(2026, month, 15) for month in (1, 3, 5, 7, 9)]


def _simulate(item: tuple[str, dt.date, int, str, str]) -> str:
    """A task (runs in a worker): the arm on ``date`` (fv3 grown by GROWTH a
    year since START if ``kind`` is growing) run in Drake; its log's path."""
    kind, date, seed, folder, trajectory = item
    true, _ = perturb_robot(load_robot("rv3sb"), dynamics_std=0.03, seed=3)
    if kind == "growing":
        links = true.dynamics.copy()
        links[2, 11] *= 1 + GROWTH * (date - START).days / DAYS_PER_YEAR
        true = true.with_dynamics(links)
    name = f"arm3_{date.isoformat()}"
    robot = true.save(Path(folder) / kind / "true" / f"{name}.yaml")
    log = Path(folder) / kind / "logs" / f"{name}.csv"
    path = simulate_file(
        str(robot), trajectory, log, rate=100.0,
        torque_noise=list(0.005 * true.limits.effort), seed=seed, echo=lambda _: None,
    )  # fmt: skip
    return str(path)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("history")
    nominal = load_robot("rv3sb")
    trajectory = random_fourier_trajectory(
        nominal, fill=0.8, seed=4, base_frequency=0.05
    ).save(tmp / "trajectory.yaml")
    items = [
        ("growing", d, i, str(tmp), str(trajectory)) for i, d in enumerate(GROWING)
    ]
    items += [("constant", d, 20 + i, str(tmp), str(trajectory))
              for i, d in enumerate(CONSTANT)]  # fmt: skip
    with TaskRunner(Execution(workers=2), tasks=len(items)) as runner:
        logs = runner.map(_simulate, items, progress=False)
    runs = {}
    for kind in ("growing", "constant"):
        lines: list[str] = []
        mine = [log for log, item in zip(logs, items, strict=True) if item[0] == kind]
        run = run_history(
            nominal, mine[::-1], tmp / kind / "out", coulomb_width=DEFAULT_V_EPS,
            execution=Execution(workers=0), echo=lines.append,
        )  # fmt: skip
        runs[kind] = (run, lines)
    return tmp, nominal, runs


def test_the_growing_friction_is_the_only_flag_with_its_trend(arm):
    _, _, runs = arm
    run, lines = runs["growing"]
    assert not run.failed and run.dates == tuple(GROWING)  # sorted by date
    flags = run.trend.flagged
    assert [f.name for f in flags] == ["fv3"], [f.text() for f in flags]
    f = flags[0]
    true, _ = perturb_robot(load_robot("rv3sb"), dynamics_std=0.03, seed=3)
    injected = GROWTH * true.dynamics[2, 11]  # N m s/rad per year
    print(f.text(), f"injected {injected:.4f}/year, found {f.trend:.4f}"
          f" +- {f.trend_std:.4f}")  # fmt: skip
    assert f.trend > 0 and abs(f.trend - injected) < 3 * f.trend_std
    assert f.trend_std < 0.3 * injected  # 0.2 measured
    assert lines[-1].startswith("history: 8 fits over 7.0 months, 1 flagged: "
                                "joint 3 viscous friction +")  # fmt: skip
    assert any(line.startswith("drifts: joint 3 viscous friction") for line in lines)


def test_a_constant_arm_flags_nothing(arm):
    _, _, runs = arm
    run, lines = runs["constant"]
    assert not run.failed and run.trend.flagged == []
    assert float(np.abs(run.trend.z).max()) < run.trend.threshold - 0.5
    assert lines[-1] == "history: 5 fits over 8.0 months, none flagged"


def test_tables_and_figure_written(arm):
    tmp, _, runs = arm
    out = tmp / "growing" / "out"
    with open(out / HISTORY_CSV, newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0]["name"] == "fv3" and rows[0]["flagged"] == "1"
    assert sum(r["flagged"] == "1" for r in rows) == 1 and len(rows) == 52
    assert float(rows[0]["trend_per_year"]) == runs["growing"][0].trend.flagged[0].trend
    with open(out / HISTORY_FITS_CSV, newline="") as f:
        fits = list(csv.DictReader(f))
    assert [r["date"] for r in fits] == [d.isoformat() for d in GROWING]
    assert np.all(np.diff([float(r["fv3"]) for r in fits]) > -0.05)
    png = (out / HISTORY_PNG).read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    assert (tmp / "constant" / "out" / HISTORY_PNG).exists()  # the largest trends
