"""Progress of long computations, for a terminal and for a batch log alike.

On a terminal (stderr is a TTY) progress is a tqdm bar. In batch use (stderr
redirected to a file or a pipe, as a scheduler runs the job) a bar's carriage
returns leave no line a log shows, so :func:`progress_bar` writes plain lines
instead: ``<desc>: <n>/<total> (<pct> %), <elapsed> s[, about <left> s
left][, <postfix>]`` when it starts, then every ``interval`` seconds (30 s,
:data:`BATCH_INTERVAL`, or the environment variable
``RMDRAKE_PROGRESS_INTERVAL``), and when it closes. The time left is the
elapsed time scaled by the work left (the rate so far), so a run sized for
days says so in its first line after ``interval`` seconds; a tqdm bar shows
the same estimate.

A line is written at an update, so a step between two updates longer than
the interval would leave a gap: a bar writes its line one step early when the
last step says the next would end past the interval. The tasks of a Dask
cluster (:mod:`rmdrake.execution`) show no bar of their own: their bars send
their lines (:func:`forward_progress`) to the calling process, which shows
them beside a heartbeat line of its own bar over the tasks
(:func:`progress_heartbeat`, :func:`progress_note`) while it waits.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:  # imported with the first bar (tqdm.auto: 50 ms)
    from tqdm.auto import tqdm

__all__ = [
    "LineProgress",
    "batch_interval",
    "forward_progress",
    "progress_bar",
    "progress_heartbeat",
    "progress_iter",
    "progress_note",
    "restart_silence",
    "silence_progress",
    "simulated_time_progress",
]

BATCH_INTERVAL = 30.0
"""Seconds between two progress lines in batch use (the README's promise: a
line at least this often)."""

INTERVAL_VARIABLE = "RMDRAKE_PROGRESS_INTERVAL"
"""The environment variable that, set to a number of seconds > 0, replaces
:data:`BATCH_INTERVAL` (in this process and the local workers it starts)."""

_SILENT = [False]
"""True in a Dask worker process: its tasks show no progress (the bar over
the tasks, in the calling process, does)."""

MARGIN = 0.05
"""The share of the interval a line comes early, so that a gap stays under the
interval (not at it plus a step)."""

_LAST_LINE = [time.perf_counter()]
"""When this process last wrote a progress line, or began its command
(:func:`restart_silence`), in ``time.perf_counter`` s."""

TERMINAL_DELAY = 2.0
"""s: a lazy bar (:func:`progress_bar`) shows on a terminal after this."""

_SINK: list[Callable[[str], None] | None] = [None]
"""Where this process's bars send their lines instead of showing them (a Dask
worker's :func:`forward_progress`); None: shown here."""


def batch_interval() -> float:
    """s between two progress lines: ``RMDRAKE_PROGRESS_INTERVAL`` when it is
    a number > 0, else :data:`BATCH_INTERVAL`."""
    try:
        value = float(os.environ.get(INTERVAL_VARIABLE, ""))
    except ValueError:
        return BATCH_INTERVAL
    return value if 0 < value < float("inf") else BATCH_INTERVAL


def restart_silence() -> None:
    """Counts this process's silence from now, as if a line had just been
    written: a command starts (one process may run many, a notebook or a
    test session), so a lazy bar of its first quick step stays quiet."""
    _LAST_LINE[0] = time.perf_counter()


def silence_progress() -> None:
    """Every later :func:`progress_bar` of this process shows nothing (a
    worker process of :mod:`rmdrake.execution`)."""
    _SILENT[0] = True
    _SINK[0] = None


def forward_progress(send: Callable[[str], None]) -> None:
    """Every later :func:`progress_bar` of this process shows nothing here
    but calls ``send(line)`` with each of its lines once it has run for an
    interval (a bar done sooner sends none): a Dask worker's bars, shown by
    the calling process (:func:`progress_note`)."""
    _SILENT[0] = True
    _SINK[0] = send


class _Sent:
    """A file whose whole lines go to ``send`` (a forwarded bar's)."""

    def __init__(self, send: Callable[[str], None]) -> None:
        self.send = send

    def write(self, text: str) -> None:
        self.send(text.rstrip("\n"))

    def flush(self) -> None:
        pass


