"""Thread pools of a process running rmdrake's work (the ``rmdrake`` command,
the examples): one BLAS/OpenMP thread unless the user says otherwise.

rmdrake's linear algebra is small matrices many times over (a 60 x 12 product
per candidate, a QR of a few thousand rows): on two cores OpenBLAS's threads
spend more time handing work to each other than computing (several times
the run time of one thread, CHANGELOG.md). So the command and the examples
set one thread for every BLAS and OpenMP pool themselves, for the libraries
already loaded (threadpoolctl) and, through the environment, for those loaded
later and for child processes. A user who sets
``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` or ``MKL_NUM_THREADS`` keeps
that choice: nothing is changed then. The Python API (``import rmdrake``)
never changes thread settings: that is the calling program's choice.
"""

from __future__ import annotations

import os
import sys

__all__ = ["THREAD_VARIABLES", "one_thread_per_pool"]

THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""The variables that, when the user sets any, leave the thread pools alone."""


def one_thread_per_pool() -> str:
    """Limits every BLAS and OpenMP pool of this process to one thread, unless
    the user set one of :data:`THREAD_VARIABLES`; returns what was done (one
    line, for ``--debug``)."""
    chosen = [v for v in THREAD_VARIABLES if os.environ.get(v)]
    if chosen:
        return f"thread pools left as set by {', '.join(chosen)}"
    for variable in THREAD_VARIABLES:
        os.environ[variable] = "1"  # libraries loaded later read it at load
    if "numpy" in sys.modules:  # a BLAS already loaded: limited in place
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1)
    return "one thread per BLAS/OpenMP pool (set OPENBLAS_NUM_THREADS to change)"
