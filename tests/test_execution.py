"""The execution layer: the same results in this process and on a local Dask
cluster, in task order; seeds that depend on the task, not on the workers; a
task that raises or crashes its worker is that task's failure, not the run's."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

from rmdrake import execution
from rmdrake.execution import Execution, TaskFailure, TaskRunner, task_seed


def _draw(index: int) -> float:
    """A task's random number, from its own seed."""
    return float(np.random.default_rng(task_seed(11, index)).standard_normal())


def _fragile(index: int) -> int:
    if index == 12:
        os.abort()  # what a C++ abort inside Drake does to the worker
    if index == 4:
        raise ValueError("no fit")
    return index


def _environment(index: int) -> tuple[str | None, str | None]:
    """What a worker's allocator and OpenMP were told."""
    return os.environ.get(execution.TRIMMED_MALLOC), os.environ.get("OMP_NUM_THREADS")


def test_task_seeds_are_the_task_indexs_not_the_runs_size():
    seeds = [task_seed(3, i) for i in range(50)]
    assert len(set(seeds)) == 50
    assert task_seed(3, 7) == seeds[7]  # whatever the number of tasks
    assert task_seed(4, 7) != seeds[7]
    spawned = np.random.SeedSequence(3).spawn(8)[7].generate_state(1, np.uint64)[0]
    assert task_seed(3, 7) == int(spawned) >> 1


def test_serial_runner_runs_in_order_and_raises():
    runner = TaskRunner(Execution(workers=0))
    with runner:
        assert not runner.parallel
        assert runner.map(_draw, range(5), progress=False) == [
            _draw(i) for i in range(5)
        ]
        with pytest.raises(ValueError, match="no fit"):
            runner.map(_fragile, [4], progress=False)
        out = runner.map(_fragile, [0, 4], progress=False, failures=True)
    assert out == [0, TaskFailure(1, "ValueError: no fit")]


def test_one_task_starts_no_cluster():
    with TaskRunner(Execution(workers=2), tasks=1) as runner:
        assert not runner.parallel


def test_local_cluster_gives_the_serial_results_and_survives_a_crash():
    serial = [_draw(i) for i in range(12)]
    lines: list[str] = []
    with TaskRunner(Execution(workers=2), tasks=12, echo=lines.append) as runner:
        assert runner.parallel
        assert runner.map(_draw, range(12), progress=False) == serial
        # glibc trims as it likes (Dask's 64 kB threshold halved numpy's
        # speed there); one OpenMP thread a worker, as Dask sets
        assert runner.map(_environment, range(2), progress=False) == [(None, "1")] * 2
        # 2 alone, then chunks of 2: the chunk of the crash goes again alone
        out = runner.map(_fragile, range(20), progress=False, failures=True)
        with pytest.raises(ValueError, match="no fit"):  # the task's own error
            runner.map(_fragile, [4, 5], progress=False)
        # the cluster still works after its workers were killed
        assert runner.map(_draw, range(3), progress=False) == serial[:3]
    assert "local Dask cluster of 2 worker processes" in lines[0]
    assert out[4] == TaskFailure(4, "ValueError: no fit")
    assert isinstance(out[12], TaskFailure) and "worker died" in out[12].reason
    assert [o for i, o in enumerate(out) if i not in (4, 12)] == [
        i for i in range(20) if i not in (4, 12)
    ]


def test_the_default_starts_a_cluster_only_for_work_that_outweighs_it(
    monkeypatch,
):
    serial = [_draw(i) for i in range(6)]
    with TaskRunner(Execution(), tasks=6) as runner:  # microseconds of work
        assert runner.map(_draw, range(6), progress=False) == serial
        assert not runner.parallel
    monkeypatch.setattr(execution, "AUTO_START_WORK", -1.0)  # any work outweighs
    with TaskRunner(Execution(), tasks=6) as runner:
        assert not runner.parallel  # not before the first task's time is known
        assert runner.map(_draw, range(6), progress=False) == serial
        assert runner.parallel
        with TaskRunner(runner) as inner:  # one cluster for several studies
            assert inner is runner
        assert runner.map(_draw, range(3), progress=False) == serial[:3]
    assert not runner.parallel


