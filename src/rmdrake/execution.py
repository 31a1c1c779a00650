"""Where many independent tasks run: in this process, or on a Dask cluster.

Every command and study that loops over robots, seeds or candidates hands its
loop to a :class:`TaskRunner`; nothing else in rmdrake starts a process.

- ``Execution(workers=0)``: in this process, one task after another (for
  debugging: a breakpoint or a traceback lands in your code).
- ``Execution(workers=N)``: a local Dask cluster of N worker processes, one
  thread each, started on entry and stopped on exit. Its start-up and each
  worker's first import of pydrake cost seconds, so a runner given one task,
  or none, runs it here.
- ``Execution()``, the default of the commands: one worker per core, started
  only when the work outweighs that: the first task of a batch runs here,
  timed, and the cluster starts if that time times the tasks left exceeds
  :data:`AUTO_START_WORK` (10 s).
- ``Execution(scheduler="tcp://host:8786")``: an existing Dask cluster
  (``dask scheduler`` and ``dask worker`` started by the user on any number of
  machines, each with rmdrake installed). It must answer within 10 s, checked
  before anything is written.

Local workers are bounded by the machine (four a core, and what the memory
holds). They start with SIGINT blocked: a Ctrl-C at the terminal interrupts
this process, which stops them, instead of printing a traceback from each.
These rules live in :mod:`rmdrake.clusters`.

Drake's ``MultibodyPlant``, ``Context`` and ``Diagram`` do not pickle: a task
receives the robot model (a plain dataclass) and builds its plant in the
worker. Results do not depend on where tasks run: a task's randomness comes
from :func:`task_seed` (the run's seed and the task's index, through
``numpy.random.SeedSequence``), Dask's worker processes use one BLAS thread
(its default), and :meth:`TaskRunner.map` returns results in task order. A
local cluster's workers keep glibc's own memory trimming (Dask's
``MALLOC_TRIM_THRESHOLD_`` made numpy-heavy tasks twice as slow there:
:data:`TRIMMED_MALLOC`).

Progress: a task on a worker shows no bar of its own; its bars that run for
longer than the progress interval (30 s, :mod:`rmdrake.progress`) send their
lines to the calling process (Dask events, topic :data:`PROGRESS_TOPIC`).
While it waits, the caller writes a heartbeat line of its bar over the tasks
at each interval (``true robots: 0/6 (0 %), 95 s, waiting on 2 tasks``, the
time left once a task has finished), each running task's newest line below
it.

Faults: a task whose worker dies (a SIGKILL, the machine lost) is run again on
another worker; one that keeps killing its workers (a C++ abort inside Drake)
and, with ``failures=True``, one that raises, becomes a :class:`TaskFailure`
with the reason, and the other tasks go on.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import importlib.util
import logging
import math
import os
import threading
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

import numpy as np

from rmdrake.clusters import (
    SCHEDULER_TIMEOUT,
    check_scheduler,
    check_workers,
    default_workers,
    interrupts_held,
    quiet_loggers,
)
from rmdrake.progress import (
    batch_interval,
    forward_progress,
    progress_bar,
    progress_heartbeat,
    progress_note,
)

__all__ = [
    "Execution",
    "Pending",
    "TaskFailure",
    "TaskRunner",
    "chunk_size",
    "task_seed",
]

AUTO_START_WORK = 10.0
"""s: the default execution starts a local cluster when the first task's time
times the tasks left exceeds this (its start-up and the workers' first import
of pydrake take a few seconds)."""

TASK_SECONDS = 0.5
"""s: how long one Dask task should last. The scheduler spends about a
millisecond per task and a worker a round trip of a few ms between two: items
shorter than this go in chunks (:func:`chunk_size`), so a cluster of
hundreds of workers keeps its scheduler under a few thousand tasks per second."""

MAX_TASK_RATE = 1000.0
"""Tasks per second a cluster's scheduler is given at most (it spends about a
millisecond on each): 2000 workers get tasks of 2 s."""

ALLOWED_WORKER_DEATHS = 2
"""On a local cluster, a task that kills this many workers and then one more is
failed, not retried (a crash inside Drake kills each worker that runs it); an
external cluster's scheduler keeps its own setting
(``distributed.scheduler.allowed-failures``, 3 by default)."""


_SCHEDULER_CONFIG = {
    "distributed.scheduler.allowed-failures": ALLOWED_WORKER_DEATHS,
    # One task per worker thread at a time: a worker that dies takes only the
    # task it was running with it, so only that task is blamed (at Dask's
    # default, 1.1, a second task waits there and is blamed too).
    "distributed.scheduler.worker-saturation": 1.0,
}
TRIMMED_MALLOC = "MALLOC_TRIM_THRESHOLD_"
"""The environment variable Dask sets in its local workers (to 65536 bytes) so
that glibc hands freed memory back to the system at once; left out of ours.
Every large numpy temporary then costs fresh page faults, which doubled a
calibration seed's time on such a worker."""


