"""No silent minutes: in batch use a progress line comes at least every
interval (30 s; RMDRAKE_PROGRESS_INTERVAL here, a fraction of a second) from
inside a long step: a slow step between two updates, an LM solve, a task on a
Dask worker while the caller waits on it. Each test reads the times at which
the lines reach stderr and checks the largest gap."""

from __future__ import annotations

import importlib
import io
import sys
import time

import pytest

from rmdrake import progress
from rmdrake.execution import Execution, TaskRunner
from rmdrake.progress import LineProgress, progress_bar

INTERVAL = 0.5
"""s: the progress interval of these tests."""

SLACK = 0.6
"""s: what a loaded machine may add to a gap (a poll, a step's jitter)."""


class _Stamped(io.TextIOBase):
    """A stderr that records when each whole line arrives (not a terminal)."""

    def __init__(self) -> None:
        self.lines: list[tuple[float, str]] = []
        self._part = ""

    def write(self, text: str) -> int:
        self._part += text
        *whole, self._part = self._part.split("\n")
        now = time.perf_counter()
        self.lines.extend((now, line) for line in whole)
        return len(text)

    def isatty(self) -> bool:
        return False

    def gaps(self, start: float, end: float) -> list[float]:
        """s between ``start``, the lines written from then on, and ``end``."""
        times = [start, *(t for t, _ in self.lines if start <= t <= end), end]
        return [b - a for a, b in zip(times, times[1:], strict=False)]


@pytest.fixture
def stamped(monkeypatch) -> _Stamped:
    """A progress interval of INTERVAL s (in this process and in the workers
    it starts) and a stderr recorded with times, that a test installs at its
    start (pytest puts its own capture back between setup and call)."""
    monkeypatch.setenv(progress.INTERVAL_VARIABLE, str(INTERVAL))
    return _Stamped()


def _slow_task(seconds: float) -> float:
    """A task of ``seconds`` s in 4 steps, with a bar of its own."""
    bar = progress_bar(total=4, desc="slow steps")
    for _ in range(4):
        time.sleep(seconds / 4)
        bar.update(1)
    bar.close()
    return seconds


def test_a_step_longer_than_the_interval_is_announced_a_step_early(monkeypatch):
    """Steps of 20 s with a 30 s interval: a line after every step whose
    successor would end past the interval, so no gap reaches 40 s (the old
    rule wrote at the first update past 30 s: gaps of 40 s)."""
    now = [0.0]
    monkeypatch.setattr("rmdrake.progress.time.perf_counter", lambda: now[0])
    out = io.StringIO()
    stamps = []

    class File:
        def write(self, text: str) -> None:
            stamps.append(now[0])
            out.write(text)

        def flush(self) -> None:
            pass

    bar = LineProgress(total=10, desc="generations", interval=30.0, file=File())
    for _ in range(10):
        now[0] += 20.0
        bar.update(1)
    bar.close()
    gaps = [b - a for a, b in zip(stamps, stamps[1:], strict=False)]
    assert max(gaps) <= 30.0
    assert "about" in out.getvalue().splitlines()[1]  # the time left


def test_the_interval_can_be_set_by_the_environment(monkeypatch):
    monkeypatch.setenv(progress.INTERVAL_VARIABLE, "0.25")
    assert progress.batch_interval() == 0.25
    for bad in ("0", "-1", "inf", "nan", "soon"):
        monkeypatch.setenv(progress.INTERVAL_VARIABLE, bad)
        assert progress.batch_interval() == progress.BATCH_INTERVAL


def test_a_slowed_lm_solve_in_a_small_calibration_shows_its_iterations(
    stamped, monkeypatch
):
    """A plate calibration (40 readings, LM, the paper's parameters) whose
    Jacobian is slowed to take 0.3 s: the solve outlasts the interval many
    times, and the LM's own lines leave no gap over the interval."""
    from rmdrake import load_robot
    from rmdrake.calibration import PlaneLM, simulate_plates
    from rmdrake.calibration.plates.cost import PlaneProblem

    importlib.import_module("scipy.optimize")  # its first import: seconds
    robot = load_robot("rv3sb")
    data = simulate_plates(robot, plates=4, per_plate=10, seed=0).data
    jacobian = PlaneProblem.jacobian

    def slow(self, x):
        time.sleep(0.3)
        return jacobian(self, x)

    monkeypatch.setattr(PlaneProblem, "jacobian", slow)
    monkeypatch.setattr(sys, "stderr", stamped)
    t0 = time.perf_counter()
    fit = PlaneLM(robot, params="paper").fit(data)
    t1 = time.perf_counter()
    assert fit.model_ is not None
    assert t1 - t0 > 3 * INTERVAL  # the step really was slow
    lm = [line for _, line in stamped.lines if line.startswith("LM iterations: ")]
    assert lm and "cost=" in lm[0] and "evaluations=" in lm[0]
    assert max(stamped.gaps(t0, t1)) <= INTERVAL + SLACK


