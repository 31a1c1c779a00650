"""Identification speed: OLS, WLS, physically consistent LS (cvxpy + Clarabel)
and the paper's DE on the RV-3SB (78 standard, 52 base parameters), the whole
``identify(method="ols")`` pipeline (regressor + fit, no cvxpy), and how
``identify`` scales with the number of samples N (time and peak memory).

    OPENBLAS_NUM_THREADS=1 python bench/identification.py [--quick] [--periods 3]

Part 1. Data: a random feasible Fourier trajectory at 150 Hz, torques from the
regressor of a perturbed (physically valid) RV-3SB plus 1 % Gaussian noise. The
physical fit's time is the estimator's own ``solve_time_`` (problem build +
Clarabel), after one warm-up call (cvxpy's first import and compile).
Every estimator is given the dense observations, so each fit includes its one
reduction of the tall system to triangular factors.

Part 2. For N = 10^3, 10^4, 10^5 (and 10^6 without ``--quick``) random states
(q uniform in +-2.5 rad, qd in +-2 rad/s, qdd in +-6 rad/s^2; seeded) of the
RV-3SB with the torques of a perturbed model plus noise, each N in its own
process (``--point N``; with ``--quick`` all in this one, whose peak resident
memory is then the run's so far, an upper bound): the time of
``identify(method)`` and of ``check_identification`` (best of ``--repeats``
below 10^6 samples, one run at 10^6), the peak of the memory traced
(tracemalloc) during both beyond the inputs, and the process's peak resident
memory (ru_maxrss: imports, inputs and the fit). The largest N that fits in
24 GB is extrapolated linearly: from the peak resident memory at the largest
N, growing as the inputs plus the traced peak grow between the two largest N.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
import tracemalloc

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.dynamics import standard_parameters  # noqa: E402
from rmdrake.dynamics.base import base_parameters  # noqa: E402
from rmdrake.dynamics.data import JointSamples  # noqa: E402
from rmdrake.dynamics.estimators import (  # noqa: E402
    DifferentialEvolutionLeastSquares,
    Observations,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.identification import identify  # noqa: E402
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares  # noqa: E402
from rmdrake.dynamics.regressor import regressor_blocks  # noqa: E402
from rmdrake.dynamics.sanity import check_identification  # noqa: E402
from rmdrake.excitation.design import random_fourier_trajectory  # noqa: E402
from rmdrake.model.dynamic_parameters import perturb_standard_parameters  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402

MEMORY_BUDGET = 24e9
"""Bytes of the machine the largest N is extrapolated for."""


def estimators(args: argparse.Namespace) -> None:
    """Part 1 (module docstring)."""
    model = load_robot("rv3sb")
    rng = np.random.default_rng(0)
    chi = perturb_standard_parameters(standard_parameters(model), rng)
    base = base_parameters(model)
    traj = random_fourier_trajectory(model, fill=0.8, seed=1)
    t, q, qd, qdd = traj.sample(150.0, args.periods)
    Y = base.regressor(model, q, qd, qdd)
    tau = Y @ base.regroup(chi)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    obs = Observations.from_regressor(Y, tau)
    K = base.K_full
    truth = base.regroup(chi)
    print(
        f"RV-3SB: {obs.n_samples} samples x 6 joints, {base.count} base / "
        f"{chi.size} standard parameters; best of {args.repeats}"
    )
    print(f"{'estimator':<38} {'time [s]':>9} {'max rel. base error':>20}")

    def report(label, make, repeats=args.repeats, key=None):
        best, est = np.inf, None
        for _ in range(repeats):
            t0 = time.perf_counter()
            est = make().fit(obs)
            best = min(best, key(est) if key else time.perf_counter() - t0)
        err = np.abs(est.params_ - truth).max() / np.abs(truth).max()
        print(f"{label:<38} {best:9.3f} {err:20.2e}")

    report("OLS (QR)", OrdinaryLeastSquares)
    report("WLS (Gautier)", WeightedLeastSquares)
    if not args.quick:  # cvxpy's import and compile alone take seconds
        PhysicalLeastSquares(K=K).fit(obs)  # warm-up
        for weights in (None, "gautier"):
            report(
                f"physical, Clarabel (weights={weights})",
                lambda w=weights: PhysicalLeastSquares(K=K, weights=w),
                key=lambda e: e.solve_time_,
            )
    samples = JointSamples(t, q, qd, qdd, tau, 150.0)
    best = np.inf
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        result = identify(model, samples, method="ols")
        best = min(best, time.perf_counter() - t0)
    err = np.abs(result.params - truth).max() / np.abs(truth).max()
    print(f"{'identify(method=ols), pipeline':<38} {best:9.3f} {err:20.2e}")
    if args.quick:
        return
    report(
        f"paper's DE (<= {args.de_maxiter} generations)",
        lambda: DifferentialEvolutionLeastSquares(
            prior=K @ standard_parameters(model),
            maxiter=args.de_maxiter,
            progress=False,
        ),
        repeats=1,
    )


def random_samples(N: int, seed: int = 0) -> tuple[JointSamples, np.ndarray]:
    """N random states of the RV-3SB (module docstring) with the torques of a
    perturbed model plus 1 % noise (built block by block), and the true base
    parameters."""
    model = load_robot("rv3sb")
    rng = np.random.default_rng(seed)
    base = base_parameters(model)
    truth = base.regroup(perturb_standard_parameters(standard_parameters(model), rng))
    q = rng.uniform(-2.5, 2.5, (N, 6))
    qd = rng.uniform(-2.0, 2.0, (N, 6))
    qdd = rng.uniform(-6.0, 6.0, (N, 6))
    tau = np.empty((N, 6))
    for s, Y in regressor_blocks(model, q, qd, qdd, base.columns):
        tau[s] = Y @ truth
    tau += 0.01 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    return JointSamples(np.arange(N) / 1000.0, q, qd, qdd, tau, 1000.0), truth


def point(N: int, method: str, repeats: int) -> dict:
    """Part 2 for one N, in this process: figures as a dict (module docstring)."""
    model = load_robot("rv3sb")
    samples, truth = random_samples(N)
    times = {"identify": np.inf, "sanity": np.inf}
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = identify(model, samples, method=method)
        t1 = time.perf_counter()
        check_identification(result)
        t2 = time.perf_counter()
        times["identify"] = min(times["identify"], t1 - t0)
        times["sanity"] = min(times["sanity"], t2 - t1)
    tracemalloc.start()
    base_line = tracemalloc.get_traced_memory()[0]
    check_identification(identify(model, samples, method=method))
    traced = tracemalloc.get_traced_memory()[1] - base_line
    tracemalloc.stop()
    err = np.abs(result.params - truth).max() / np.abs(truth).max()
    arrays = (samples.t, samples.q, samples.qd, samples.qdd, samples.tau)
    return {
        "N": N,
        "inputs_B": sum(a.nbytes for a in arrays),
        "identify_s": times["identify"],
        "sanity_s": times["sanity"],
        "traced_peak_B": traced,
        "maxrss_B": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
        "error": float(err),
    }


def scaling(args: argparse.Namespace) -> None:
    """Part 2: one process per N, then the table and the extrapolation."""
    sizes = [10**3, 10**4, 10**5] + ([] if args.quick else [10**6])
    load = os.getloadavg()
    print(
        f"\nidentify(method={args.method}) + check_identification against N "
        f"(RV-3SB, 6 joints, 52 base parameters; load "
        f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f})"
    )
    head = (
        f"{'N':>9} {'identify [s]':>13} {'sanity [s]':>11} {'us/sample':>10} "
        f"{'traced peak [MB]':>17} {'max RSS [MB]':>13} {'max rel. error':>15}"
    )
    print(head)
    rows = []
    for N in sizes:
        repeats = 1 if N >= 10**6 else args.repeats
        if args.quick:  # in this process: max RSS is then the run's so far
            r = point(N, args.method, repeats)
        else:
            cmd = [sys.executable, __file__, "--point", str(N)]
            cmd += ["--method", args.method, "--repeats", str(repeats)]
            out = subprocess.run(cmd, check=True, capture_output=True, text=True)
            r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(r)
        total = r["identify_s"] + r["sanity_s"]
        print(
            f"{N:>9} {r['identify_s']:>13.3f} {r['sanity_s']:>11.3f} "
            f"{1e6 * total / N:>10.2f} {r['traced_peak_B'] / 1e6:>17.1f} "
            f"{r['maxrss_B'] / 1e6:>13.0f} {r['error']:>15.2e}"
        )
    # Memory that grows with N: the input samples and what identify traces.
    r1, r2 = rows[-2:]
    grown = [r["inputs_B"] + r["traced_peak_B"] for r in (r1, r2)]
    slope = (grown[1] - grown[0]) / (r2["N"] - r1["N"])
    largest = r2["N"] + (MEMORY_BUDGET - r2["maxrss_B"]) / slope
    print(
        f"inputs + traced peak grow {slope:.0f} B per sample (N {r1['N']} .. "
        f"{r2['N']}; the samples t, q, qd, qdd, tau are "
        f"{r2['inputs_B'] / r2['N']:.0f} B): from the max RSS at N = {r2['N']}, "
        f"the largest N in {MEMORY_BUDGET / 1e9:g} GB is about {largest:.2g} "
        "samples (linear extrapolation)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick",
        action="store_true",
        help="under 20 s: no physical fit or DE in part 1, N up to 10^5",
    )
    parser.add_argument("--periods", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--de-maxiter", type=int, default=3000)
    parser.add_argument("--method", default="ols", help="identify's method")
    parser.add_argument("--point", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.repeats is None:
        args.repeats = 1 if args.quick else 5
    if args.point is not None:
        print(json.dumps(point(args.point, args.method, args.repeats)))
        return
    estimators(args)
    scaling(args)


if __name__ == "__main__":
    main()
