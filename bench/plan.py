"""Monte Carlo calibration planning on Dask: arms per second, per-task overhead,
bytes moved per task, and the wall time of a 1000-arm plan.

The paper's setup: RV-3SB, the paper's 17 parameters, 5 plates x 12 readings,
2 um noise, true errors of 0.2 mm and 1 mrad standard deviation. Prints:

- arms per second with 0 workers (this process), 1 and 2 local Dask workers,
  on ``--arms`` arms, each run as a whole ``run_plan`` (cluster start-up and
  every worker's first import of pydrake included) and as the steady rate once
  the workers are warm (target: 2 workers >= 1.7x one);
- the per-task overhead: a task that does nothing, through the same runner;
- the bytes a task and its row pickle to (what crosses the network per arm);
- with ``--big N`` (default 1000), the wall time of an N-arm plan on 2 workers.

Run on an idle machine:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/plan.py
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import cloudpickle  # noqa: E402

from rmdrake.execution import Execution, TaskRunner  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.studies.planning import (  # noqa: E402
    ArmTask,
    PlanConfig,
    plan_arm,
    run_plan,
)


def _config(arms: int) -> PlanConfig:
    return PlanConfig(
        robot=load_robot("rv3sb"),
        robots=arms,
        noise=2e-6,
        plates=5,
        per_plate=12,
        length_std=2e-4,
        angle_std=1e-3,
        params="paper",
        target=5e-5,
    )


def _nothing(item: int) -> int:
    return item


def _whole(arms: int, workers: int) -> float:
    """Wall time (s) of a whole ``run_plan`` of ``arms`` arms."""
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        run_plan(
            _config(arms),
            out,
            execution=Execution(workers=workers),
            echo=lambda _: None,
            progress=False,
        )
        return time.perf_counter() - t0


def _steady(arms: int, workers: int) -> tuple[float, float]:
    """(start-up s, arms per s once warm) on a runner of ``workers``."""
    config = _config(arms)
    tasks = [ArmTask(config, arm, 0) for arm in range(arms)]
    t0 = time.perf_counter()
    with TaskRunner(Execution(workers=workers), tasks=arms) as runner:
        runner.map(plan_arm, tasks[: max(workers, 1)], progress=False)  # warm-up
        t1 = time.perf_counter()
        runner.map(plan_arm, tasks, progress=False)
        t2 = time.perf_counter()
    return t1 - t0, arms / (t2 - t1)


def _overhead(tasks: int, workers: int) -> float:
    """Seconds per do-nothing task through a warm runner."""
    with TaskRunner(Execution(workers=workers), tasks=tasks) as runner:
        runner.map(_nothing, range(4), progress=False)
        t0 = time.perf_counter()
        runner.map(_nothing, range(tasks), progress=False)
        return (time.perf_counter() - t0) / tasks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, default=100, help="arms per rate")
    parser.add_argument("--big", type=int, default=1000, help="0: skip")
    args = parser.parse_args()
    print(
        f"{os.cpu_count()} CPUs, load average before "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}; paper setup, "
        f"{args.arms} arms per figure"
    )
    config = _config(args.arms)
    task, row = ArmTask(config, 0, 0), plan_arm(ArmTask(config, 0, 0))
    print(
        f"bytes per task: {len(cloudpickle.dumps(task))} in (the task: config "
        f"with the robot model), {len(pickle.dumps(row))} out (the row)"
    )
    print(f"{'workers':>7} {'whole [s]':>10} {'arms/s':>7} {'start [s]':>10} "
          f"{'warm arms/s':>12} {'task overhead [ms]':>19}")  # fmt: skip
    warm = {}
    for workers in (0, 1, 2):
        whole = _whole(args.arms, workers)
        start, warm[workers] = _steady(args.arms, workers)
        overhead = _overhead(1000, workers) * 1e3
        print(
            f"{workers:7d} {whole:10.1f} {args.arms / whole:7.2f} {start:10.2f} "
            f"{warm[workers]:12.2f} {overhead:19.3f}"
        )
    print(
        f"2 workers / 1 worker (warm): {warm[2] / warm[1]:.2f}x (target >= 1.7x); "
        f"1 worker / this process: {warm[1] / warm[0]:.2f}x"
    )
    if args.big:
        whole = _whole(args.big, 2)
        print(f"{args.big}-arm plan on 2 workers: {whole:.0f} s wall")


if __name__ == "__main__":
    main()
