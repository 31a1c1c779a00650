"""The excitation design's DE population as tasks: the same design, bit for
bit, in this process and on two local Dask workers; the cost (with a cell's
clearance checker, which holds a Drake plant) pickles and is rebuilt there."""

from __future__ import annotations

import pickle

import numpy as np

from rmdrake.dynamics.base import base_parameters
from rmdrake.excitation.design import (
    ExcitationCost,
    FourierParametrization,
    design_excitation,
)
from rmdrake.execution import Execution
from rmdrake.kinematics.clearance import ClearanceChecker
from rmdrake.model.scene import load_cell

# Two chunks of 64 candidates per generation (2 x 42 coordinates x popsize 2),
# so the runner starts its workers.
_SMALL = dict(
    design_samples=40, popsize=2, maxiter=3, n_random=2, seed=5, progress=False
)


def _checker(model) -> ClearanceChecker:
    return ClearanceChecker(model=model, cell=load_cell("rv3sb_table"))


def test_cost_with_a_checker_pickles_and_gives_the_same_costs(rv3sb):
    cost = ExcitationCost(
        model=rv3sb,
        base=base_parameters(rv3sb, 13),
        parametrization=FourierParametrization(6, 5),
        q0=0.5 * (rv3sb.limits.lower + rv3sb.limits.upper),
        base_frequency=0.1,
        times=np.arange(40) * 0.25,
    )
    cost.checker, cost.clearance = _checker(rv3sb), 0.05
    copy = pickle.loads(pickle.dumps(cost))
    assert isinstance(copy.checker, ClearanceChecker)
    assert copy.checker is not cost.checker
    X = np.random.default_rng(0).uniform(-0.3, 0.3, (8, cost.parametrization.size))
    np.testing.assert_array_equal(copy(X), cost(X))
    # rebuilt once per process: a second copy shares the first one's checker
    assert pickle.loads(pickle.dumps(cost)).checker is copy.checker


def test_design_is_the_same_in_process_and_on_two_workers(rv3sb):
    cell = {"checker": _checker(rv3sb), "clearance": 0.05}
    serial = design_excitation(rv3sb, execution=Execution(workers=0), **_SMALL, **cell)
    parallel = design_excitation(
        rv3sb, execution=Execution(workers=2), **_SMALL, **cell
    )
    np.testing.assert_array_equal(parallel.trajectory.a, serial.trajectory.a)
    np.testing.assert_array_equal(parallel.trajectory.b, serial.trajectory.b)
    assert parallel.cond == serial.cond
    np.testing.assert_array_equal(parallel.history[:, 2], serial.history[:, 2])
    assert parallel.generations == serial.generations == 3
    assert parallel.min_clearance == serial.min_clearance >= 0.05
