"""Hostile cluster options: a ``--scheduler`` that is malformed, silent, not a
scheduler or not there; ``--workers`` beyond the machine; Ctrl-C to the whole
process group. Each ends in one line on stderr, in seconds, with nothing
written. Ports are ephemeral (bound to port 0), never fixed."""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from rmdrake import clusters
from rmdrake.cli.commands import main
from rmdrake.clusters import check_scheduler, worker_bound
from rmdrake.execution import Execution

PLAN = [
    *("plan", "--robot", "rv3sb", "--robots", "2", "--plates", "5"),
    *("--noise", "1e-6", "--target", "1e-4"),
]
TIMEOUT = 1.0  # s, the scheduler timeout these tests set (10 s shipped)


def _commands(tmp_path: Path) -> dict[str, list[str]]:
    """Each command with --scheduler, its --out under ``tmp_path``."""
    log = tmp_path / "arm_a.csv"
    log.write_text("t,q1\n0,0\n")
    return {
        "plan": [*PLAN, "--out", str(tmp_path / "out")],
        "fleet": ["fleet", "--robot", "rv3sb", "--logs", str(log), "--out",
                  str(tmp_path / "out")],
        "run": ["run", "--scenario", "paper_smoke", "--out", str(tmp_path / "out")],
        "demo": ["demo", "--smoke", "--out", str(tmp_path / "out")],
        "excite": ["excite", "--robot", "rv3sb", "--maxiter", "2", "--out",
                   str(tmp_path / "out")],
    }  # fmt: skip


def _serve(reply: bytes | None) -> Iterator[str]:
    """A TCP server on a free port that accepts every connection and then
    never answers (``reply`` None) or sends ``reply`` and closes; yields its
    address."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:  # closed at the end
                return
            if reply is None:
                held.append(conn)
            else:
                conn.sendall(reply)
                conn.close()

    threading.Thread(target=accept, daemon=True).start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        server.close()
        for conn in held:
            conn.close()


@pytest.fixture
def silent() -> Iterator[str]:
    """A port that accepts and never answers."""
    yield from _serve(None)


@pytest.fixture
def http() -> Iterator[str]:
    """A port that answers as a web server would, then closes."""
    yield from _serve(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")


@pytest.fixture
def closed() -> str:
    """A free port nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{s.getsockname()[1]}"


@pytest.fixture
def short_timeout(monkeypatch) -> None:
    monkeypatch.setattr(clusters, "SCHEDULER_TIMEOUT", TIMEOUT)


@pytest.mark.parametrize(
    "address, why",
    [
        ("abc", "no port"),
        ("http://", "scheme http://"),
        ("inproc://", "scheme inproc://"),
        ("tcp://", "no host"),
        ("tcp://host:99999", "port 99999 is not in 1..65535"),
        ("tcp://:8786", "no host"),
    ],
)
def test_a_malformed_scheduler_address_is_one_line_at_once(
    address, why, tmp_path, capsys
):
    t0 = time.monotonic()
    code = main([*PLAN, "--out", str(tmp_path / "out"), "--scheduler", address])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("rmdrake: error: argument --scheduler: ") and why in err
    assert time.monotonic() - t0 < 5.0
    assert not (tmp_path / "out").exists()


def test_a_well_formed_address_passes_the_parser():
    for good in ("tcp://host:8786", "host:8786", "tls://10.0.0.1:8786/",
                 "tcp://[::1]:8786", "TCP://Host.example:1"):  # fmt: skip
        assert clusters.scheduler_address(good) == good.strip()


@pytest.mark.parametrize("command", ["plan", "fleet", "run", "demo", "excite"])
def test_a_silent_scheduler_times_out_before_anything_is_written(
    command, silent, short_timeout, tmp_path, capsys
):
    argv = [*_commands(tmp_path)[command], "--scheduler", silent]
    t0 = time.monotonic()
    code = main(argv)
    took = time.monotonic() - t0
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err == (
        f"rmdrake: error: --scheduler {silent}: no Dask scheduler answered "
        f"within {TIMEOUT:g} s"
    )
    assert took < 4 * TIMEOUT + 5.0  # Dask's own client would wait forever
    assert not (tmp_path / "out").exists()  # no plan.yaml, no robot page


