"""The ``rmdrake`` console script's entry point (``python -m rmdrake.cli``
too): the process's thread pools chosen, then the command run."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from rmdrake.threads import one_thread_per_pool

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``rmdrake`` (:func:`rmdrake.cli.commands.main`: its exit code) with
    one thread per BLAS/OpenMP pool (:func:`one_thread_per_pool`: the measured
    speed-up on small matrices; a user's OPENBLAS_NUM_THREADS wins), set before
    numpy is imported, so that its pool starts with one thread."""
    one_thread_per_pool()
    from rmdrake.cli.commands import main as run_command

    try:
        return run_command(argv)
    finally:
        _quiet_dask_to_the_end()


def _quiet_dask_to_the_end() -> None:
    """Dask's loggers at CRITICAL for the rest of the process, once a command
    that used a cluster is done: a client whose scheduler went away while it
    closed has a reconnect pending, which the interpreter's exit cancels and
    Dask logs as an ERROR with two tracebacks after the command's last line
    (its runner reported what mattered; its files are written)."""
    if "distributed" not in sys.modules:  # no cluster in this command
        return
    from rmdrake.clusters import mute_loggers

    mute_loggers()
