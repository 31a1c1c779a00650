"""Socket calibration (a ball seated in sockets, MUKCa) speed and accuracy.

Synthetic, on the RV-3SB and on the MUKCa Panda (its URDF, when the data
folder exists): true robots 0.3 mm / 0.3 mrad off on every MDH parameter, 4
placements x 2 sockets (50 mm apart) x 25 configurations, 0.02 mm seating
noise per coordinate, ``params="full"`` (the subset sockets identify well).

* held-out ball error: over ``--seeds`` simulations (placements and noise
  differ), the 3-D error at 200 random configurations after the best rigid
  alignment (sockets cannot see the base frame), mean per simulation: the
  mean over simulations and the worst, against 2 x the noise;
* reported std against the spread: ``--draws`` noise draws on the same
  placements and configurations (each row seated again by IK from its
  noise-free configuration), per kept parameter the std of the estimate over
  the draws / the RMS of its reported std, min / median / max, and the same
  with only the first 20 draws;
* fit time (median).

``--quick`` (for CI): 3 simulations and 10 draws. Run:

    OPENBLAS_NUM_THREADS=1 python bench/socket_calibration.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.calibration.points.simulate import random_point_poses  # noqa: E402
from rmdrake.calibration.sockets.data import SocketMeasurements  # noqa: E402
from rmdrake.calibration.sockets.lm import SocketLM  # noqa: E402
from rmdrake.calibration.sockets.simulate import simulate_sockets  # noqa: E402
from rmdrake.kinematics.compare import rigid_alignment  # noqa: E402
from rmdrake.kinematics.forward import tool_points  # noqa: E402
from rmdrake.kinematics.ik import solve_tool_ik  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.model.perturb import perturb_robot  # noqa: E402

NOISE = 2e-5
MUKCA = Path(__file__).resolve().parents[2] / "shared" / "data" / "mukca_panda"


def aligned_errors(model, true, q) -> np.ndarray:
    """(len(q),) 3-D ball errors of ``model`` against ``true`` after the best
    rigid alignment, m."""
    a = tool_points(model.table, q, sigma=model.sigma)
    b = tool_points(true.table, q, sigma=true.sigma)
    X = rigid_alignment(a, b)
    return np.linalg.norm(a @ X[:3, :3].T + X[:3, 3] - b, axis=1)


def study(nominal, seeds: int, draws: int) -> None:
    true, _ = perturb_robot(
        nominal, params="full", length_std=3e-4, angle_std=3e-4, seed=1
    )
    held = random_point_poses(nominal, 200, np.random.default_rng(99))
    means, times = [], []
    for seed in range(seeds):
        sim = simulate_sockets(true, noise=NOISE, seed=seed)
        t0 = time.perf_counter()
        est = SocketLM(nominal, params="full", noise=NOISE).fit(sim.data)
        times.append(time.perf_counter() - t0)
        means.append(aligned_errors(est.model_, true, held).mean())
    means = np.array(means)
    print(
        f"{nominal.name}: {len(est.names_)} parameters + 8 sockets; fit median "
        f"{np.median(times) * 1e3:.0f} ms; held-out ball error (mean over 200 "
        f"configurations) over {seeds} simulations: mean {means.mean() * 1e6:.1f} "
        f"um, worst {means.max() * 1e6:.1f} um (target <= 2 x noise = "
        f"{2 * NOISE * 1e6:.0f} um); nominal "
        f"{aligned_errors(nominal, true, held).mean() * 1e6:.0f} um"
    )
    clean = simulate_sockets(true, noise=0, seed=3)
    d = clean.data
    names = SocketLM(nominal, params="full").fit(d).names_
    rng = np.random.default_rng(11)
    values, stds = [], []
    for _ in range(draws):
        target = clean.p_B + NOISE * rng.standard_normal(clean.p_B.shape)
        q = solve_tool_ik(true, d.q, target).q
        est = SocketLM(nominal, params=names).fit(
            SocketMeasurements(d.socket, q, d.distances)
        )
        values.append(est.deltas_)
        stds.append(est.std_)
    values, stds = np.array(values), np.array(stds)
    for count in sorted({min(20, draws), draws}):
        ratio = np.std(values[:count], axis=0, ddof=1) / np.sqrt(
            np.mean(stds[:count] ** 2, axis=0)
        )
        inside = int(np.sum((ratio >= 0.7) & (ratio <= 1.4)))
        print(
            f"  spread over {count} draws / reported std: min {ratio.min():.2f}, "
            f"median {np.median(ratio):.2f}, max {ratio.max():.2f}; {inside} of "
            f"{ratio.size} parameters in 0.7-1.4"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, help="simulations (20; quick 3)")
    parser.add_argument("--draws", type=int, help="noise draws (60; quick 10)")
    parser.add_argument("--quick", action="store_true", help="CI size")
    args = parser.parse_args()
    seeds = args.seeds or (3 if args.quick else 20)
    draws = args.draws or (10 if args.quick else 60)
    study(load_robot("rv3sb"), seeds, draws)
    if (MUKCA / "panda.urdf").exists():
        with warnings.catch_warnings():  # kinematic-only URDF: one warning
            warnings.simplefilter("ignore")
            panda = load_robot(
                MUKCA / "panda.urdf", base="panda_link0", tip="ball_link"
            )
        study(panda, seeds, draws)
    else:
        print(f"(no MUKCa Panda at {MUKCA}: its rows skipped)")


if __name__ == "__main__":
    main()
