"""Excitation design speed and quality: cond(A) against wall time.

    OPENBLAS_NUM_THREADS=1 python bench/excitation.py [--max-time 240] [--seed 0]

Runs the DE design of paper eq. 16-17 on the RV-3SB (5 harmonics, 0.1 Hz,
100 design samples per period) and prints the best cond(A) as the DE goes, then
cond(A) of the result on the full 1500-sample period next to random feasible
trajectories: (a) random coordinates scaled to the limits like every DE
candidate, (b) the same with a random overall amplitude in (0, 1] of that.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.excitation import (  # noqa: E402
    ExcitationCost,
    FourierParametrization,
    design_excitation,
)
from rmdrake.robot import load_robot  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="rv3sb")
    parser.add_argument("--max-time", type=float, default=240.0)
    parser.add_argument("--maxiter", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--criterion", default="cond", choices=("cond", "logdet"))
    args = parser.parse_args()
    model = load_robot(args.robot)
    r = design_excitation(
        model,
        seed=args.seed,
        max_time=args.max_time,
        maxiter=args.maxiter,
        criterion=args.criterion,
        n_random=100,
        progress=False,
    )
    print(
        f"robot {model.name}: DE {args.criterion}, {r.generations} generations, "
        f"{r.time:.1f} s ({r.stopped})"
    )
    print(f"{'gen':>5} {'time[s]':>8} {'best (design samples)':>22}")
    step = max(1, len(r.history) // 15)
    for g, t, best in list(r.history[::step]) + [r.history[-1]]:
        print(f"{int(g):>5} {t:8.1f} {best:22.4g}")
    # Baseline (b): random feasible trajectories with a random overall amplitude.
    lim = model.limits
    param = FourierParametrization(model.n_joints, 5)
    from rmdrake.dynamics.base import base_parameters

    t_full = np.arange(1500) / 150.0
    t_dense = np.arange(1000) * 0.01
    cost = ExcitationCost(
        model=model,
        base=base_parameters(model),
        parametrization=param,
        q0=0.5 * (lim.lower + lim.upper),
        base_frequency=0.1,
        times=t_dense,
    )
    rng = np.random.default_rng(args.seed + 2)
    half = np.repeat(
        np.minimum(0.5 * (lim.upper - lim.lower) * 2 * np.pi * 0.1, lim.velocity),
        param.per_joint,
    )
    a, b = cost.coefficients(rng.uniform(-half, half, (100, half.size)))
    s = rng.uniform(0.0, 1.0, (100, 1, 1))
    conds_b = cost.cond(cost.gram(a * s, b * s, t_full))
    med_a, med_b = np.median(r.random_conds), np.median(conds_b)
    print(f"cond(A) on 1500 samples: optimised {r.cond:.4g}")
    print(
        f"  random (a) at full amplitude: median {med_a:.4g} -> {med_a / r.cond:.2f}x"
    )
    print(
        f"  random (b) random amplitude:  median {med_b:.4g} -> {med_b / r.cond:.2f}x"
    )


if __name__ == "__main__":
    main()