def test_a_slow_task_on_a_dask_worker_gets_heartbeats_and_its_own_lines(
    stamped, monkeypatch
):
    """Two tasks of 3 s on a local cluster of 2 workers (whose own bars do not
    print): the caller writes its bar's line every interval while waiting,
    with the tasks waited on, and each task's newest line under it."""
    monkeypatch.setattr(sys, "stderr", stamped)
    with TaskRunner(Execution(workers=2), tasks=2) as runner:
        assert runner.parallel
        t0 = time.perf_counter()
        out = runner.map(_slow_task, [3.0, 3.0], desc="true robots")
        t1 = time.perf_counter()
        ahead = runner.start(_slow_task, 3.0)  # a call started ahead, waited on
        assert ahead.on_cluster and ahead.result() == 3.0
        t2 = time.perf_counter()
    assert out == [3.0, 3.0]
    lines = [line for t, line in stamped.lines if t0 <= t <= t1]
    beats = [line for line in lines if "waiting on" in line]
    assert beats and beats[0].startswith("true robots: 0/2 (0 %), ")
    assert "waiting on 2 tasks" in beats[0]
    assert any(line.startswith("  [task ") and "slow steps:" in line for line in lines)
    assert lines[-1].startswith("true robots: 2/2 (100 %)")
    assert max(stamped.gaps(t0, t1)) <= INTERVAL + SLACK
    waits = [line for t, line in stamped.lines if t >= t1]
    assert any(line.startswith("waiting on _slow_task, a task started ahead: ")
               for line in waits)  # fmt: skip
    assert any(line.startswith("  [task] slow steps:") for line in waits)
    assert max(stamped.gaps(t1 + INTERVAL, t2)) <= INTERVAL + SLACK


def _slow_diagram(pause: float):
    """A Drake system whose every 0.1 s of simulated time takes ``pause`` s
    of wall time (a periodic publish that sleeps)."""
    from pydrake.systems.framework import LeafSystem

    class Slow(LeafSystem):
        def __init__(self) -> None:
            super().__init__()
            self.DeclareContinuousState(1)
            self.DeclarePeriodicPublishEvent(0.1, 0.0, self._pause)

        def _pause(self, context) -> None:
            time.sleep(pause)

        def DoCalcTimeDerivatives(self, context, derivatives) -> None:
            derivatives.get_mutable_vector().SetAtIndex(0, 1.0)

    return Slow()


def test_a_slow_drake_run_shows_its_simulated_seconds_a_quick_one_nothing(
    stamped, monkeypatch
):
    """simulation_progress (the study runs that call AdvanceTo themselves):
    a run slowed to 1.5 s shows the simulated seconds with no gap over the
    interval; a quick run right after a line shows nothing (lazy)."""
    from pydrake.systems.analysis import Simulator

    from rmdrake.systems.station import simulation_progress

    monkeypatch.setattr(sys, "stderr", stamped)
    simulator = Simulator(_slow_diagram(0.05))
    t0 = time.perf_counter()
    with simulation_progress(simulator, 3.0):
        simulator.AdvanceTo(3.0)
    t1 = time.perf_counter()
    runs = [line for _, line in stamped.lines if line.startswith("simulated s: ")]
    assert runs and "/3 (" in runs[0]
    assert max(stamped.gaps(t0, t1)) <= INTERVAL + SLACK
    monkeypatch.setattr(progress, "_LAST_LINE", [time.perf_counter()])
    quick = Simulator(_slow_diagram(0.0))
    with simulation_progress(quick, 3.0):
        quick.AdvanceTo(3.0)
    assert [t for t, _ in stamped.lines if t > t1] == []


def test_a_command_counts_silence_from_its_own_start(stamped, monkeypatch, tmp_path):
    """One process runs many commands (a notebook, a test session): a command
    that begins after the process has been quiet for an interval does not
    announce its first quick lazy step (a socket calibration's LM solve) at
    once."""
    from rmdrake.cli.commands import main

    out = tmp_path / "s.csv"
    argv = ["simulate-sockets", "--robot", "rv3sb", "--out", str(out)]
    assert main([*argv, "--placements", "3", "--per-socket", "10"]) == 0
    progress.restart_silence()
    time.sleep(2 * INTERVAL)  # the process is quiet for longer than an interval
    monkeypatch.setattr(sys, "stderr", stamped)
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(out)]
    assert main([*argv, "--out", str(tmp_path / "c.yaml")]) == 0
    assert not [line for _, line in stamped.lines if line.startswith("LM iter")]