def test_a_closed_port_or_a_web_server_is_no_scheduler(
    closed, http, short_timeout, tmp_path, capsys
):
    for address in (closed, http):
        out = tmp_path / "out"
        assert main([*PLAN, "--out", str(out), "--scheduler", address]) == 2
        err = capsys.readouterr().err.strip()
        assert err.endswith(f"{address}: no Dask scheduler answered within 1 s")
        assert not out.exists()


def test_a_workers_address_is_refused_naming_what_answered():
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, processes=False, protocol="tcp", dashboard_address=":0"
    ) as cluster:
        check_scheduler(cluster.scheduler_address, timeout=5.0)  # answers
        worker = next(iter(cluster.workers.values())).address
        with pytest.raises(ValueError, match="a Dask Worker did"):
            check_scheduler(worker, timeout=5.0)


def test_the_shipped_timeout_is_seconds():
    assert 1.0 <= clusters.SCHEDULER_TIMEOUT <= 30.0


def test_workers_over_the_machines_bound_are_refused_naming_it(tmp_path, capsys):
    bound, why = worker_bound()
    cores = clusters.default_workers()
    assert 1 <= bound <= clusters.WORKERS_PER_CORE * cores
    for many in (bound + 1, 10_000, 10**30):
        code = main([*PLAN, "--out", str(tmp_path / "out"), "--workers", str(many)])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1
        assert f"over this machine's bound of {bound} ({why})" in err
        assert "give fewer or use --scheduler" in err
    assert main([*PLAN, "--out", str(tmp_path / "out"), "--workers", "1e30"]) == 2
    assert "expected an integer" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match=f"bound of {bound}"):
        Execution(workers=bound + 1)
    assert Execution(workers=bound).workers == bound  # nothing started


def test_the_bound_counts_memory_when_it_is_short(monkeypatch):
    import distributed.system

    monkeypatch.setattr(distributed.system, "MEMORY_LIMIT", 3 * clusters.WORKER_MEMORY)
    bound, why = worker_bound()
    assert bound == min(3, clusters.WORKERS_PER_CORE * clusters.default_workers())
    if bound == 3:
        assert "GiB of memory" in why


def test_ctrl_c_to_the_process_group_is_one_line(tmp_path):
    """SIGINT to the whole group, as a terminal's Ctrl-C: the workers do not
    print tracebacks; the command prints its one line and exits 130."""
    plan = (
        "plan --robot rv3sb --robots 12 --plates 5 --per-plate 12 --noise 2e-6 "
        "--length-std 2e-4 --angle-std 1e-3 --target 5e-5 --workers 2"
    ).split()
    cmd = [sys.executable, "-m", "rmdrake.cli", *plan, "--out", str(tmp_path / "o")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=env,
    )
    try:
        first = proc.stderr.readline()  # the progress bar's first line
        assert "arms: 0/12" in first, first
        time.sleep(0.5)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    lines = [line for line in err.splitlines() if not line.startswith("arms: ")]
    assert proc.returncode == 130, err
    assert len(lines) <= 2, err
    assert lines[-1].startswith("rmdrake: interrupted; ")
    assert "Traceback" not in err


def test_quiet_loggers_reach_the_children_dask_gives_a_level():
    """Dask's config sets ``distributed.client`` to WARNING of its own, which
    the parent's CRITICAL does not reach: it is muted too, and put back."""
    import distributed  # noqa: F401 - its config sets the levels

    client = logging.getLogger("distributed.client")
    before = client.level
    assert before != logging.NOTSET
    with clusters.quiet_loggers():
        assert client.getEffectiveLevel() == logging.CRITICAL
        assert not client.isEnabledFor(logging.ERROR)
    assert client.level == before
