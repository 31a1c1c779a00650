"""Monte Carlo calibration planning on Dask: arms per second, per-task overhead,
bytes moved per task, and the wall time of a 1000-arm plan.

The paper's setup: RV-3SB, the paper's 17 parameters, 5 plates x 12 readings,
2 um noise, true errors of 0.2 mm and 1 mrad standard deviation. Prints:

- arms per second with 0 workers (this process), 1 and 2 local Dask workers,
  on ``--arms`` arms, each run as a whole ``run_plan`` (cluster start-up and
  every worker's first import of pydrake included) and as the steady rate once
  the workers are warm (target: 2 workers >= 1.7x one);
- the per-task overhead: ``--overhead-tasks`` tasks that do nothing, through
  the runner of the steady rate, still warm;
- the bytes a task and its row pickle to (what crosses the network per arm);
- with ``--big N`` (default 1000), the wall time of an N-arm plan on 2 workers.

``--quick`` (for CI, still through a real Dask worker): 2 arms per figure (the
fewest that start a cluster), 0 and 1 worker only, 50 do-nothing tasks, no big
plan. Run on an idle machine:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/plan.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import cloudpickle  # noqa: E402

from rmdrake.calibration.plates.plan import PlatePlan  # noqa: E402
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
        plan=PlatePlan(plates=5, per_plate=12),
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


def _steady(arms: int, workers: int, nothing: int) -> tuple[float, float, float]:
    """(start-up s, arms per s once warm, s per do-nothing task) on one runner
    of ``workers``: started and warmed by one arm per worker, then ``arms``
    arms, then ``nothing`` do-nothing tasks."""
    config = _config(arms)
    tasks = [ArmTask(config, arm, 0) for arm in range(arms)]
    t0 = time.perf_counter()
    with TaskRunner(Execution(workers=workers), tasks=arms) as runner:
        runner.map(plan_arm, tasks[: max(workers, 1)], progress=False)  # warm-up
        t1 = time.perf_counter()
        runner.map(plan_arm, tasks, progress=False)
        t2 = time.perf_counter()
        runner.map(_nothing, range(nothing), progress=False)
        t3 = time.perf_counter()
    return t1 - t0, arms / (t2 - t1), (t3 - t2) / nothing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, help="arms per rate (100; quick 2)")
    parser.add_argument(
        "--big", type=int, help="big plan's arms (1000; quick 0 = skip)"
    )
    parser.add_argument(
        "--overhead-tasks", type=int, help="do-nothing tasks (1000; quick 50)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="CI size: 2 arms, 0 and 1 worker"
    )
    args = parser.parse_args()
    arms = args.arms or (2 if args.quick else 100)
    big = (0 if args.quick else 1000) if args.big is None else args.big
    nothing = args.overhead_tasks or (50 if args.quick else 1000)
    print(
        f"{os.cpu_count()} CPUs, load average before "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}; paper setup, "
        f"{arms} arms per figure"
    )
    config = _config(arms)
    task, row = ArmTask(config, 0, 0), plan_arm(ArmTask(config, 0, 0))
    print(
        f"bytes per task: {len(cloudpickle.dumps(task))} in (the task: config "
        f"with the robot model), {len(pickle.dumps(row))} out (the row)"
    )
    print(f"{'workers':>7} {'whole [s]':>10} {'arms/s':>7} {'start [s]':>10} "
          f"{'warm arms/s':>12} {'task overhead [ms]':>19}")  # fmt: skip
    warm = {}
    for workers in (0, 1) if args.quick else (0, 1, 2):
        whole = _whole(arms, workers)
        start, warm[workers], overhead = _steady(arms, workers, nothing)
        print(
            f"{workers:7d} {whole:10.1f} {arms / whole:7.2f} {start:10.2f} "
            f"{warm[workers]:12.2f} {overhead * 1e3:19.3f}"
        )
    ratios = [f"1 worker / this process: {warm[1] / warm[0]:.2f}x"]
    if 2 in warm:
        ratios.insert(
            0, f"2 workers / 1 worker (warm): {warm[2] / warm[1]:.2f}x (target >= 1.7x)"
        )
    print("; ".join(ratios))
    if big:
        whole = _whole(big, 2)
        print(f"{big}-arm plan on 2 workers: {whole:.0f} s wall")


if __name__ == "__main__":
    main()