def _worker_environment() -> dict[str, Any]:
    """Dask's ``distributed.nanny.pre-spawn-environ`` without
    :data:`TRIMMED_MALLOC` (one BLAS and OpenMP thread a worker, as Dask
    sets)."""
    import dask

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    env.pop(TRIMMED_MALLOC, None)
    return env


PROGRESS_TOPIC = "rmdrake-progress"
"""The Dask event topic of the progress lines a task's bars send (each event
``{"key": task key, "line": line}``)."""

_POLL = 0.1
"""s: how often a caller waiting on tasks checks whether a heartbeat is due
(as_completed's own wait)."""


def task_seed(seed: int, index: int) -> int:
    """The seed of task ``index`` of a run seeded by ``seed``: the first 63-bit
    word of ``SeedSequence(seed).spawn(index + 1)[index]``, the same whatever the
    number of tasks, workers or machines."""
    child = np.random.SeedSequence(int(seed), spawn_key=(int(index),))
    return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))


@dataclasses.dataclass(frozen=True)
class Execution:
    """Where a run's tasks go.

    Attributes:
      workers: local worker processes; None: one per core
        (:func:`default_workers`); 0: none, tasks run in this process.
      scheduler: address of an existing Dask scheduler (``tcp://host:port``);
        when given, ``workers`` is not used.
    """

    workers: int | None = None
    scheduler: str | None = None

    def __post_init__(self) -> None:
        if self.workers is not None and self.workers < 0:
            raise ValueError(f"workers: expected >= 0, got {self.workers}")
        if self.workers is not None and self.scheduler is None:
            check_workers(self.workers)  # the machine's bound

    @property
    def auto(self) -> bool:
        """The default: a local cluster started when the work outweighs it."""
        return self.scheduler is None and self.workers is None

    @property
    def in_process(self) -> bool:
        """Tasks run in this process, one after another."""
        return self.scheduler is None and self.workers == 0

    def describe(self) -> str:
        """One line: where the tasks run."""
        if self.scheduler is not None:
            return f"the Dask cluster at {self.scheduler}"
        if self.workers == 0:
            return "this process (serially)"
        n = default_workers() if self.workers is None else self.workers
        return f"a local Dask cluster of {n} worker process{'es' * (n != 1)}"


SERIAL = Execution(workers=0)
"""In this process, one task after another."""


@dataclasses.dataclass(frozen=True)
class TaskFailure:
    """A task that did not return: its index and why (one line)."""

    index: int
    reason: str


def _guarded(fn: Callable[[Any], Any], index: int, item: Any) -> Any:
    """Runs ``fn(item)`` in the worker; an exception becomes a
    :class:`TaskFailure` naming its type and message (the traceback's last
    line: the rest stays in the worker)."""
    try:
        return fn(item)
    except Exception as e:  # a failed task is a result, not the run's end
        last = traceback.format_exception_only(e)[-1].strip()
        return TaskFailure(index, last)


def _send_progress(line: str) -> None:
    """A progress line of the task running in this worker thread, sent to the
    calling process as a Dask event (:data:`PROGRESS_TOPIC`); nothing outside
    a worker."""
    from distributed import get_worker

    try:
        worker = get_worker()
        key = worker.get_current_task()
    except (ValueError, KeyError):  # not in a worker's task
        return
    worker.log_event(PROGRESS_TOPIC, {"key": key, "line": line})