def test_chunks_last_about_half_a_second_and_balance_the_workers():
    assert execution.chunk_size(1e-3, 10_000, 2) == 500  # 0.5 s of 1 ms items
    assert execution.chunk_size(1e-3, 400, 2) == 50  # 4 chunks per worker
    assert execution.chunk_size(2.0, 10_000, 2) == 1  # long items go alone
    assert execution.chunk_size(0.0, 3, 8) == 1
    assert execution.chunk_size(0.1, 10**6, 1600) == 16  # 1.6 s: 1000 tasks/s


def test_a_scheduler_address_sends_the_tasks_there():
    """An external cluster is used whatever the number of tasks (here an
    in-process one: its address is all the runner is given)."""
    from distributed import LocalCluster

    serial = [_draw(i) for i in range(3)]
    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as c:
        lines: list[str] = []
        where = Execution(scheduler=c.scheduler_address)
        with TaskRunner(where, tasks=1, echo=lines.append) as runner:
            assert runner.parallel
            assert runner.map(_draw, range(3), progress=False) == serial
        address = c.scheduler_address
        assert lines[0].startswith(f"tasks run on the Dask cluster at {address}")


def test_execution_refuses_negative_workers():
    with pytest.raises(ValueError, match="workers"):
        Execution(workers=-1)


def _twice(x: float) -> float:
    return 2.0 * x


def _warns(x: float) -> float:
    warnings.warn(f"odd {x}", UserWarning, stacklevel=1)
    return x


@pytest.mark.parametrize("workers", [0, 1])
def test_started_calls_give_the_same_results_here_and_ahead_on_a_cluster(workers):
    """A started call's result, and one that takes it as an argument, are the
    same in this process (run when asked) and on a cluster (run at once); the
    warning a started call raised is raised again here, once."""
    with TaskRunner(Execution(workers=workers), tasks=3) as runner:
        assert runner.parallel == (workers > 0)
        first = runner.start(_draw, 3)
        assert first.on_cluster == (workers > 0)
        second = runner.start(_twice, first)
        warned = runner.start(_warns, 5.0)
        assert runner.map(_draw, range(2), progress=False) == [_draw(0), _draw(1)]
        assert second.result() == 2.0 * _draw(3) and first.result() == _draw(3)
        with pytest.warns(UserWarning, match="odd 5.0"):
            assert warned.result() == 5.0
        with warnings.catch_warnings(record=True) as again:
            warnings.simplefilter("always")
            assert warned.result() == 5.0
        assert not again  # raised once, by the first result()
        after = runner.start(_twice, first)  # a started call already fetched
        assert after.result() == 2.0 * _draw(3)


def _late_block(n: int) -> np.ndarray:
    """n ones (8 n bytes), after 1.2 s: fetched while the caller polls."""
    import time

    time.sleep(1.2)
    return np.ones(n)


def test_a_large_result_started_ahead_is_fetched_whole():
    """A started call whose 80 MB result is still being fetched when a poll of
    the caller's heartbeat wait would time out: the result arrives whole.
    (A timed ``future.result(timeout=)`` there cancels distributed's shared
    fetch and the next one ends in ``UnboundLocalError``.)"""
    with TaskRunner(Execution(workers=1), tasks=2) as runner:
        block = runner.start(_late_block, 10_000_000)
        assert block.on_cluster
        out = block.result()
    assert out.shape == (10_000_000,) and np.all(out == 1.0)


def test_a_started_call_the_cluster_cancelled_is_a_connection_error():
    """A started call whose task the cluster cancelled (as when its scheduler
    goes away): a ConnectionError naming Dask's reason, not the
    ``UnboundLocalError`` of distributed's own ``result()``."""
    import time

    with TaskRunner(Execution(workers=1), tasks=2) as runner:
        slow = runner.start(time.sleep, 30.0)
        slow._future.cancel(reason="a test", msg="cancelled by hand")
        with pytest.raises(ConnectionError, match=r"cancelled the tasks \(a test: "):
            slow.result()
