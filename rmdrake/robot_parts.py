"""The parts of a :class:`~rmdrake.robot.RobotModel` besides its MDH table
(joint limits, payload, base frame) and the parsers of the robot YAML's fields
(one-line ValueErrors naming the field). Import them from :mod:`rmdrake.robot`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.model_units import MAX_ANGLE, MAX_LENGTH
from rmdrake.yaml_io import yaml_number, yaml_vector

__all__ = ["BaseFrame", "JointLimits", "Payload"]

_LIMIT_KEYS = ("lower", "upper", "velocity", "acceleration", "effort")


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """Per-joint limits: position (rad), velocity (rad/s), acceleration (rad/s^2)
    and effort (N m), each an array of length n."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray

    def __post_init__(self) -> None:
        for key in _LIMIT_KEYS:
            object.__setattr__(self, key, _frozen(getattr(self, key)))


@dataclasses.dataclass(frozen=True)
class Payload:
    """A rigid payload held by the tool (the robot YAML's optional ``payload``
    entry: ``{mass, com, inertia}`` at the tool frame).

    Attributes:
      mass: kg.
      p_EPcm: centre of mass in the tool frame E, m.
      inertia: rotational inertia about the centre of mass in E axes,
        ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (tensor entries), kg m^2.
    """

    mass: float
    p_EPcm: np.ndarray
    inertia: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "p_EPcm", _frozen(self.p_EPcm))
        object.__setattr__(self, "inertia", _frozen(self.inertia))


@dataclasses.dataclass(frozen=True)
class BaseFrame:
    """The pose X_LB of the MDH base frame B in the source's link named ``link``
    (L): p_L = X_LB p_B; ``xyz`` = p_LB (m), ``rpy`` = R_LB as Drake
    RollPitchYaw (rad). The robot YAML's optional ``base_frame``."""

    link: str
    xyz: np.ndarray
    rpy: np.ndarray

    def __post_init__(self) -> None:
        for key in ("xyz", "rpy"):
            v = as_finite_array(getattr(self, key), f"base_frame.{key}", (3,))
            object.__setattr__(self, key, _frozen(v))


def _plain(obj: Any) -> Any:
    """Converts numpy scalars/arrays inside nested containers to plain Python."""
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _base_frame(value: Any) -> BaseFrame | None:
    """The optional ``base_frame: {link, xyz, rpy}`` entry (m, rad)."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or set(value) != {"link", "xyz", "rpy"}:
        raise ValueError("base_frame: expected a mapping with link, xyz, rpy only")
    if not isinstance(value["link"], str) or not value["link"]:
        raise ValueError("base_frame.link: expected a link name")
    xyz = yaml_vector(value["xyz"], "base_frame.xyz", 3)
    rpy = yaml_vector(value["rpy"], "base_frame.rpy", 3)
    if np.any(np.abs(xyz) > MAX_LENGTH) or np.any(np.abs(rpy) > MAX_ANGLE):
        raise ValueError(
            "base_frame: xyz beyond 100 m or rpy beyond 4 pi: expected m and rad"
        )
    return BaseFrame(value["link"], xyz, rpy)


def _drive_gain(value: Any, n: int) -> np.ndarray | None:
    """The optional ``drive: {gain: [...]}`` entry: n positive gains, N m/A (N/A
    on a prismatic joint); checked for sign by RobotModel."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or set(value) != {"gain"}:
        raise ValueError("drive: expected a mapping with gain only")
    return yaml_vector(value["gain"], "drive.gain", n)


def _sigma(value: Any, what: str) -> int:
    """The joint type of an MDH row mapping: ``sigma`` 0 (revolute, the default)
    or 1 (prismatic)."""
    s = value.get("sigma", 0) if isinstance(value, Mapping) else 0
    if isinstance(s, bool) or s not in (0, 1):
        raise ValueError(
            f"{what}.sigma: expected 0 (revolute) or 1 (prismatic), found {s!r}"
        )
    return int(s)


def _row(value: Any, what: str, keys: Sequence[str]) -> np.ndarray:
    if not isinstance(value, Mapping):
        raise ValueError(f"{what}: expected a mapping with keys {', '.join(keys)}")
    allowed = set(keys) | ({"sigma"} if what.startswith("mdh[") else set())
    unknown = set(value) - allowed
    if unknown:
        hint = (
            " (a joint's type is sigma: 0 revolute, 1 prismatic)"
            if (allowed != set(keys) and unknown & {"type", "joint", "kind"})
            else ""
        )
        raise ValueError(
            f"{what}: unknown key(s) {', '.join(sorted(map(str, unknown)))}{hint}"
        )
    out = []
    for k in keys:
        if k not in value:
            if k == "beta":  # optional: Hayati's angle is zero unless given
                out.append(0.0)
                continue
            raise ValueError(f"{what}: missing key '{k}'")
        out.append(yaml_number(value[k], f"{what}.{k}"))
    return np.array(out)
