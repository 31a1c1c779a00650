"""Clusters as users give them: how many local worker processes this machine
holds, a Dask scheduler's address checked as it is typed and its answer
awaited with a deadline, and the quiet start of a local cluster (Dask's
loggers muted, SIGINT kept from its workers).

A user's scheduler must answer within :data:`SCHEDULER_TIMEOUT` (10 s)
before anything is written; ``--workers`` is bounded by :func:`worker_bound`
(:data:`WORKERS_PER_CORE` a core, and what the memory holds at
:data:`WORKER_MEMORY` each):

>>> scheduler_address("tcp://host:8786")
'tcp://host:8786'
>>> check_workers(0)
0
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import re
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = [
    "QUIET_LOGGERS",
    "REMOTE_SCHEMES",
    "SCHEDULER_TIMEOUT",
    "WORKERS_PER_CORE",
    "WORKER_MEMORY",
    "check_scheduler",
    "check_workers",
    "default_workers",
    "interrupts_held",
    "mute_loggers",
    "quiet_loggers",
    "scheduler_address",
    "worker_bound",
]

QUIET_LOGGERS = ("distributed", "tornado", "asyncio")
"""Loggers held at CRITICAL while a runner is open: their errors are about
workers lost and tasks retried, which the runner handles and reports."""


def default_workers() -> int:
    """One worker process per core this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


WORKERS_PER_CORE = 4
"""Local worker processes per core at most (:func:`worker_bound`): beyond one
per core they only queue for the cores; four leaves room for tasks that wait
on I/O, far below the thousands that exhaust the file descriptors (each
worker holds a dozen: pipes, sockets, its nanny's)."""

WORKER_MEMORY = 2**29
"""bytes (512 MiB): the memory a local worker process is counted for in
:func:`worker_bound`: one holds 170 MB once pydrake is imported (measured),
more with a robot's plant and a task's data."""


