"""The ``rmdrake`` process chooses its BLAS/OpenMP threads (one per pool)
unless the user set them: checked on the pools threadpoolctl reports in a
fresh process, since a pool's size is a process-wide setting."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from rmdrake.threads import THREAD_VARIABLES

PROBE = """
import json, threadpoolctl
from rmdrake.cli.entry import main
main(["show", "--robot", "rv3sb"])
import scipy.linalg  # a library loaded after the command starts
print(json.dumps([i["num_threads"] for i in threadpoolctl.threadpool_info()]))
"""


def _pools(**env: str) -> list[int]:
    clean = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    out = subprocess.run(
        [sys.executable, "-c", PROBE], env={**clean, **env},
        capture_output=True, text=True, check=True, timeout=300,
    ).stdout  # fmt: skip
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.skipif(os.cpu_count() < 2, reason="one core: every pool has 1 thread")
def test_one_thread_per_pool_unless_the_user_set_it():
    assert set(_pools()) == {1}
    assert max(_pools(OPENBLAS_NUM_THREADS="2")) == 2  # the user's choice kept
