"""Shared fixtures: shipped robots and seeded random generators."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

from rmdrake.robot import RobotModel, load_robot, shipped_robots  # noqa: E402


@pytest.fixture(params=shipped_robots())
def shipped(request) -> RobotModel:
    """Each shipped robot in turn."""
    return load_robot(request.param)


@pytest.fixture
def rv3sb() -> RobotModel:
    return load_robot("rv3sb")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20161)
