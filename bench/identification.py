"""Identification speed: OLS, WLS, physically consistent LS (cvxpy + Clarabel)
and the paper's DE on the RV-3SB (78 standard, 52 base parameters), and the
whole ``identify(method="ols")`` pipeline (regressor + fit, no cvxpy).

    OPENBLAS_NUM_THREADS=1 python bench/identification.py [--periods 3]

Data: a random feasible Fourier trajectory at 150 Hz, torques from the
regressor of a perturbed (physically valid) RV-3SB plus 1 % Gaussian noise. The
physical fit's time is the estimator's own ``solve_time_`` (problem build +
Clarabel), after one warm-up call (cvxpy's first import and compile).
"""

from __future__ import annotations

import argparse
import os
import time

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
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares
from rmdrake.excitation.design import random_fourier_trajectory  # noqa: E402
from rmdrake.model.dynamic_parameters import perturb_standard_parameters  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--de-maxiter", type=int, default=2000)
    args = parser.parse_args()
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
    print(f"{'estimator':<34} {'time [s]':>9} {'max rel. base error':>20}")

    def report(label, make, repeats=args.repeats, key=None):
        best, est = np.inf, None
        for _ in range(repeats):
            t0 = time.perf_counter()
            est = make().fit(obs)
            best = min(best, key(est) if key else time.perf_counter() - t0)
        err = np.abs(est.params_ - truth).max() / np.abs(truth).max()
        print(f"{label:<34} {best:9.3f} {err:20.2e}")

    PhysicalLeastSquares(K=K).fit(obs)  # warm-up: cvxpy import and compile
    report("OLS (QR)", OrdinaryLeastSquares)
    report("WLS (Gautier)", WeightedLeastSquares)
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
    print(f"{'identify(method=ols), pipeline':<34} {best:9.3f} {err:20.2e}")
    report(
        f"paper's DE ({args.de_maxiter} generations)",
        lambda: DifferentialEvolutionLeastSquares(
            prior=K @ standard_parameters(model),
            maxiter=args.de_maxiter,
            progress=False,
        ),
        repeats=1,
    )


if __name__ == "__main__":
    main()