def _quiet_worker(caller: int) -> None:
    """In a process other than the ``caller``'s (pid): its bars send their
    lines to the caller (:func:`_send_progress`) instead of showing them."""
    if os.getpid() != caller:
        forward_progress(_send_progress)


def _task_label(group: Sequence[int]) -> str:
    """``task 3`` or ``tasks 3-7``: the task indices of a chunk."""
    if len(group) == 1:
        return f"task {group[0]}"
    return f"tasks {group[0]}-{group[-1]}"


class _Forwarded:
    """The progress lines tasks sent (:data:`PROGRESS_TOPIC`), shown under the
    caller's bar at a heartbeat: each running task's newest line not yet
    shown, labelled by ``label(key)`` (None: not a task of this wait)."""

    def __init__(self, client: Any, label: Callable[[Any], str | None]) -> None:
        self.client, self.label = client, label
        self.shown: dict[Any, float] = {}

    def show(self, bar: Any) -> None:
        """Writes the new lines under ``bar``."""
        try:
            events = self.client.get_events(PROGRESS_TOPIC)
        except Exception:  # noqa: BLE001 - progress must not end a run
            return
        newest: dict[Any, tuple[float, str]] = {}
        for stamp, msg in events:
            key = msg.get("key") if isinstance(msg, dict) else None
            if key is None or stamp <= self.shown.get(key, -math.inf):
                continue
            newest[key] = (stamp, str(msg.get("line", "")))
        for key, (stamp, line) in newest.items():
            label = self.label(key)
            if label is not None:
                self.shown[key] = stamp
                progress_note(bar, f"  [{label}] {line}")


def _wait_with_heartbeat(done: Any, bar: Any, forwarded: _Forwarded) -> Iterator[list]:
    """``done.batches()`` (a distributed ``as_completed``) that, while no
    task finishes, writes ``bar``'s heartbeat line at each progress interval
    (:func:`progress_heartbeat`: the tasks waited on, the time left once
    known) and under it the tasks' own newest lines."""
    while True:
        if done.has_ready():
            yield done.next_batch(block=False)
            continue
        if done.is_empty():
            return
        with done.thread_condition:  # as as_completed's own wait
            done.thread_condition.wait(timeout=_POLL)
        if done.has_ready():
            continue
        waiting = len(done.futures)
        note = f"waiting on {waiting} task{'s' * (waiting != 1)}"
        if progress_heartbeat(bar, note):
            forwarded.show(bar)


def _cancelled(future: Any, error: BaseException | None = None) -> ConnectionError:
    """The error for a task the cluster cancelled (``future.status`` is
    ``cancelled``: the client lost its scheduler, which was stopped or
    restarted): what Dask gave as the reason, on one line, e.g. ``the Dask
    cluster cancelled the tasks (scheduler-connection-lost: Client lost the
    connection to the scheduler. ...)``."""
    if error is None:
        error = getattr(getattr(future, "_state", None), "exception", None)
    reason = getattr(error, "reason", None) or "no reason given"
    msg = getattr(error, "msg", None)
    why = f"{reason}: {msg}" if msg else reason
    return ConnectionError(f"the Dask cluster cancelled the tasks ({why})")


def _result_with_heartbeat(future: Any, name: str) -> Any:
    """``future.result()``, with a line every progress interval while it
    runs (``waiting on <name>, a task started ahead``) and the task's own
    newest lines under it.

    It waits on the future's done callback, not on ``future.result(timeout=)``:
    distributed's timed wait can end with neither a result nor an error (an
    ``UnboundLocalError`` inside ``Client.sync`` when its timeout races the
    task's end), so the result is read once, when the task is done."""
    finished = threading.Event()
    future.add_done_callback(lambda _: finished.set())
    if finished.wait(min(1.0, batch_interval())):
        return _done_result(future)
    desc = f"waiting on {name}, a task started ahead"
    bar = progress_bar(total=None, desc=desc, lazy=True)
    key = future.key
    forwarded = _Forwarded(future.client, lambda k: "task" if k == key else None)
    try:
        while not finished.wait(_POLL):
            if progress_heartbeat(bar):
                forwarded.show(bar)
        return _done_result(future)
    finally:
        bar.close()


