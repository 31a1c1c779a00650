"""The one Differential Evolution entry point (rmdrake.optimize): seeding, the
vectorised objective, convergence on a known minimum and the budget options."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.optimize import differential_evolution

CENTRE = np.array([0.3, -1.2, 2.0])
BOUNDS = np.array([[-4.0, 4.0], [-3.0, 1.0], [0.5, 5.0]])


def quadratic(X: np.ndarray) -> np.ndarray:
    """Sum of squares about CENTRE (minimum 0 at CENTRE), one cost per row."""
    return np.sum((np.atleast_2d(X) - CENTRE) ** 2, axis=1)


def test_same_seed_same_result_and_seed_matters() -> None:
    kw = dict(seed=5, popsize=8, maxiter=15, progress=False)
    r1 = differential_evolution(quadratic, BOUNDS, **kw)
    r2 = differential_evolution(quadratic, BOUNDS, **kw)
    np.testing.assert_array_equal(r1.x, r2.x)
    assert r1.fun == r2.fun and r1.nfev == r2.nfev and r1.nit == r2.nit
    r3 = differential_evolution(quadratic, BOUNDS, **{**kw, "seed": 6})
    assert not np.array_equal(r1.x, r3.x)


def test_objective_receives_the_population_as_rows() -> None:
    shapes: list[tuple[int, ...]] = []

    def func(X: np.ndarray) -> np.ndarray:
        shapes.append(X.shape)
        assert np.all(X >= BOUNDS[:, 0]) and np.all(X <= BOUNDS[:, 1])
        return quadratic(X)

    popsize = 6
    r = differential_evolution(
        func, BOUNDS, seed=0, popsize=popsize, maxiter=4, progress=False
    )
    d = BOUNDS.shape[0]
    # One call per generation (plus the initial population), each with the whole
    # population of popsize * d candidates as an (S, d) array.
    assert all(len(s) == 2 and s[1] == d for s in shapes)
    assert shapes[0] == (popsize * d, d)
    assert len(shapes) == r.nit + 1
    assert all(s == shapes[0] for s in shapes)


def test_finds_the_minimum_of_a_quadratic() -> None:
    r = differential_evolution(
        quadratic, BOUNDS, seed=1, maxiter=300, tol=1e-10, progress=False
    )
    # DE without polish: 1e-3 per coordinate is well within what 300
    # generations reach on a 3-variable bowl (cost <= 3e-6).
    np.testing.assert_allclose(r.x, CENTRE, rtol=0, atol=1e-3)
    assert r.fun <= 3e-6
    assert r.fun == pytest.approx(quadratic(r.x)[0], rel=1e-12)
    assert r.time > 0.0


def test_polish_and_x0() -> None:
    # The polish step (L-BFGS-B) calls the objective with single candidates,
    # which arrive as one-row (1, d) arrays, and improves on the DE's best.
    shapes: list[tuple[int, ...]] = []

    def func(X: np.ndarray) -> np.ndarray:
        shapes.append(X.shape)
        return quadratic(X)

    kw = dict(seed=2, maxiter=10, progress=False)
    plain = differential_evolution(quadratic, BOUNDS, **kw)
    r = differential_evolution(func, BOUNDS, polish=True, **kw)
    assert (1, BOUNDS.shape[0]) in shapes
    assert r.fun <= plain.fun
    # L-BFGS-B on finite-difference gradients stops about 1e-6 from the
    # minimum of this bowl: 1e-5 per coordinate, cost below 1e-9.
    np.testing.assert_allclose(r.x, CENTRE, rtol=0, atol=1e-5)
    assert r.fun < 1e-9
    # x0 joins the first population: starting at the minimum, the best after
    # one generation is the minimum itself.
    r = differential_evolution(
        quadratic, BOUNDS, seed=2, maxiter=1, x0=CENTRE, progress=False
    )
    assert r.fun <= 1e-20


def test_budget_options_are_honoured() -> None:
    calls: list[int] = []

    def func(X: np.ndarray) -> np.ndarray:
        calls.append(X.shape[0])
        return quadratic(X)

    # maxiter bounds the generations.
    r = differential_evolution(func, BOUNDS, seed=3, maxiter=5, progress=False)
    assert r.nit == 5 and len(calls) == 6 and not r.success
    # A loose tol stops early on convergence, before maxiter.
    r = differential_evolution(
        quadratic, BOUNDS, seed=3, maxiter=1000, tol=0.5, progress=False
    )
    assert r.success and r.nit < 1000
    # popsize sets the population size (a multiple of the dimension).
    calls.clear()
    differential_evolution(func, BOUNDS, seed=3, popsize=4, maxiter=1, progress=False)
    assert calls[0] == 4 * BOUNDS.shape[0]


@pytest.mark.parametrize(
    "bounds",
    [
        np.array([0.0, 1.0]),  # not (k, 2)
        np.array([[0.0, 1.0], [2.0, 2.0]]),  # empty interval
        np.array([[0.0, np.inf]]),  # infinite
    ],
)
def test_bad_bounds(bounds: np.ndarray) -> None:
    with pytest.raises(ValueError, match="bounds: expected"):
        differential_evolution(quadratic, bounds, seed=0, progress=False)


def test_seed_is_keyword_and_required() -> None:
    with pytest.raises(TypeError):
        differential_evolution(quadratic, BOUNDS)  # type: ignore[call-arg]
