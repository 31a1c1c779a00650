"""Loading a robot: a shipped model by name, a robot YAML, or a URDF's chain.

The shipped robots are the YAML files of ``rmdrake/model/shipped`` (``rv3sb``,
``demo_rh``, ...). A :data:`Robot` is anything a command accepts as a robot: a
loaded :class:`~rmdrake.model.robot.RobotModel`, a shipped name, or a path.
"""

from __future__ import annotations

import dataclasses
import os
import re
from importlib import resources
from pathlib import Path

from rmdrake.io.yaml import load_yaml, read_yaml
from rmdrake.model.robot import RobotModel

__all__ = [
    "Robot",
    "as_robot_model",
    "controller_model_for",
    "load_robot",
    "shipped_robots",
]

_MODELS = "rmdrake.model.shipped"

Robot = RobotModel | str | os.PathLike
"""A robot: a loaded model, a shipped name, a robot YAML or a URDF path."""


def as_robot_model(robot: Robot) -> RobotModel:
    """``robot`` itself if it is a loaded model, else :func:`load_robot` of it.

    Example:

    >>> from rmdrake.model import as_robot_model, load_robot
    >>> as_robot_model("rv3sb").name
    'rv3sb'
    >>> robot = load_robot("rv3sb")
    >>> as_robot_model(robot) is robot
    True
    """
    return robot if isinstance(robot, RobotModel) else load_robot(robot)


def shipped_robots() -> list[str]:
    """Names of the robots shipped in ``rmdrake/model/shipped``.

    Example:

    >>> from rmdrake import shipped_robots
    >>> "rv3sb" in shipped_robots()
    True
    """
    files = resources.files(_MODELS).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".yaml"))


def load_robot(
    robot: str | os.PathLike, *, base: str | None = None, tip: str | None = None
) -> RobotModel:
    """Loads a shipped robot by name (``rv3sb``, ``demo_rh``), a robot YAML by
    path, or the serial chain from link ``base`` to link ``tip`` of a URDF (a
    path ending in ``.urdf``; see :func:`rmdrake.model.urdf.importer.robot_from_urdf`).

    Raises:
      ValueError: unknown name, unreadable file or invalid content (one line);
        ``base``/``tip`` given for a robot that is not a URDF.

    Example:

    >>> from rmdrake import load_robot
    >>> robot = load_robot("rv3sb")
    >>> robot.name, robot.n_joints
    ('rv3sb', 6)
    >>> robot.limits.upper.round(2)
    array([2.97, 2.36, 2.98, 2.79, 2.09, 6.28])
    """
    text_name = str(robot)
    if text_name.lower().endswith(".urdf"):
        from rmdrake.model.urdf.importer import robot_from_urdf  # Drake's parser

        return robot_from_urdf(robot, base=base, tip=tip)
    if base is not None or tip is not None:
        raise ValueError(
            f"{text_name}: --base and --tip pick the chain of a URDF; this robot is "
            "a robot YAML or a shipped model"
        )
    is_name = isinstance(robot, str) and re.fullmatch(r"[A-Za-z0-9_\-]+", text_name)
    if is_name and not Path(text_name).exists():
        res = resources.files(_MODELS).joinpath(f"{text_name}.yaml")
        if not res.is_file():
            raise ValueError(
                f"unknown robot '{text_name}': expected a shipped model "
                f"({', '.join(shipped_robots())}) or a path to a robot YAML"
            )
        name = f"{text_name}.yaml"
        return RobotModel.from_dict(load_yaml(res.read_text(), name), name)
    path = Path(robot)
    data = read_yaml(path, "robot YAML")
    return RobotModel.from_dict(data, str(path))


def controller_model_for(true_model: RobotModel, robot_arg: str) -> RobotModel:
    """The model a controller uses when none is named: the shipped robot whose
    name the true robot carries, when the true robot was given as a file (a
    perturbed copy of a shipped robot), else the true robot itself; with rigid
    joints either way (the station's computed-torque controller assumes them;
    an elastic arm's encoders read the motor side it feeds back).

    Example:

    >>> from rmdrake.model import controller_model_for, load_robot
    >>> true_robot = load_robot("rv3sb")
    >>> controller_model_for(true_robot, "rv3sb").name
    'rv3sb'
    """
    model = true_model
    if true_model.name in shipped_robots() and robot_arg != true_model.name:
        model = load_robot(true_model.name)
    if model.compliance is not None:
        model = dataclasses.replace(model, compliance=None)
    return model
