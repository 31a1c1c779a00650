"""Excitation design speed and quality: cond(A) against wall time, old and new.

    OPENBLAS_NUM_THREADS=1 python bench/excitation.py [--quick] [--seed 0]

The paper's design (RV-3SB, 5 harmonics, 0.1 Hz, paper eq. 16-17), twice
through ``design_excitation``:

- old: the objective as it was before the speed-up (kept here only,
  :func:`reference_objective`: each candidate's series evaluated twice, for
  the limits at the design samples and again for A; numpy's batched
  ``eigvalsh``) with the old sizes (100 design samples, popsize 15,
  400 generations);
- new: today's objective (one series at the design and limit samples,
  LAPACK's values-only eigensolver per matrix) at ``design_excitation``'s
  defaults.

Both end alike: the lowest on the full period of the DE's last 16 bests.

For each, every improvement of the best candidate is re-evaluated afterwards
(outside the clock) on the full 1500-sample period (scaled into the limits at
200 samples per harmonic, as the final trajectory is), so the table is
cond(A) on 1500 samples against wall time. Then: cond after the run, seconds
per generation, and when the new run first came within 10 % of the old
run's final cond.

``--quick`` (under 20 s, figures only): seconds per generation of both
objectives on one population, the new objective's parts, and how cond(A) on
S design samples tracks cond(A) on 1500 for random feasible candidates.

The old objective's Fourier sums now run through today's faster
``fourier_series`` (a matmul where it was an einsum), so its figures here are
a little better than the code before the rework.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import os
import time
import timeit
from collections.abc import Callable, Iterator

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.dynamics.base import base_parameters  # noqa: E402
from rmdrake.excitation.design import (  # noqa: E402
    LIMIT_SAMPLES_PER_HARMONIC,
    ExcitationCost,
    ExcitationResult,
    FourierParametrization,
    design_excitation,
)
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.model.robot import RobotModel  # noqa: E402

F, N, RATE = 0.1, 5, 150.0  # Hz, harmonics, Hz: the paper's design
OLD = dict(design_samples=100, popsize=15, maxiter=400)  # the sizes before


def reference_objective(cost: ExcitationCost, X: np.ndarray) -> np.ndarray:
    """The DE objective as it was: feasible coefficients at the design times
    (a series), their series again at those times for A, A^T A, numpy's
    batched ``eigvalsh``; no extra limit samples."""
    a, b = cost.coefficients(X, cost.times)
    return ExcitationCost.cond_of_eigenvalues(
        np.linalg.eigvalsh(cost.gram(a, b, cost.times))
    )


@contextlib.contextmanager
def recording(
    objective: Callable[[ExcitationCost, np.ndarray], np.ndarray] | None,
) -> Iterator[list]:
    """Runs ``ExcitationCost.__call__`` (or ``objective`` in its place) and
    records every new best: (perf_counter s, cost, x, the cost object). The
    DE keeps the best it has seen, so without a cell these are its bests."""
    original = ExcitationCost.__call__
    run = objective or original
    log: list = []

    def recorded(cost: ExcitationCost, X: np.ndarray) -> np.ndarray:
        c = run(cost, X)
        i = int(np.argmin(c))
        if not log or c[i] < log[-1][1]:
            log.append((time.perf_counter(), float(c[i]), X[i].copy(), cost))
        return c

    ExcitationCost.__call__ = recorded
    try:
        yield log
    finally:
        ExcitationCost.__call__ = original


def full_period_cond(cost: ExcitationCost, x: np.ndarray) -> float:
    """cond(A) on the 1500 samples of one period of candidate x, scaled into
    the limits at 200 samples per harmonic (the final trajectory's rule)."""
    t_dense = np.arange(200 * N) / (200 * N * F)
    t_full = np.arange(round(RATE / F)) / RATE
    a, b = cost.coefficients(x[None], t_dense)
    return float(cost.cond(cost.gram(a, b, t_full))[0])


def design(
    model: RobotModel, label: str, objective: Callable | None, **kw
) -> tuple[ExcitationResult, np.ndarray]:
    """One design; returns it and its (time s, cond on 1500) per improvement,
    time from the first evaluation."""
    with recording(objective) as log:
        t0, cpu = time.perf_counter(), time.process_time()
        result = design_excitation(model, n_random=20, progress=False, **kw)
        wall, cpu = time.perf_counter() - t0, time.process_time() - cpu
    start = log[0][0] if log else t0
    curve = np.array([(t - start, full_period_cond(c, x)) for t, _, x, c in log])
    print(
        f"\n{label}: {result.generations} generations in {result.time:.1f} s "
        f"({result.time / max(result.generations, 1):.3f} s per generation; the "
        f"whole call {wall:.1f} s, {cpu:.1f} s of CPU), cond(A) on "
        f"{result.samples} samples {result.cond:.4g}"
    )
    print(f"  {'time[s]':>8} {'cond(A), 1500 samples':>22}")
    keep = np.unique(np.linspace(0, len(curve) - 1, 14).round().astype(int))
    for t, c in curve[keep]:
        print(f"  {t:8.1f} {c:22.4g}")
    return result, curve


def _cost(model: RobotModel, samples: int, limit_samples: int = 0) -> ExcitationCost:
    """The objective at ``samples`` design samples (and the limits also at
    ``limit_samples`` per period), as design_excitation builds it."""
    limits = np.arange(limit_samples) / (limit_samples * F) if limit_samples else None
    return ExcitationCost(
        model=model,
        base=base_parameters(model, 13),
        parametrization=FourierParametrization(model.n_joints, N),
        q0=0.5 * (model.limits.lower + model.limits.upper),
        base_frequency=F,
        times=np.arange(samples) / (samples * F),
        limit_times=limits,
    )


def _best_of(f: Callable[[], object], repeats: int = 3) -> float:
    """Best wall time of ``repeats`` calls, s."""
    return min(timeit.repeat(f, number=1, repeat=repeats))


def quick(model: RobotModel, seed: int) -> None:
    """Per-generation seconds of both objectives, the new one's parts, and
    cond on S design samples against 1500 (printed only)."""
    defaults = inspect.signature(design_excitation).parameters
    samples = defaults["design_samples"].default
    popsize = defaults["popsize"].default
    limit_samples = LIMIT_SAMPLES_PER_HARMONIC * N
    new = _cost(model, samples, limit_samples)
    old = _cost(model, OLD["design_samples"])
    k = new.parametrization.size
    lim = np.repeat(model.limits.velocity, new.parametrization.per_joint)
    rng = np.random.default_rng(seed)

    def generation(cost: ExcitationCost, objective: Callable, size: int) -> None:
        X = rng.uniform(-lim, lim, (size, k))
        for i in range(0, size, cost.chunk):
            objective(cost, X[i : i + cost.chunk])

    t_old = _best_of(lambda: generation(old, reference_objective, 15 * k))
    t_same = _best_of(lambda: generation(old, ExcitationCost.__call__, 15 * k))
    t_new = _best_of(lambda: generation(new, ExcitationCost.__call__, popsize * k))
    print(f"seconds per generation (best of 3, {k} coordinates):")
    print(f"  old objective, 100 samples, popsize 15 ({15 * k}): {t_old:.3f}")
    print(f"  new objective, 100 samples, popsize 15 ({15 * k}): {t_same:.3f}")
    print(
        f"  new objective, {samples} samples + limits at {limit_samples}, popsize "
        f"{popsize} ({popsize * k}): {t_new:.3f}"
    )
    X = rng.uniform(-lim, lim, (new.chunk, k))
    _, _, q, qd, qdd = new.motion(X)
    G = new.gram_of_motion(q, qd, qdd)
    Y = new.base.regressor(new.chain, q[0], qd[0], qdd[0])
    A = np.repeat(Y.reshape(1, -1, Y.shape[-1]), new.chunk, axis=0)  # S n x p
    parts = {
        "series + limits": lambda: new.motion(X),
        "regressor + A^T A": lambda: new.gram_of_motion(q, qd, qdd),
        "eigenvalues": lambda: new.eigenvalues(G),
        "(a tall SVD instead)": lambda: np.linalg.svd(A, compute_uv=False),
    }
    print(f"new objective's parts, per candidate ({new.chunk} at a time):")
    for name, f in parts.items():
        print(f"  {name:<22} {_best_of(f) / new.chunk * 1e3:.3f} ms")
    full = _cost(model, round(RATE / F))
    X = rng.uniform(-lim, lim, (24, k))
    a, b = new.coefficients(X, np.arange(200 * N) / (200 * N * F))
    c_full = full.cond(full.gram(a, b, full.times))
    print("cond(A) on S design samples / on 1500, 24 random feasible candidates:")
    for S in (25, 50, 100):
        ratio = new.cond(new.gram(a, b, np.arange(S) / (S * F))) / c_full
        print(
            f"  S = {S:>3}: median {np.median(ratio):.4f}, "
            f"worst {ratio[np.argmax(np.abs(ratio - 1))]:.4f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="rv3sb")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="figures in < 20 s")
    parser.add_argument("--no-old", action="store_true", help="the new run only")
    parser.add_argument(
        "--maxiter", type=int, help="generations of the new run (default: its own)"
    )
    args = parser.parse_args()
    model = load_robot(args.robot)
    if args.quick:
        quick(model, args.seed)
        return
    big = dict(max_time=1e6, seed=args.seed)
    target = None
    if not args.no_old:
        old, curve = design(model, "old", reference_objective, **OLD, **big)
        target = 1.1 * old.cond
    extra = {} if args.maxiter is None else {"maxiter": args.maxiter}
    new, curve = design(model, "new", None, **extra, **big)
    if target is not None:
        hit = np.flatnonzero(curve[:, 1] <= target)
        when = f"{curve[hit[0], 0]:.1f} s" if hit.size else "not reached"
        print(
            f"\nnew within 10 % of the old run's {old.cond:.4g} (<= {target:.4g}) "
            f"after {when}; old {old.time:.1f} s, new {new.time:.1f} s"
        )


if __name__ == "__main__":
    main()
