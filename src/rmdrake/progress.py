"""Progress of long computations, for a terminal and for a batch log alike.

On a terminal (stderr is a TTY) progress is a tqdm bar. In batch use (stderr
redirected to a file or a pipe, as a scheduler runs the job) a bar's carriage
returns leave no line a log shows, so :func:`progress_bar` writes plain lines
instead: ``<desc>: <n>/<total> (<pct> %), <elapsed> s[, about <left> s
left][, <postfix>]`` when it starts, then at most every ``interval`` seconds,
and when it closes. The time left is the elapsed time scaled by the work left
(the rate so far), so a run sized for days says so in its first line after
``interval`` seconds; a tqdm bar shows the same estimate.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:  # imported with the first bar (tqdm.auto: 50 ms)
    from tqdm.auto import tqdm

__all__ = [
    "LineProgress",
    "progress_bar",
    "progress_iter",
    "silence_progress",
    "simulated_time_progress",
]

BATCH_INTERVAL = 30.0
"""Seconds between two progress lines in batch use."""

_SILENT = [False]
"""True in a Dask worker process: its tasks show no progress (the bar over
the tasks, in the calling process, does)."""


def silence_progress() -> None:
    """Every later :func:`progress_bar` of this process shows nothing (a
    worker process of :mod:`rmdrake.execution`)."""
    _SILENT[0] = True


class LineProgress:
    """The batch form of a tqdm bar: the same ``update``, ``set_postfix``,
    ``close`` and ``n``, written as whole lines to ``file``."""

    def __init__(
        self,
        *,
        total: float | None,
        desc: str,
        interval: float = BATCH_INTERVAL,
        file: TextIO | None = None,
    ) -> None:
        self.total, self.desc, self.interval = total, desc, float(interval)
        self.file = sys.stderr if file is None else file
        self.n: float = 0
        self._postfix = ""
        self._t0 = time.perf_counter()
        self._last = self._t0
        self._closed = False
        self._written_n: float | None = None
        self._write()

    def _write(self) -> None:
        done = f"{self.n:g}"
        if self.total:
            done += f"/{self.total:g} ({100.0 * self.n / self.total:.0f} %)"
        elapsed = time.perf_counter() - self._t0
        tail = f", {self._postfix}" if self._postfix else ""
        if self.total and 0 < self.n < self.total and not self._closed:
            left = elapsed * (self.total - self.n) / self.n
            tail = f", about {left:.0f} s left{tail}"
        # One write of the whole line: an interrupt cannot split it from its
        # newline and glue the next message onto it.
        self.file.write(f"{self.desc}: {done}, {elapsed:.0f} s{tail}\n")
        self.file.flush()
        self._written_n = self.n
        self._last = time.perf_counter()

    def update(self, n: float = 1) -> None:
        """Advances by ``n``; writes a line if ``interval`` s have passed."""
        self.n += n
        if time.perf_counter() - self._last >= self.interval:
            self._write()

    def set_postfix(self, ordered_dict: Any = None, refresh: bool = True, **kw) -> None:
        """Shown after the count on the next line, as ``key=value`` pairs."""
        items = dict(ordered_dict or {}, **kw)
        self._postfix = ", ".join(f"{k}={v}" for k, v in items.items())

    def close(self) -> None:
        """Writes the final line (once; not again when the last update wrote
        that same count)."""
        if not self._closed:
            self._closed = True
            if self.n != self._written_n:
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
    interval: float = BATCH_INTERVAL,
) -> tqdm | LineProgress:
    """A tqdm bar on a terminal, a :class:`LineProgress` in batch use, or a
    disabled tqdm bar (``disable``) that shows nothing."""
    from tqdm.auto import tqdm

    # tqdm's monitor is a Python thread; rmdrake starts none: a Meshcat that the
    # collector frees on a thread other than its own aborts the process.
    tqdm.monitor_interval = 0
    if disable or _SILENT[0]:
        return tqdm(total=total, disable=True)
    if sys.stderr.isatty():
        return tqdm(total=total, desc=desc, leave=leave)
    return LineProgress(total=total, desc=desc, interval=interval)


def progress_iter(
    iterable: Iterable, *, desc: str, total: int | None = None, disable: bool = False
) -> Iterator:
    """Iterates ``iterable`` with a :func:`progress_bar` (``total`` default
    ``len(iterable)`` when it has one); the bar closes when the loop ends."""
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    bar = progress_bar(total=total, desc=desc, disable=disable, leave=True)
    try:
        for item in iterable:
            yield item
            bar.update(1)
    finally:
        bar.close()


@contextmanager
def simulated_time_progress(
    duration: float, *, desc: str = "simulated s", disable: bool = False
) -> Iterator[Callable[[float, float], None]]:
    """A ``progress(t, t_final)`` callback (s) for a simulation of ``duration``
    s (``RunStation``'s ``progress``) that drives a :func:`progress_bar`; the
    bar opens at the first call (a run refused before its first step shows
    none) and closes when the block ends."""
    bar: list = []

    def progress(t: float, t_final: float) -> None:
        if not bar:
            total = round(duration, 3)
            bar.append(progress_bar(total=total, desc=desc, disable=disable))
        bar[0].update(t - bar[0].n)

    try:
        yield progress
    finally:
        for b in bar:
            b.close()