def worker_bound() -> tuple[int, str]:
    """The most local worker processes this machine is given, and why, e.g.
    ``(8, "2 cores x 4")``: :data:`WORKERS_PER_CORE` per core
    (:func:`default_workers`), and no more than its memory holds at
    :data:`WORKER_MEMORY` each (the memory Dask sees: the machine's, or its
    container's limit)."""
    from distributed.system import MEMORY_LIMIT  # bytes, cgroup limits included

    cores = default_workers()
    by_cores = WORKERS_PER_CORE * cores
    by_memory = max(1, int(MEMORY_LIMIT // WORKER_MEMORY))
    if by_memory < by_cores:
        gib = MEMORY_LIMIT / 2**30
        return by_memory, f"{gib:.3g} GiB of memory / {WORKER_MEMORY / 2**30:g} GiB"
    return by_cores, f"{cores} core{'s' * (cores != 1)} x {WORKERS_PER_CORE}"


def check_workers(workers: int) -> int:
    """``workers`` local worker processes if this machine can hold them
    (:func:`worker_bound`), else ValueError naming the bound: ``--workers
    10000: over this machine's bound of 8 (2 cores x 4); give fewer or use
    --scheduler``. Zero (this process) is always allowed."""
    if workers > 0:
        bound, why = worker_bound()
        if workers > bound:
            raise ValueError(
                f"--workers {workers}: over this machine's bound of {bound} "
                f"({why}); give fewer or use --scheduler"
            )
    return workers


SCHEDULER_TIMEOUT = 10.0
"""s: a Dask scheduler given by its address must answer (connect and say who
it is) within this, or the run is refused before anything is written
(:func:`check_scheduler`); a scheduler on a network answers in milliseconds."""

REMOTE_SCHEMES = ("tcp", "tls", "ws", "wss")
"""The address schemes of a Dask scheduler in another process, on this or
another machine (Dask's ``inproc://`` is a scheduler in this very process,
and ``ucx://`` needs UCX-Py)."""

_HOST_PORT = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]@?#]+):(\d{1,5})/?")


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address as a user gives it, checked:
    ``[SCHEME://]HOST:PORT`` with SCHEME one of :data:`REMOTE_SCHEMES` (tcp
    when left out), a host (an IPv6 one in brackets) and a port in 1..65535.

    Raises:
      ValueError: one line naming what is wrong, e.g. ``expected a scheduler
        address tcp://HOST:PORT ..., found 'abc': no port``.
    """
    scheme, sep, rest = text.strip().rpartition("://")
    scheme = scheme.lower() if sep else "tcp"
    match = _HOST_PORT.fullmatch(rest)
    if scheme not in REMOTE_SCHEMES:
        why = f"scheme {scheme}:// is not one of {', '.join(REMOTE_SCHEMES)}"
    elif not rest or rest.startswith(":"):
        why = "no host"
    elif match is None:
        why = "no port" if ":" not in rest.strip("[]") else "not HOST:PORT"
    elif not 0 < int(match.group(2)) < 65536:
        why = f"port {int(match.group(2))} is not in 1..65535"
    else:
        return text.strip()
    raise ValueError(
        "expected a scheduler address tcp://HOST:PORT such as tcp://host:8786 "
        f"(or tls://, ws://, wss://), found {text!r}: {why}"
    )


async def _identity(address: str, timeout: float) -> Any:
    """What the Dask server at ``address`` says it is (``{"type":
    "Scheduler", ...}``), each step within ``timeout`` (s)."""
    from distributed.comm import connect

    comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
    try:
        await asyncio.wait_for(comm.write({"op": "identity", "reply": True}), timeout)
        return await asyncio.wait_for(comm.read(), timeout)
    finally:
        comm.abort()


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Refuses ``address`` unless a Dask scheduler there answers within
    ``timeout`` (s; None: :data:`SCHEDULER_TIMEOUT`). Dask's own client
    waits forever on a port that accepts a connection and never answers; this
    asks in a thread of its own with a deadline on each step, so a wrong
    port, a server of another kind or a worker's address end the run in
    seconds.

    Raises:
      ValueError: ``--scheduler ADDRESS: no Dask scheduler answered within
        10 s`` (and who did answer, if anyone).
    """
    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout
    found: dict[str, Any] = {}

    def ask() -> None:
        try:
            found["identity"] = asyncio.run(_identity(address, timeout))
        except BaseException as error:  # noqa: BLE001 - any failure is "no answer"
            found["error"] = error

    with quiet_loggers():
        thread = threading.Thread(target=ask, name="rmdrake scheduler check")
        thread.daemon = True
        thread.start()
        thread.join(3 * timeout)  # each of its 3 steps is bounded
    identity = found.get("identity")
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind == "Scheduler":
        return
    who = f" (a Dask {kind} did: give its scheduler's address)" if kind else ""
    raise ValueError(
        f"--scheduler {address}: no Dask scheduler answered within {timeout:g} s{who}"
    )


def mute_loggers() -> dict[str, int]:
    """Sets :data:`QUIET_LOGGERS`'s loggers, and those below them that have a
    level of their own, to CRITICAL; returns the levels they had. Dask's
    config gives some children their own level (``distributed.client`` at
    WARNING), which a parent's level does not reach: a client's failed
    reconnect would still print its ERROR with two tracebacks."""
    names = [
        name
        for name, logger in list(logging.Logger.manager.loggerDict.items())
        if isinstance(logger, logging.Logger)
        and logger.level != logging.NOTSET
        and any(name.startswith(f"{root}.") for root in QUIET_LOGGERS)
    ]
    levels = {}
    for name in (*QUIET_LOGGERS, *names):
        logger = logging.getLogger(name)
        levels[name] = logger.level
        logger.setLevel(logging.CRITICAL)
    return levels


@contextlib.contextmanager
def quiet_loggers() -> Iterator[None]:
    """:func:`mute_loggers` meanwhile; the levels are put back at the end."""
    levels = mute_loggers()
    try:
        yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


@contextlib.contextmanager
def interrupts_held() -> Iterator[None]:
    """SIGINT blocked in this thread meanwhile, and delivered at the end (a
    Ctrl-C then raises KeyboardInterrupt as usual). The threads started
    meanwhile inherit the mask, and so do the worker processes they spawn,
    then and later (a worker restarted after a crash): Ctrl-C at a terminal,
    sent to the whole process group, reaches this process alone, which
    closes the cluster, instead of ending each worker with a traceback."""
    if not hasattr(signal, "pthread_sigmask"):  # not POSIX
        yield
        return
    from multiprocessing import resource_tracker

    # Started here first: the thread that starts it (else Dask's IO loop, at
    # the first worker) is left with SIGINT unblocked, whatever it had.
    resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