def _done_result(future: Any) -> Any:
    """A done future's result; a cancelled one's :func:`_cancelled` (its
    ``result()`` would end in distributed's ``UnboundLocalError``)."""
    if future.cancelled():
        raise _cancelled(future)
    return future.result()


def _run_chunk(
    fn: Callable[[Any], Any],
    failures: bool,
    indices: list[int],
    items: list[Any],
    caller: int,
) -> tuple[float, list[Any]]:
    """A task as a worker runs it: no progress bars of its own in a process
    other than the ``caller``'s (pid; a cluster of threads in the caller's
    process keeps the caller's bars), then each item through :func:`_guarded`
    (``failures``) or the plain call; returns the chunk's wall time (s) and
    its results."""
    _quiet_worker(caller)
    t0 = time.perf_counter()
    if failures:
        out = [_guarded(fn, i, item) for i, item in zip(indices, items, strict=True)]
    else:
        out = [fn(item) for item in items]
    return time.perf_counter() - t0, out


def _died(index: int) -> TaskFailure:
    """The failure of a task whose workers kept dying."""
    return TaskFailure(
        index,
        "its worker died each time it ran (a crash inside Drake, or out of memory)",
    )


def chunk_size(seconds: float, items: int, workers: int) -> int:
    """Items per task: enough that a task lasts about :data:`TASK_SECONDS`
    (an item takes ``seconds``), longer on a cluster so big that the workers
    would send its scheduler over :data:`MAX_TASK_RATE` tasks a second; but
    at least 4 tasks per worker over the ``items`` left, so the workers
    finish together."""
    task = max(TASK_SECONDS, workers / MAX_TASK_RATE)
    by_time = math.ceil(task / max(seconds, 1e-6))
    by_balance = max(1, items // (4 * workers))
    return max(1, min(by_time, by_balance))


_TASK_WARNINGS: dict[str, dict] = {}
"""Per source file, the registry of the task warnings raised again (shown once
per text and line, as a warning raised here would be)."""


def _warned_call(call: Callable[[], Any]) -> tuple[Any, list[tuple]]:
    """``call()`` and the warnings it raised, (message, category, file, line)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [(w.message, w.category, w.filename, w.lineno) for w in caught]


def _warn_again(caught: list[tuple]) -> None:
    """Raises the warnings a task caught (:func:`_warned_call`) here, each
    shown once per text and line as this process's filters say."""
    for message, category, filename, lineno in caught:
        registry = _TASK_WARNINGS.setdefault(filename, {})
        warnings.warn_explicit(message, category, filename, lineno, registry=registry)


@dataclasses.dataclass(frozen=True)
class _Returned:
    """What a started call returned, with the warnings it raised."""

    value: Any
    caught: list[tuple]


def _started_call(
    fn: Callable[..., Any], args: tuple, kwargs: dict, caller: int
) -> _Returned:
    """A started call as a worker runs it: its arguments that were started
    calls arrive as their :class:`_Returned` (Dask passes a future's result)."""
    _quiet_worker(caller)
    args = tuple(a.value if isinstance(a, _Returned) else a for a in args)
    kwargs = {k: v.value if isinstance(v, _Returned) else v for k, v in kwargs.items()}
    return _Returned(*_warned_call(functools.partial(fn, *args, **kwargs)))


class Pending:
    """A call started ahead of need by :meth:`TaskRunner.start`: on a cluster
    it runs there at once (after the started calls among its arguments); in
    this process it runs when its :meth:`result` is first asked for. Either
    way its warnings are raised again by that first :meth:`result`."""

    def __init__(
        self,
        fn: Callable[..., Any],
        args: tuple,
        kwargs: dict,
        future: Any = None,
    ) -> None:
        self._fn, self._args, self._kwargs, self._future = fn, args, kwargs, future
        self._sent = future is not None
        self._done: _Returned | None = None

    @property
    def on_cluster(self) -> bool:
        """Sent to a cluster when started (False: runs here when asked)."""
        return self._sent

    def result(self) -> Any:
        """The call's return value (its exception, if it raised)."""
        if self._done is None:
            if self._future is not None:
                name = getattr(self._fn, "__name__", "a call")
                self._done = _result_with_heartbeat(self._future, name)
                self._future = None
            else:
                args = tuple(
                    a.result() if isinstance(a, Pending) else a for a in self._args
                )
                kwargs = {
                    k: v.result() if isinstance(v, Pending) else v
                    for k, v in self._kwargs.items()
                }
                self._done = _Returned(
                    *_warned_call(functools.partial(self._fn, *args, **kwargs))
                )
            _warn_again(self._done.caught)
        return self._done.value


class TaskRunner:
    """Runs ``fn(item)`` over items, where :class:`Execution` says.

    A context manager: a local cluster starts on entry (``workers`` N >= 1, and
    ``tasks`` > 1) or, for the default ``Execution()`` (``workers`` None), at
    the first :meth:`imap` whose first task, run here and timed, shows that the
    rest outweighs the cluster's start-up (:data:`AUTO_START_WORK`); it stops
    on exit. A client of an external cluster connects and disconnects.
    ``echo`` gets one line saying where tasks run and, when ``bokeh`` is
    installed, the dashboard's address.

    Given an open runner instead of an :class:`Execution`, ``with
    TaskRunner(runner)`` is that runner: its cluster serves this block too and
    is not stopped at its end (one cluster for several studies).

    ``fn`` must be importable in the workers (a module-level function of an
    installed package, or a ``functools.partial`` of one); items and results
    must pickle.
    """

    def __init__(
        self,
        execution: Execution | TaskRunner = SERIAL,
        *,
        tasks: int | None = None,
        echo: Callable[[str], None] | None = None,
    ) -> None:
        self._shared = execution if isinstance(execution, TaskRunner) else None
        self.execution = (
            execution.execution if isinstance(execution, TaskRunner) else execution
        )
        self._tasks = tasks
        self._echo = echo
        self._client = None
        self._cluster = None
        self._quiet = contextlib.ExitStack()  # Dask's loggers, held quiet
        self._open = False

    @property
    def parallel(self) -> bool:
        """Tasks go to Dask workers (False: this process, so far)."""
        if self._shared is not None:
            return self._shared.parallel
        return self._client is not None

    def __enter__(self) -> TaskRunner:
        if self._shared is not None:
            return self._shared
        self._open = True
        ex = self.execution
        if ex.scheduler is not None:
            self._start()  # the user's cluster: always
        elif not (ex.in_process or ex.auto or self._tasks in (0, 1)):
            self._start()  # auto: started, if at all, by the first imap
        return self

    def _start(self) -> None:
        """Connects to the cluster, or starts the local one: a scheduler
        given by address must answer within 10 s
        (:func:`~rmdrake.clusters.check_scheduler`); a local cluster's
        workers start with SIGINT blocked
        (:func:`~rmdrake.clusters.interrupts_held`), its dashboard (with
        ``bokeh`` installed) on a free port. Dask's loggers are
        quiet until :meth:`close`; a failure to start closes what started."""
        from distributed import Client, LocalCluster

        ex = self.execution
        self._quiet.enter_context(quiet_loggers())
        dashboard = importlib.util.find_spec("bokeh") is not None
        try:
            if ex.scheduler is not None:
                if not ex.scheduler.startswith("inproc://"):  # in this process
                    check_scheduler(ex.scheduler)
                self._client = Client(
                    ex.scheduler, set_as_default=False, timeout=SCHEDULER_TIMEOUT
                )
            else:
                import dask

                n = default_workers() if ex.workers is None else ex.workers
                config = {
                    **_SCHEDULER_CONFIG,
                    "distributed.nanny.pre-spawn-environ": _worker_environment(),
                }
                # read once, by the scheduler and nannies
                with dask.config.set(config), interrupts_held():
                    self._cluster = LocalCluster(
                        n_workers=n,
                        threads_per_worker=1,
                        processes=True,
                        # A free port: the scheduler serves HTTP even with
                        # no dashboard (no bokeh), on 8787 unless told, and
                        # warns when another cluster holds it.
                        dashboard_address=":0",
                        silence_logs=logging.CRITICAL,
                    )
                    self._client = Client(self._cluster, set_as_default=False)
        except BaseException:
            self.close()
            raise
        if self._echo is not None:
            line = f"tasks run on {ex.describe()}"
            if dashboard and self._client.dashboard_link:
                line += f"; dashboard {self._client.dashboard_link}"
            self._echo(line)

    def __exit__(self, *exc: object) -> None:
        if self._shared is None:
            self.close()

    def close(self) -> None:
        """Disconnects from the cluster, and stops it if it is ours."""
        client, cluster = self._client, self._cluster
        self._client = self._cluster = None
        self._open = False
        try:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
        finally:
            self._quiet.close()

    def imap(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        indices: Sequence[int] | None = None,
        desc: str = "tasks",
        progress: bool = True,
        failures: bool = False,
    ) -> Iterator[tuple[int, Any]]:
        """Yields ``(index, fn(item))`` as tasks finish (in task order in this
        process, in any order on a cluster), with a progress bar over them.

        Args:
          fn, items: the work.
          indices: each item's task index (default ``range(len(items))``):
            what a :class:`TaskFailure` and the yielded pairs carry.
          desc: the progress bar's label.
          progress: show it.
          failures: a task that raises, or whose workers keep dying, yields a
            :class:`TaskFailure` and the others go on (False: the exception
            ends the run).
        """
        if self._shared is not None:
            yield from self._shared.imap(
                fn, items, indices=indices, desc=desc, progress=progress,
                failures=failures,
            )  # fmt: skip
            return
        idx = list(range(len(items))) if indices is None else list(indices)
        if len(idx) != len(items):
            raise ValueError("indices: expected one per item")
        bar = progress_bar(total=len(items), desc=desc, disable=not progress)
        try:
            first = 0
            if self._client is None and self._auto_pending(len(items)):
                t0 = time.perf_counter()
                out = _guarded(fn, idx[0], items[0]) if failures else fn(items[0])
                bar.update(1)
                yield idx[0], out
                first = 1
                rest = (time.perf_counter() - t0) * (len(items) - 1)
                if rest > AUTO_START_WORK:
                    self._start()
            if self._client is None:
                for i, item in zip(idx[first:], items[first:], strict=True):
                    out = _guarded(fn, i, item) if failures else fn(item)
                    bar.update(1)
                    yield i, out
                return
            yield from self._imap_dask(fn, items[first:], idx[first:], bar, failures)
        finally:
            bar.close()

    def start_cluster(self) -> bool:
        """For the default execution, inside ``with``: starts the local
        cluster now, without timing a first task (the caller knows the work
        outweighs the start-up); returns :attr:`parallel`. Nothing changes
        for another execution or a cluster already running."""
        if self._shared is not None:
            return self._shared.start_cluster()
        if self._client is None and self._open and self.execution.auto:
            self._start()
        return self.parallel

    def _auto_pending(self, n: int) -> bool:
        """The default execution, inside ``with``, no cluster yet, and more
        than one task: time the first here to decide."""
        return self._open and self.execution.auto and n > 1

    def _imap_dask(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        idx: list[int],
        bar: Any,
        failures: bool,
    ) -> Iterator[tuple[int, Any]]:
        """The cluster's side of :meth:`imap`: the first task per worker goes
        alone and is timed in the worker; the rest go in chunks of k items
        (:func:`chunk_size`), so a task lasts about :data:`TASK_SECONDS`
        whatever the item's size. A chunk whose workers keep dying is sent
        again item by item, one item at a time (a few tasks at once are not
        queued by the scheduler but placed on workers at once, so one could
        wait on the worker another kills and be blamed with it): only the
        item that crashes them fails."""
        from distributed import as_completed
        from distributed.scheduler import KilledWorker

        client = self._client
        assert client is not None
        workers = max(1, sum(client.nthreads().values()))
        position = dict(zip(idx, range(len(idx)), strict=True))
        todo = list(idx)
        chunks: dict[str, list[int]] = {}
        suspects: collections.deque[int] = collections.deque()
        alone: str | None = None  # the key of the suspect running, if any

        def submit(group: list[list[int]]) -> list:
            futures = client.map(  # one batch: the function is sent once
                _run_chunk,
                [fn] * len(group),
                [failures] * len(group),
                group,
                [[items[position[i]] for i in g] for g in group],
                [os.getpid()] * len(group),
                pure=False,
            )
            chunks.update({f.key: g for f, g in zip(futures, group, strict=True)})
            return futures

        first, todo = todo[:workers], todo[workers:]
        done = as_completed(
            submit([[i] for i in first]),
            loop=client.loop,
            with_results=True,
            raise_errors=False,
        )
        forwarded = _Forwarded(
            client, lambda key: _task_label(chunks[key]) if key in chunks else None
        )
        try:  # results fetched together, not one by one
            for batch in _wait_with_heartbeat(done, bar, forwarded):
                for future, out in batch:
                    group = chunks.pop(future.key)
                    if future.key == alone:
                        alone = None
                    failed = future.status == "error"  # before release changes it
                    if future.status == "cancelled":  # the scheduler went away
                        raise _cancelled(future, out)
                    future.release()
                    seconds = None
                    if not failed:
                        seconds, results = out
                    else:
                        _, error, traceback_ = out  # as as_completed gives it
                        if not failures or not isinstance(error, KilledWorker):
                            raise error.with_traceback(traceback_)
                        if len(group) > 1:  # find the item that kills them
                            suspects.extend(group)
                            group = []
                        results = [_died(i) for i in group]
                    if suspects and alone is None:
                        (suspect,) = submit([[suspects.popleft()]])
                        alone = suspect.key
                        done.add(suspect)
                    if todo:  # the first timing sizes every other chunk
                        k = (
                            1
                            if seconds is None
                            else chunk_size(seconds / len(group), len(todo), workers)
                        )
                        rest = [todo[j : j + k] for j in range(0, len(todo), k)]
                        todo = []
                        for f in submit(rest):
                            done.add(f)
                    for i, result in zip(group, results, strict=True):
                        bar.update(1)
                        yield i, result
        finally:
            client.cancel([f for f in done.futures if not f.done()])

    def map(
        self,
        fn: Callable[[Any], Any],
        items: Iterable[Any],
        *,
        desc: str = "tasks",
        progress: bool = True,
        failures: bool = False,
    ) -> list[Any]:
        """``[fn(item) for item in items]``, run as tasks, in task order (see
        :meth:`imap` for the arguments)."""
        items = list(items)
        out: list[Any] = [None] * len(items)
        for i, result in self.imap(
            fn, items, desc=desc, progress=progress, failures=failures
        ):
            out[i] = result
        return out

    def run_calls(
        self,
        calls: Sequence[Callable[[], Any]],
        *,
        desc: str = "tasks",
        progress: bool = True,
    ) -> list[Any]:
        """Runs each of ``calls`` (a :func:`functools.partial` of a module-level
        function, its arguments plain data that pickles) as a task; returns
        their results in order. The warnings a call raised are raised again
        here, in call order, once every call has returned (this process's
        filters decide what is shown), so the output is the same wherever the
        tasks ran."""
        out = self.map(_warned_call, calls, desc=desc, progress=progress)
        for _, caught in out:
            _warn_again(caught)
        return [result for result, _ in out]

    def start(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Pending:
        """``fn(*args, **kwargs)`` started ahead of need: on a cluster that is
        running, a task sent now, behind every task of :meth:`imap` (lower
        priority: those run first when a worker frees), so that work of a
        later step fills the workers while this process does something else;
        otherwise kept, to run here when asked for. Arguments that are
        :class:`Pending` are their results (the task waits for them). ``fn``
        and the arguments must pickle, as for :meth:`run_calls`."""
        if self._shared is not None:
            return self._shared.start(fn, *args, **kwargs)
        if self._client is None:
            return Pending(fn, args, kwargs)

        def sent(a: Any) -> Any:
            """A started call's future (its value once fetched); else ``a``."""
            if not isinstance(a, Pending):
                return a
            return a._future if a._future is not None else _Returned(a.result(), [])

        future = self._client.submit(
            _started_call,
            fn,
            tuple(sent(a) for a in args),
            {k: sent(v) for k, v in kwargs.items()},
            os.getpid(),
            pure=False,
            priority=-1,
        )
        return Pending(fn, args, kwargs, future)

    def scipy_map(self, func: Callable[[Any], Any], iterable: Iterable[Any]) -> list:
        """A map for scipy's ``workers=`` (``differential_evolution`` with
        ``updating="deferred"``): one generation's population as tasks, no
        progress bar, results in order."""
        return self.map(func, iterable, progress=False)
