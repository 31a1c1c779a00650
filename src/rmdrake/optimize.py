"""The one Differential Evolution entry point of rmdrake.

Both engines use it: the plane-constraint calibration (paper eq. 5, cost summed
over tetrahedron volumes) and the excitation design (paper eq. 16, condition number
of the observation matrix). It wraps :func:`scipy.optimize.differential_evolution`
with the house rules: the objective is evaluated for the whole population in one
vectorised call, every run is seeded, and a progress bar shows the generations
(:func:`rmdrake.progress.progress_bar`: lines in batch use).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.progress import progress_bar

if TYPE_CHECKING:  # types only: imported where used
    import scipy.optimize


__all__ = ["differential_evolution"]


def differential_evolution(
    func: Callable[[np.ndarray], np.ndarray],
    bounds: Sequence[tuple[float, float]] | np.ndarray,
    *,
    seed: int,
    popsize: int = 15,
    maxiter: int = 1000,
    tol: float = 0.01,
    atol: float = 0.0,
    mutation: float | tuple[float, float] = (0.5, 1.0),
    recombination: float = 0.7,
    strategy: str = "best1bin",
    init: str | np.ndarray = "latinhypercube",
    x0: np.ndarray | None = None,
    polish: bool = False,
    constraints: object = (),
    progress: bool = True,
    desc: str = "differential evolution",
) -> scipy.optimize.OptimizeResult:
    """Minimises ``func`` over a box by Differential Evolution (Storn and Price).

    Args:
      func: the objective, vectorised over the population: it always receives
        an (S, k) array, one candidate per row, and returns S costs (single
        candidates, e.g. for the polish step, come as S = 1).
      bounds: (k, 2) lower and upper bound of each variable.
      seed: seeds numpy's ``default_rng``; equal seeds give equal runs.
      popsize: population size as a multiple of k (scipy's convention).
      maxiter: maximum number of generations.
      tol, atol: stop when the population's cost spread is below
        ``atol + tol * |mean cost|`` (scipy's convergence test).
      mutation, recombination, strategy, init, constraints: as in scipy.
      x0: an initial guess placed in the first population (e.g. the nominal).
      polish: finish with L-BFGS-B (off by default: callers polish with their
        own local method).
      progress: show the generations on stderr (a bar on a terminal, lines in
        batch use).
      desc: label of the progress bar.

    Returns:
      scipy's OptimizeResult (``x``, ``fun``, ``nit``, ``nfev``, ``success``,
      ``message``) plus ``time``, the wall time in s.

    Example:

    >>> import numpy as np
    >>> from rmdrake.optimize import differential_evolution
    >>> def cost(X):  # (P, 2) candidates -> (P,) costs
    ...     return ((X - 0.5) ** 2).sum(axis=1)
    ...
    >>> bounds = [(-1.0, 1.0), (-1.0, 1.0)]
    >>> result = differential_evolution(cost, bounds, seed=0, progress=False)
    >>> result.x.round(2).tolist()
    [0.5, 0.5]
    """
    import scipy.optimize

    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.ndim != 2 or bounds.shape[1] != 2:
        raise ValueError(f"bounds: expected shape (k, 2), found {bounds.shape}")
    if np.any(~np.isfinite(bounds)) or np.any(bounds[:, 0] >= bounds[:, 1]):
        raise ValueError("bounds: expected finite lower < upper for every variable")

    def objective(x: np.ndarray) -> np.ndarray | float:
        if x.ndim == 1:
            return float(np.asarray(func(x[None, :])).reshape(-1)[0])
        return np.asarray(func(x.T), dtype=np.float64).reshape(-1)

    bar = progress_bar(total=maxiter, desc=desc, disable=not progress)

    def callback(intermediate_result: scipy.optimize.OptimizeResult) -> None:
        bar.update(1)
        bar.set_postfix(best=f"{intermediate_result.fun:.4g}", refresh=False)

    t0 = time.perf_counter()
    try:
        result = scipy.optimize.differential_evolution(
            objective,
            bounds,
            strategy=strategy,
            maxiter=maxiter,
            popsize=popsize,
            tol=tol,
            atol=atol,
            mutation=mutation,
            recombination=recombination,
            rng=np.random.default_rng(seed),
            callback=callback,
            polish=polish,
            init=init,
            updating="deferred",
            x0=x0,
            constraints=constraints,
            vectorized=True,
        )
    finally:
        bar.close()
    result.time = time.perf_counter() - t0
    return result
