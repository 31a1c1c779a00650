"""``rmdrake plan --scheduler`` on a Dask cluster started with Dask's own
command line (a scheduler and two workers on 127.0.0.1, random free ports), as
a user starts one on their machines: the same ``robots.csv``, byte for byte, as
the serial run, even when a worker is killed (SIGKILL) in the middle of the
plan. Every cluster process is stopped at the end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

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


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[str]:
    """`dask scheduler` and two `dask worker` processes, one thread each; yields
    the scheduler's address."""
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
        yield address
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
    tmp_path: Path, dask_cluster: str
):
    serial = _rmdrake(
        "plan", *PLAN, "--out", str(tmp_path / "serial"), "--workers", "0"
    )
    out_s, _ = serial.communicate(timeout=600)
    assert serial.returncode == 0, out_s

    run = _rmdrake(
        "plan", *PLAN, "--out", str(tmp_path / "cluster"), "--scheduler", dask_cluster
    )
    try:
        table = tmp_path / "cluster" / "robots.csv"
        deadline = time.monotonic() + 300
        while _rows(table) < 2 and run.poll() is None:  # mid-plan: some rows in
            assert time.monotonic() < deadline, "no row within 300 s"
            time.sleep(0.05)
        killed = _worker_pids(dask_cluster)[0]
        os.kill(killed, signal.SIGKILL)
        at_kill = _rows(table)
        out_c, _ = run.communicate(timeout=600)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, out_c
    assert f"tasks run on the Dask cluster at {dask_cluster}" in out_c
    assert _rows(tmp_path / "serial" / "robots.csv") == 40  # 20 arms x 2 plans
    assert at_kill < 40  # the worker died in the middle of the plan
    assert (tmp_path / "cluster" / "robots.csv").read_bytes() == (
        tmp_path / "serial" / "robots.csv"
    ).read_bytes()
    assert "failed" not in (tmp_path / "cluster" / "robots.csv").read_text()
    assert killed not in _worker_pids(dask_cluster)  # one worker did die
