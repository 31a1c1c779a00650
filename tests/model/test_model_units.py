"""A robot model in mm or degrees is refused at load, naming the value."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from rmdrake.model.loading import load_robot, shipped_robots
from rmdrake.model.robot import RobotModel


@pytest.mark.parametrize("name", shipped_robots())
def test_shipped_robots_are_in_si_units(name):
    load_robot(name)  # no error


def _edited(edit):
    data = copy.deepcopy(load_robot("rv3sb").to_dict())
    edit(data)
    return data


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["mdh"][2].update(d=1000 * d["mdh"][2]["d"]),
         r"mdh row 3: d = 2\d+ is beyond 100 m: .*this looks like mm"),
        (lambda d: d["tool"].update(r=85.0 * 1000),
         r"mdh tool: r = 85000 .*looks like mm"),
        (lambda d: d["mdh"][1].update(theta=-90.0),
         r"mdh row 2: theta = -90 is beyond 12.57 rad.*looks like degrees"),
        (lambda d: d["limits"].update(upper=[170.0] * 6),
         r"limits.upper: joint 1 has 170, beyond 12.57 rad: .*degrees"),
        (lambda d: d["limits"].update(velocity=[225.0] * 6),
         r"limits.velocity: joint 1 has 225, beyond 100 rad/s"),
    ],
)  # fmt: skip
def test_a_robot_in_mm_or_degrees_is_refused(edit, message):
    with pytest.raises(ValueError, match=message):
        RobotModel.from_dict(_edited(edit))


def test_two_turn_joints_and_long_arms_are_accepted():
    data = _edited(lambda d: d["limits"].update(lower=[-2 * np.pi] * 6))
    assert RobotModel.from_dict(data).limits.lower[0] == pytest.approx(-2 * np.pi)
