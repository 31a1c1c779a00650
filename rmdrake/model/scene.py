"""A robot cell: the fixed shapes around a robot (table, walls, fixtures).

A cell file is a small YAML mapping read with Drake's
:func:`pydrake.common.yaml.yaml_load_typed` into :class:`Cell`, behind the
project's bounded reader (:func:`rmdrake.io.yaml.read_yaml`)::

    name: rv3sb_table
    boxes:
      - name: table_top
        size: [1.2, 0.9, 0.04]            # m, along x_G, y_G, z_G
        X_BG: {xyz: [0.2, 0.0, -0.02], rpy: [0.0, 0.0, 0.0]}
    cylinders:
      - {name: post, radius: 0.04, length: 0.8, X_BG: {xyz: [...], rpy: [...]}}
    spheres:
      - {name: sensor, radius: 0.05, X_BG: {xyz: [...]}}

Every shape has a name (unique in the cell) and its pose X_BG: the shape's
frame G in the robot's base frame B, ``xyz`` the position p_BGo in m and
``rpy`` the roll, pitch and yaw in rad of Drake's
:class:`~pydrake.math.RollPitchYaw` (R_BG = Rz(yaw) Ry(pitch) Rx(roll)). G is
at the shape's centre; a cylinder's axis is z_G (Drake's conventions). Bad input
(an unknown key, a wrong type, a non-positive size, a repeated name, a
non-finite number) is one ``ValueError`` line naming the file and the shape.

Cells shipped with rmdrake (:func:`shipped_cells`) are in ``rmdrake/model/cells``;
``--scene NAME`` finds them by name.
"""

import dataclasses
import math
import os
from importlib import resources
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed
from pydrake.geometry import Box, Cylinder, Shape, Sphere
from pydrake.math import RigidTransform, RollPitchYaw

from rmdrake.io.yaml import read_yaml

__all__ = [
    "Cell",
    "CellBox",
    "CellCylinder",
    "CellPose",
    "CellSphere",
    "load_cell",
    "shipped_cells",
]

_CELLS = "rmdrake.model.cells"


@dataclasses.dataclass
class CellPose:
    """X_BG: position ``xyz`` (m) of G in B and Drake roll-pitch-yaw ``rpy``
    (rad) of R_BG."""

    xyz: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])

    def transform(self) -> RigidTransform:
        """X_BG as a Drake RigidTransform."""
        return RigidTransform(RollPitchYaw(self.rpy), self.xyz)


@dataclasses.dataclass
class CellBox:
    """A box of edge lengths ``size`` (3,) in m along x_G, y_G, z_G, centred
    on G."""

    name: str = ""
    size: list[float] = dataclasses.field(default_factory=list)
    X_BG: CellPose = dataclasses.field(default_factory=CellPose)

    def shape(self) -> Shape:
        """The Drake shape, in G."""
        return Box(*self.size)


@dataclasses.dataclass
class CellCylinder:
    """A cylinder of ``radius`` and ``length`` (m), its axis z_G, centred on G."""

    name: str = ""
    radius: float = 0.0
    length: float = 0.0
    X_BG: CellPose = dataclasses.field(default_factory=CellPose)

    def shape(self) -> Shape:
        """The Drake shape, in G."""
        return Cylinder(self.radius, self.length)


@dataclasses.dataclass
class CellSphere:
    """A sphere of ``radius`` (m) centred on G."""

    name: str = ""
    radius: float = 0.0
    X_BG: CellPose = dataclasses.field(default_factory=CellPose)

    def shape(self) -> Shape:
        """The Drake shape, in G."""
        return Sphere(self.radius)


CellShape = CellBox | CellCylinder | CellSphere


@dataclasses.dataclass
class Cell:
    """The fixed shapes of a robot cell, each posed in the robot's base B."""

    name: str = "cell"
    boxes: list[CellBox] = dataclasses.field(default_factory=list)
    cylinders: list[CellCylinder] = dataclasses.field(default_factory=list)
    spheres: list[CellSphere] = dataclasses.field(default_factory=list)

    def shapes(self) -> list[CellShape]:
        """Every shape: boxes, then cylinders, then spheres, in file order."""
        return [*self.boxes, *self.cylinders, *self.spheres]

    def check(self, source: str = "cell") -> "Cell":
        """Returns self; raises a one-line ValueError (starting with ``source``)
        on an empty or repeated name, a size that is not positive and finite, or
        a pose that is not 3 + 3 finite numbers."""
        seen: set[str] = set()
        for kind, shapes in (
            ("boxes", self.boxes),
            ("cylinders", self.cylinders),
            ("spheres", self.spheres),
        ):
            for i, s in enumerate(shapes):
                where = f"{source}: {kind}[{i}]" + (f" '{s.name}'" if s.name else "")
                if not s.name:
                    raise ValueError(f"{where}: expected a name")
                if s.name in seen:
                    raise ValueError(f"{where}: the name is used twice")
                seen.add(s.name)
                _check_sizes(s, where)
                for key in ("xyz", "rpy"):
                    v = getattr(s.X_BG, key)
                    if len(v) != 3 or not all(math.isfinite(x) for x in v):
                        raise ValueError(
                            f"{where}: X_BG.{key}: expected 3 finite numbers, found {v}"
                        )
        return self


def _check_sizes(shape: CellShape, where: str) -> None:
    """Refuses dimensions (m) that are not positive and finite."""
    if isinstance(shape, CellBox):
        dims = {"size": shape.size}
        if len(shape.size) != 3:
            raise ValueError(f"{where}: size: expected 3 lengths, found {shape.size}")
    elif isinstance(shape, CellCylinder):
        dims = {"radius": [shape.radius], "length": [shape.length]}
    else:
        dims = {"radius": [shape.radius]}
    for key, values in dims.items():
        if not all(math.isfinite(v) and v > 0 for v in values):
            value = values if key == "size" else values[0]
            raise ValueError(
                f"{where}: {key}: expected positive finite m, found {value}"
            )


def shipped_cells() -> list[str]:
    """Names of the cells shipped with rmdrake (``--scene NAME``)."""
    folder = resources.files(_CELLS)
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def load_cell(path: str | os.PathLike) -> Cell:
    """Reads a cell YAML (see the module docstring): a file path, or the name of
    a shipped cell (:func:`shipped_cells`).

    Raises:
      ValueError: one line naming the file: unreadable or bad YAML, an unknown
        key, a wrong type, or a bad shape (:meth:`Cell.check`).
    """
    text_path = Path(path)
    if not text_path.exists() and str(path) in shipped_cells():
        text_path = Path(str(resources.files(_CELLS) / f"{path}.yaml"))
    raw = read_yaml(text_path, "cell file")
    if not isinstance(raw, dict):
        raise ValueError(
            f"cell file {text_path}: expected a mapping with name, boxes, "
            "cylinders, spheres"
        )
    try:
        cell = yaml_load_typed(schema=Cell, data=text_path.read_text("utf-8"))
    except (RuntimeError, TypeError, ValueError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"cell file {text_path}: {first}") from None
    return cell.check(f"cell file {text_path}")
