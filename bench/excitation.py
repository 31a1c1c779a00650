"""Excitation design speed and quality: cond(A) against wall time.

    OPENBLAS_NUM_THREADS=1 python bench/excitation.py [--max-time 240] [--seed 0]

Runs the DE design of paper eq. 16-17 on the RV-3SB (5 harmonics, 0.1 Hz,
100 design samples per period) and prints the best cond(A) as the DE goes, then
cond(A) of the result on the full 1500-sample period next to random feasible
trajectories (see ``ExcitationResult``): (a) random coordinates scaled to the
limits like every DE candidate, (b) the same with a random amplitude in (0, 1].
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.excitation.design import design_excitation
from rmdrake.model.loading import load_robot  # noqa: E402


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
    med_a, med_b = np.median(r.random_conds_full), np.median(r.random_conds)
    print(f"cond(A) on 1500 samples: optimised {r.cond:.4g}")
    print(
        f"  random (a) at full amplitude: median {med_a:.4g} -> {med_a / r.cond:.2f}x"
    )
    print(
        f"  random (b) random amplitude:  median {med_b:.4g} -> {med_b / r.cond:.2f}x"
    )


if __name__ == "__main__":
    main()
