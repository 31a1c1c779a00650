"""``rmdrake plan --scheduler`` on a Dask cluster started with Dask's own
command line (a scheduler and two workers on 127.0.0.1, random free ports), as
a user starts one on their machines: the same ``robots.csv``, byte for byte, as
the serial run, even when a worker is killed (SIGKILL) in the middle of the
plan; a scheduler killed there ends the plan with one line, its rows kept for
``--resume``. Every cluster process is stopped at the end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pytest

BIN = Path(sys.executable).parent
PLAN = [
    *("--robot", "rv3sb", "--robots", "20", "--plates", "5", "--per-plate", "12"),
    *("--noise", "2e-6", "--length-std", "2e-4", "--angle-std", "1e-3"),
    *("--params", "paper", "--readings", "60,120", "--target", "5e-5", "--seed", "3"),
]
START_TIMEOUT = 60.0  # s, for the scheduler file and both workers


def _rmdrake(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [str(BIN / "rmdrake"), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        **kw,
    )


def _stop(processes: list[subprocess.Popen]) -> None:
    """SIGTERM to each process group (a worker's nanny and its child), then
    SIGKILL to what is left after 10 s."""
    for p in processes:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in processes:
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(10)


class DaskCluster(NamedTuple):
    address: str  # the scheduler's
    processes: list[subprocess.Popen]  # the scheduler's first, then the workers'


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[DaskCluster]:
    """`dask scheduler` and two `dask worker` processes, one thread each."""
    from distributed import Client

    info = tmp_path / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    processes = [
        subprocess.Popen(
            [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0"]
            + ["--no-dashboard", "--scheduler-file", str(info)],
            start_new_session=True,
            **quiet,
        )
    ]
    try:
        deadline = time.monotonic() + START_TIMEOUT
        while not info.exists() or not info.read_text().strip():
            assert time.monotonic() < deadline, "dask scheduler did not start"
            time.sleep(0.05)
        time.sleep(0.1)  # the file is written whole, but give it its newline
        address = json.loads(info.read_text())["address"]
        for _ in range(2):
            processes.append(
                subprocess.Popen(
                    [str(BIN / "dask"), "worker", "--scheduler-file", str(info)]
                    + ["--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                    start_new_session=True,
                    **quiet,
                )
            )
        with Client(address, timeout=START_TIMEOUT) as client:
            client.wait_for_workers(2, timeout=START_TIMEOUT)
        yield DaskCluster(address, processes)
    finally:
        _stop(processes)
        assert all(p.poll() is not None for p in processes)


def _worker_pids(address: str) -> list[int]:
    from distributed import Client

    with Client(address) as client:
        return sorted(client.run(os.getpid).values())


def _rows(path: Path) -> int:
    return max(0, len(path.read_text().splitlines()) - 1) if path.exists() else 0


def test_plan_on_a_cluster_started_by_dask_equals_the_serial_plan(
    tmp_path: Path, dask_cluster: DaskCluster
):
    address = dask_cluster.address
    serial = _rmdrake(
        "plan", *PLAN, "--out", str(tmp_path / "serial"), "--workers", "0"
    )
    out_s, _ = serial.communicate(timeout=600)
    assert serial.returncode == 0, out_s

    run = _rmdrake(
        "plan", *PLAN, "--out", str(tmp_path / "cluster"), "--scheduler", address
    )
    try:
        table = tmp_path / "cluster" / "robots.csv"
        deadline = time.monotonic() + 300
        while _rows(table) < 2 and run.poll() is None:  # mid-plan: some rows in
            assert time.monotonic() < deadline, "no row within 300 s"
            time.sleep(0.05)
        killed = _worker_pids(address)[0]
        os.kill(killed, signal.SIGKILL)
        at_kill = _rows(table)
        out_c, _ = run.communicate(timeout=600)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, out_c
    assert f"tasks run on the Dask cluster at {address}" in out_c
    assert _rows(tmp_path / "serial" / "robots.csv") == 40  # 20 arms x 2 plans
    assert at_kill < 40  # the worker died in the middle of the plan
    assert (tmp_path / "cluster" / "robots.csv").read_bytes() == (
        tmp_path / "serial" / "robots.csv"
    ).read_bytes()
    assert "failed" not in (tmp_path / "cluster" / "robots.csv").read_text()
    assert killed not in _worker_pids(address)  # one worker did die


def test_a_scheduler_killed_mid_plan_ends_it_in_one_line_and_resume_finishes_it(
    tmp_path: Path, dask_cluster: DaskCluster
):
    """The scheduler SIGKILLed once rows are in: exit 2 with one line naming
    Dask's reason (no traceback, no Dask log after it), the rows written so
    far kept, and ``--resume`` (here in this process) ends the same plan."""
    out = tmp_path / "cluster"
    run = _rmdrake("plan", *PLAN, "--out", str(out), "--scheduler",
                   dask_cluster.address)  # fmt: skip
    try:
        deadline = time.monotonic() + 300
        while _rows(out / "robots.csv") < 2 and run.poll() is None:
            assert time.monotonic() < deadline, "no row within 300 s"
            time.sleep(0.05)
        os.killpg(dask_cluster.processes[0].pid, signal.SIGKILL)
        text, _ = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    lines = text.strip().splitlines()
    assert run.returncode == 2, text
    assert lines[-1].startswith(
        "rmdrake: error: the Dask cluster cancelled the tasks "
        "(scheduler-connection-lost: "
    ), text
    assert "Traceback" not in text and "ERROR" not in text, text
    kept = _rows(out / "robots.csv")
    assert 2 <= kept < 40
    resumed = _rmdrake("plan", *PLAN, "--out", str(out), "--resume", "--workers", "0")
    text, _ = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, text
    assert f"{kept} done, {40 - kept} to run" in text
    assert _rows(out / "robots.csv") == 40