class LineProgress:
    """The batch form of a tqdm bar: the same ``update``, ``set_postfix``,
    ``close`` and ``n``, written as whole lines to ``file``.

    A line at the start, then at the update that is the last before
    ``interval`` s (default :func:`batch_interval`) since the previous line
    would pass, as far as the last step's time tells, and at the end. Given
    ``since`` (a ``time.perf_counter()`` time), no line at the start: the
    first is due an interval after ``since`` (a bar closed sooner writes
    nothing)."""

    def __init__(
        self,
        *,
        total: float | None,
        desc: str,
        interval: float | None = None,
        file: TextIO | None = None,
        since: float | None = None,
    ) -> None:
        self.total, self.desc = total, desc
        self.interval = batch_interval() if interval is None else float(interval)
        self.file = sys.stderr if file is None else file
        self.n: float = 0
        self._postfix = ""
        self._t0 = time.perf_counter()
        self._step_t = self._t0  # the time of the last update
        self._step = 0.0  # s: the last step's time
        self._closed = False
        self._written_n: float | None = None
        if since is not None:  # the first line due an interval after it
            self._last = since
        else:
            self._last = self._t0
            self._write()

    def _write(self, note: str = "") -> None:
        done = f"{self.n:g}"
        if self.total:
            done += f"/{self.total:g} ({100.0 * self.n / self.total:.0f} %)"
        elapsed = time.perf_counter() - self._t0
        tail = f", {self._postfix}" if self._postfix else ""
        tail += f", {note}" if note else ""
        if self.total and 0 < self.n < self.total and not self._closed:
            left = elapsed * (self.total - self.n) / self.n
            tail = f", about {left:.0f} s left{tail}"
        # One write of the whole line: an interrupt cannot split it from its
        # newline and glue the next message onto it.
        self.file.write(f"{self.desc}: {done}, {elapsed:.0f} s{tail}\n")
        self.file.flush()
        self._written_n = self.n
        self._last = time.perf_counter()
        if not isinstance(self.file, _Sent):
            _LAST_LINE[0] = self._last

    def update(self, n: float = 1) -> None:
        """Advances by ``n``; writes a line if ``interval`` s have passed
        since the last, or would have by the end of another step as long as
        the last one."""
        self.n += n
        now = time.perf_counter()
        self._step, self._step_t = now - self._step_t, now
        if now - self._last + self._step >= self._due:
            self._write()

    @property
    def _due(self) -> float:
        """s after the last line that the next is written: the interval less
        :data:`MARGIN` of it (a poll, the write itself, a step a little
        longer than the last fit in the interval)."""
        return self.interval * (1.0 - MARGIN)

    def heartbeat(self, note: str = "") -> bool:
        """Writes the line again, ``note`` (e.g. ``waiting on 2 tasks``)
        after the count, if ``interval`` s have passed since the last line:
        for a caller that waits between updates. Returns whether it wrote."""
        if self._closed or time.perf_counter() - self._last < self._due:
            return False
        self._write(note)
        return True

    def set_postfix(self, ordered_dict: Any = None, refresh: bool = True, **kw) -> None:
        """Shown after the count on the next line, as ``key=value`` pairs."""
        items = dict(ordered_dict or {}, **kw)
        self._postfix = ", ".join(f"{k}={v}" for k, v in items.items())

    def close(self) -> None:
        """Writes the final line (once; not again when the last update wrote
        that same count, nor for a delayed bar that wrote none)."""
        if not self._closed:
            self._closed = True
            if self._written_n is not None and self.n != self._written_n:
                self._write()

    def __enter__(self) -> LineProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_bar(
    *,
    total: float | None,
    desc: str,
    disable: bool = False,
    leave: bool = False,
    interval: float | None = None,
    lazy: bool = False,
) -> tqdm | LineProgress:
    """A tqdm bar on a terminal, a :class:`LineProgress` in batch use, or a
    disabled tqdm bar (``disable``) that shows nothing. ``lazy``: a step
    that is usually quick (an LM solve): on a terminal, shown after
    :data:`TERMINAL_DELAY` s; in batch use, no start line, the first line
    when this process has written none for an interval. In a Dask worker
    that forwards its progress (:func:`forward_progress`), a
    :class:`LineProgress` whose lines from the ``interval``-th second on go
    to the calling process."""
    from tqdm.auto import tqdm

    # tqdm's monitor is a Python thread; rmdrake starts none: a Meshcat that the
    # collector frees on a thread other than its own aborts the process.
    tqdm.monitor_interval = 0
    if disable:
        return tqdm(total=total, disable=True)
    send = _SINK[0]
    if send is not None:
        return LineProgress(total=total, desc=desc, interval=interval,
                            file=_Sent(send), since=time.perf_counter())  # fmt: skip
    if _SILENT[0]:
        return tqdm(total=total, disable=True)
    if sys.stderr.isatty():
        delay = TERMINAL_DELAY if lazy else 0.0
        return tqdm(total=total, desc=desc, leave=leave, delay=delay)
    since = _LAST_LINE[0] if lazy else None
    return LineProgress(total=total, desc=desc, interval=interval, since=since)


