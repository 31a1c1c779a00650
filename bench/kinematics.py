"""Forward-kinematics speed: tool points per second for P parameter sets x N poses.

P = 500, N = 60 is one Differential Evolution generation of the paper's
calibration (population 500, 5 plates x 12 readings). Run:

    OPENBLAS_NUM_THREADS=1 python bench/kinematics.py
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.kinematics import point_jacobian, tool_points, tool_poses  # noqa: E402
from rmdrake.robot import (  # noqa: E402
    error_parameter_indices,
    error_parameter_names,
    load_robot,
)


def best_time(fn, repeats: int) -> float:
    """Best wall time of ``repeats`` calls (s)."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="rv3sb")
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    model = load_robot(args.robot)
    rng = np.random.default_rng(0)
    N = 60
    q = rng.uniform(model.limits.lower, model.limits.upper, size=(N, model.n_joints))
    dist = rng.uniform(0.005, 0.08, N)
    print(f"robot {model.name}, N = {N} poses, best of {args.repeats}")
    print(f"{'what':<34} {'P':>5} {'time [ms]':>10} {'poses/s':>12}")
    for P in (1, 500):
        tables = model.table + 1e-4 * rng.standard_normal((P, *model.table.shape))
        for label, fn in (
            (
                "tool_points (measurement point)",
                lambda t=tables: tool_points(t, q, dist),
            ),
            ("tool_poses (4x4)", lambda t=tables: tool_poses(t, q)),
        ):
            t = best_time(fn, args.repeats)
            print(f"{label:<34} {P:>5} {t * 1e3:10.3f} {P * N / t:12.4g}")
    idx = error_parameter_indices(model, error_parameter_names(model, "paper"))
    t = best_time(lambda: point_jacobian(model.table, q, idx, dist), args.repeats)
    print(f"{'point_jacobian, 17 params':<34} {1:>5} {t * 1e3:10.3f} {N / t:12.4g}")


if __name__ == "__main__":
    main()
