"""The ``rmdrake`` console script's entry point (``python -m rmdrake.cli``
too): the process's thread pools chosen, then the command run."""

from __future__ import annotations

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

    return run_command(argv)