def progress_heartbeat(bar: tqdm | LineProgress, note: str = "") -> bool:
    """For a caller waiting on work that updates ``bar`` rarely: a line in
    batch use (:meth:`LineProgress.heartbeat`, ``note`` after the count) if
    an interval has passed since the last; a terminal's bar shows ``note``
    and is redrawn (its elapsed time). Returns whether an interval had passed
    (a line was written; on a terminal, since the last True): the time to
    show the tasks' own progress (:func:`progress_note`)."""
    if isinstance(bar, LineProgress):
        return bar.heartbeat(note)
    if getattr(bar, "disable", True):
        return False
    bar.set_postfix_str(note, refresh=True)
    now = time.perf_counter()
    last = getattr(bar, "_rmdrake_beat", None)
    if last is None:
        bar._rmdrake_beat = last = now
    if now - last < batch_interval():
        return False
    bar._rmdrake_beat = now
    return True


def progress_note(bar: tqdm | LineProgress, line: str) -> None:
    """Shows ``line`` (a task's forwarded progress) under ``bar``: a line of
    its own in batch use, printed above a terminal's bar; nothing when the
    bar is disabled."""
    if isinstance(bar, LineProgress):
        bar.file.write(f"{line}\n")
        bar.file.flush()
    elif not getattr(bar, "disable", True):
        from tqdm.auto import tqdm

        tqdm.write(line, file=sys.stderr)


def progress_iter(
    iterable: Iterable,
    *,
    desc: str,
    total: int | None = None,
    disable: bool = False,
    lazy: bool = False,
) -> Iterator:
    """Iterates ``iterable`` with a :func:`progress_bar` (``total`` default
    ``len(iterable)`` when it has one; ``lazy``: shown only when the process
    has been silent for an interval); the bar closes when the loop ends."""
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    bar = progress_bar(total=total, desc=desc, disable=disable, leave=True, lazy=lazy)
    try:
        for item in iterable:
            yield item
            bar.update(1)
    finally:
        bar.close()


@contextmanager
def simulated_time_progress(
    duration: float,
    *,
    desc: str = "simulated s",
    disable: bool = False,
    lazy: bool = False,
) -> Iterator[Callable[[float, float], None]]:
    """A ``progress(t, t_final)`` callback (s) for a simulation of ``duration``
    s (``RunStation``'s ``progress``) that drives a :func:`progress_bar`
    (``lazy``: one of many short runs, shown only when the process has been
    silent for an interval); the bar opens at the first call (a run refused
    before its first step shows none) and closes when the block ends."""
    bar: list = []

    def progress(t: float, t_final: float) -> None:
        if not bar:
            total = round(duration, 3)
            bar.append(progress_bar(total=total, desc=desc, disable=disable, lazy=lazy))
        bar[0].update(t - bar[0].n)

    try:
        yield progress
    finally:
        for b in bar:
            b.close()
