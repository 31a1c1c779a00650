"""Kinematics speed: tool points per second for P parameter sets x N poses,
and the tool IK (:func:`rmdrake.kinematics.ik.solve_tool_ik`) batched and one at a time.

P = 500, N = 60 is one Differential Evolution generation of the paper's
calibration (population 500, 5 plates x 12 readings). IK: full-pose targets
at random joint positions of the middle 80 % of the ranges, seeded 0.05 (rad
or m) off, 1000 at once and then one by one (the single-problem fast path).
``--robot`` takes a shipped name or a robot YAML (one with prismatic joints
too). ``--quick`` (for CI, a few seconds on one core) measures the same
calls on P = 1 and 50 parameter sets, 100 IK targets at once and 20 one by
one, best of 3. Run:

    OPENBLAS_NUM_THREADS=1 python bench/kinematics.py [--robot ROBOT] [--quick]
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.kinematics.forward import point_jacobian, tool_points, tool_poses  # noqa: E402
from rmdrake.kinematics.ik import solve_tool_ik  # noqa: E402
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot


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
    parser.add_argument("--repeats", type=int, help="default 20 (3 with --quick)")
    parser.add_argument(
        "--quick", action="store_true", help="small sizes for CI (a few seconds)"
    )
    args = parser.parse_args()
    repeats = args.repeats or (3 if args.quick else 20)
    model = load_robot(args.robot)
    rng = np.random.default_rng(0)
    N = 60
    q = rng.uniform(model.limits.lower, model.limits.upper, size=(N, model.n_joints))
    dist = rng.uniform(0.005, 0.08, N)
    print(f"robot {model.name}, N = {N} poses, best of {repeats}")
    print(f"{'what':<34} {'P':>5} {'time [ms]':>10} {'poses/s':>12}")
    for P in (1, 50 if args.quick else 500):
        tables = model.table + 1e-4 * rng.standard_normal((P, *model.table.shape))
        for label, fn in (
            (
                "tool_points (measurement point)",
                lambda t=tables: tool_points(t, q, dist, sigma=model.sigma),
            ),
            (
                "tool_poses (4x4)",
                lambda t=tables: tool_poses(t, q, sigma=model.sigma),
            ),
        ):
            t = best_time(fn, repeats)
            print(f"{label:<34} {P:>5} {t * 1e3:10.3f} {P * N / t:12.4g}")
    idx = error_parameter_indices(model, error_parameter_names(model, "paper"))
    jac = partial(point_jacobian, model.table, q, idx, dist, sigma=model.sigma)
    t = best_time(jac, repeats)
    label = f"point_jacobian, {len(idx)} params"
    print(f"{label:<34} {1:>5} {t * 1e3:10.3f} {N / t:12.4g}")
    batch, singles = (100, 20) if args.quick else (1000, 200)
    ik_speed(model, rng, repeats, batch, singles)


def ik_speed(
    model, rng: np.random.Generator, repeats: int, batch: int, singles: int
) -> None:
    """Full-pose tool IK: ``batch`` targets at once, then ``singles`` of them
    each alone (best of ``repeats // 4``, at least 1)."""
    lo, hi = model.limits.lower, model.limits.upper
    M = batch
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (M, model.n_joints))
    X = tool_poses(model.table, q, sigma=model.sigma)
    seed = q + 0.05 * rng.choice([-1.0, 1.0], q.shape)
    args = (X[:, :3, 3], X[:, :3, 2], X[:, :3, 0])
    t = best_time(lambda: solve_tool_ik(model, seed, *args), max(1, repeats // 4))
    ik = solve_tool_ik(model, seed, *args)
    ok = int((ik.residual < 1e-9).sum())
    print(f"{'solve_tool_ik, batch (full pose)':<34} {M:>5} {t * 1e3:10.3f} "
          f"{M / t:12.4g}  ({ok} of {M} solved, {ik.iterations.mean():.1f} "
          "steps mean)")  # fmt: skip
    K = singles
    one = [tuple(a[k : k + 1] for a in args) for k in range(K)]

    def singles() -> None:
        for k in range(K):
            solve_tool_ik(model, seed[k : k + 1], *one[k])

    t = best_time(singles, max(1, repeats // 4))
    print(f"{'solve_tool_ik, one at a time':<34} {1:>5} {t / K * 1e3:10.3f} "
          f"{K / t:12.4g}")  # fmt: skip


if __name__ == "__main__":
    main()
