"""Shared fixtures (shipped robots, seeded random generators) and the oracles
several test folders use (Drake's own distance query on a robot in its cell)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

os.environ.setdefault("MPLBACKEND", "Agg")

import rmdrake  # noqa: E402
from rmdrake.model.loading import load_robot, shipped_robots  # noqa: E402
from rmdrake.model.plant import CELL_PREFIX, MakePlant  # noqa: E402
from rmdrake.model.robot import RobotModel

CHECKOUT = Path(__file__).resolve().parents[1]
if os.environ.get("RMDRAKE_TEST_INSTALLED") and Path(
    rmdrake.__file__
).resolve().is_relative_to(CHECKOUT / "src"):
    raise RuntimeError(  # `make test` tests the wheel, not the source tree
        f"RMDRAKE_TEST_INSTALLED: rmdrake was imported from the checkout "
        f"({rmdrake.__file__}), not from the installed wheel"
    )

SHARED_DATA = CHECKOUT.parent / "shared" / "data"
"""The real robot data beside the repository (``../shared/data``), read in
place; tests that need them skip with a reason when absent."""

RIGID_SHIPPED = [r for r in shipped_robots() if load_robot(r).compliance is None]
"""The shipped robots with rigid joints: the elastic ones (demo_rh_elastic is
demo_rh with compliance) have plants with 2 positions per elastic joint and are
tested by test_elastic_plant, test_elastic_station and test_compliance."""


@pytest.fixture(params=RIGID_SHIPPED)
def shipped(request) -> RobotModel:
    """Each shipped robot with rigid joints in turn."""
    return load_robot(request.param)


@pytest.fixture
def rv3sb() -> RobotModel:
    return load_robot("rv3sb")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20161)


def boom_arm() -> RobotModel:
    """A 6-joint test arm with two prismatic joints: a vertical lifting column
    (joint 1, m), a shoulder yaw and pitch, a telescopic boom (joint 4, m) and a
    two-axis wrist, with every MDH entry non-zero somewhere (offsets, beta) and
    seeded random physically valid dynamics. Not shipped: tests only."""
    from rmdrake.model.dynamic_parameters import random_standard_parameters
    from rmdrake.model.robot import JointLimits

    h = np.pi / 2
    mdh = np.array(
        [  # alpha, d, theta, r, beta
            [0.0, 0.0, 0.1, 0.40, 0.0],  # lifting column: r1 = q1 + 0.40
            [0.02, 0.05, 0.0, 0.12, 0.0],
            [-h, 0.15, -0.2, 0.03, 0.0],
            [-h, 0.02, 0.3, 0.25, 0.0],  # telescopic boom: r4 = q4 + 0.25
            [h, 0.01, 0.0, 0.05, 0.0],
            [-h, 0.0, 0.1, 0.0, 0.01],
        ]
    )
    rng = np.random.default_rng(7)
    return RobotModel(
        name="boom_arm",
        mdh=mdh,
        tool=np.array([0.0, 0.01, 0.0, 0.12, 0.0]),
        sigma=np.array([1, 0, 0, 1, 0, 0]),
        limits=JointLimits(
            lower=[0.0, -2.9, -1.5, 0.0, -2.0, -3.0],
            upper=[0.8, 2.9, 1.5, 0.6, 2.0, 3.0],
            velocity=[0.3, 2.0, 2.0, 0.4, 3.0, 4.0],
            acceleration=[1.0, 5.0, 5.0, 1.5, 10.0, 12.0],
            effort=[2000.0, 400.0, 400.0, 800.0, 60.0, 30.0],
        ),
        dynamics=random_standard_parameters(6, rng).reshape(6, 13),
    )


@pytest.fixture
def boom() -> RobotModel:
    """The test arm with prismatic joints 1 and 4 (see :func:`boom_arm`)."""
    return boom_arm()


@pytest.fixture(params=[*RIGID_SHIPPED, "boom_arm"])
def any_robot(request) -> RobotModel:
    """Each shipped rigid robot, then the prismatic test arm."""
    return boom_arm() if request.param == "boom_arm" else load_robot(request.param)


def cell_distances(model, cell, radius: float, q) -> np.ndarray:
    """Oracle: the smallest signed distance robot-cell per row of q (m), by
    Drake's ComputeSignedDistancePairwiseClosestPoints on a fresh plant."""
    builder = DiagramBuilder()
    plant, sg = MakePlant(
        model, builder=builder, visual=False, collision_radius=radius, cell=cell
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    pc = plant.GetMyMutableContextFromRoot(context)
    sc = sg.GetMyContextFromRoot(context)
    inspector = sg.model_inspector()
    out = []
    for qi in np.atleast_2d(q):
        plant.SetPositions(pc, qi)
        pairs = sg.get_query_output_port().Eval(sc)
        d = [
            p.distance
            for p in pairs.ComputeSignedDistancePairwiseClosestPoints()
            if inspector.GetName(p.id_A).startswith(CELL_PREFIX)
            or inspector.GetName(p.id_B).startswith(CELL_PREFIX)
        ]
        out.append(min(d))
    return np.array(out)
