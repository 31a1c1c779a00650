"""The doors a robot model comes in by (a robot YAML, a URDF) refuse, with
one line naming the key or attribute, what no manipulator has: a file in mm,
a gravity beyond physics, a negative velocity or effort limit, a file with no
joint to move."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.model.units import MAX_GRAVITY
from rmdrake.model.urdf.importer import robot_from_urdf, robot_to_urdf


def _in_mm(urdf: str) -> str:
    """The URDF with every ``<origin xyz>`` (joints and inertials) times 1000."""

    def scale(m: re.Match) -> str:
        xyz = " ".join(repr(float(v) * 1000) for v in m.group(2).split())
        return f"{m.group(1)}{xyz}{m.group(3)}"

    return re.sub(r'(<origin xyz=")([^"]*)(")', scale, urdf)


@pytest.fixture
def rv3sb_urdf() -> str:
    return robot_to_urdf(load_robot("rv3sb"))


def test_a_urdf_in_mm_is_refused_as_a_yaml_in_mm(rv3sb_urdf, tmp_path):
    """The one unit check holds at both doors: the URDF and its YAML."""
    urdf = tmp_path / "mm.urdf"
    urdf.write_text(_in_mm(rv3sb_urdf))
    with pytest.raises(ValueError, match=r"mm\.urdf: mdh .* looks like mm\?"):
        robot_from_urdf(urdf)
    with pytest.raises(ValueError, match=r"mm\.urdf: .*looks like mm\?"):
        load_robot(urdf)
    data = load_robot("rv3sb").to_dict()
    data["mdh"][2]["d"] *= 1000
    with pytest.raises(ValueError, match=r"looks like mm\? convert"):
        RobotModel.from_dict(data)


def test_the_urdf_in_m_still_imports(rv3sb_urdf, tmp_path):
    urdf = tmp_path / "m.urdf"
    urdf.write_text(rv3sb_urdf)
    robot, nominal = robot_from_urdf(urdf), load_robot("rv3sb")
    q = np.random.default_rng(0).uniform(-1, 1, (5, 6))
    assert np.allclose(tool_poses(robot.table, q), tool_poses(nominal.table, q))


@pytest.mark.parametrize(
    ("gravity", "hint"),
    [
        ([0, 0, -1e6], r"gravity: \|g\| = 1e\+06 m/s\^2 is beyond 30 m/s\^2"),
        ([0, 0, -981], r"cm/s\^2\?"),
        ([0, -9810, 0], r"mm/s\^2\?"),
    ],
)
def test_gravity_beyond_physics_is_refused(gravity, hint):
    data = load_robot("rv3sb").to_dict()
    data["gravity"] = gravity
    with pytest.raises(ValueError, match=hint):
        RobotModel.from_dict(data, "g.yaml")


@pytest.mark.parametrize("gravity", [[0, 0, 0], [0, 0, -9.81], [0, 0, -MAX_GRAVITY]])
def test_gravity_within_physics_loads(gravity):
    data = load_robot("rv3sb").to_dict()
    data["gravity"] = gravity
    assert np.allclose(RobotModel.from_dict(data).gravity, gravity)


@pytest.mark.parametrize(
    ("old", "new", "line"),
    [
        (
            'velocity="4.363323129985824"',
            'velocity="-4.36"',
            r"""joint 'joint1': <limit velocity="-4.36"> is negative""",
        ),
        (
            'effort="90.0"',
            'effort="-90.0"',
            r"""joint 'joint1': <limit effort="-90.0"> is negative""",
        ),
        (
            'lower="-2.9670597283903604"',
            'lower="3.5"',
            r"""joint 'joint1': <limit lower="3.5"> is above upper""",
        ),
    ],
)
def test_a_urdf_limit_drake_would_abort_on_is_named(
    rv3sb_urdf, tmp_path, old, new, line
):
    """Drake's parser aborts the process on a negative velocity limit (and on
    swapped position limits); every effort negative made a kinematic-only
    model. Each is refused at parse, naming the joint and the attribute."""
    assert old in rv3sb_urdf
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(rv3sb_urdf.replace(old, new, 1))
    with pytest.raises(ValueError, match=re.escape(str(urdf)) + ": " + line):
        robot_from_urdf(urdf)


@pytest.mark.parametrize(
    "text",
    [
        '<robot name="empty"></robot>',
        '<robot name="one"><link name="base"/></robot>',
        '<robot name="two"><link name="base"/><link name="tool"/><joint name="w" '
        'type="fixed"><parent link="base"/><child link="tool"/></joint></robot>',
    ],
)
def test_a_urdf_with_no_joint_to_move_is_refused(tmp_path, text):
    urdf = tmp_path / "none.urdf"
    urdf.write_text(text)
    with pytest.raises(ValueError, match="robot has no actuated joints between base"):
        robot_from_urdf(urdf)


def test_make_plant_says_it_has_no_friction_and_how_to_add_it():
    """A user composing a diagram from help() alone must learn that the plant
    has no friction and which system adds it (the docstring's example runs
    in the doctests)."""
    from rmdrake.model.plant import MakePlant

    doc = " ".join(MakePlant.__doc__.split())
    assert "The plant has no joint friction" in doc
    assert "JointFriction.AddToBuilder" in doc
    assert "AddDiscretePlantFriction" in doc
    plant, _ = MakePlant(load_robot("rv3sb"))
    for i in plant.GetJointIndices():  # what the docstring says: no damping
        assert plant.get_joint(i).default_damping() == 0
