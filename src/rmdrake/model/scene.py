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
    meshes:
      - {name: jig, file: jig.obj, scale: 0.001, X_BG: {xyz: [...], rpy: [...]}}
    models: [fixtures.sdf, cell.dmd.yaml]

A mesh is a file Drake's ``Convex`` reads (OBJ, VTK, glTF), in its own units
times ``scale`` (0.001 for a CAD export in mm): the clearance is measured to
its convex hull (what Drake's signed-distance queries support), the Meshcat
page draws the mesh itself. ``models`` are SDFormat or URDF files, or Drake
model directives (``*.dmd.yaml``), parsed by Drake into a plant of their own:
every body must be welded to the world (the cell does not move), and their
collision geometries, posed in the world = the robot's base B, join the cell
as ``<model>/<geometry>`` (drawn as what the clearance check uses). Relative
file names are relative to the cell file; ``package://`` URIs must resolve
offline (rmdrake loads nothing from the network).

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
from pydrake.geometry import (
    Box,
    Convex,
    Cylinder,
    Mesh,
    Role,
    SceneGraph,
    Shape,
    Sphere,
)
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import (
    LoadModelDirectives,
    Parser,
    ProcessModelDirectives,
)
from pydrake.multibody.plant import MultibodyPlant

from rmdrake.io.yaml import read_yaml

__all__ = [
    "Cell",
    "CellBox",
    "CellCylinder",
    "CellMesh",
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

    @staticmethod
    def of(X_BG: RigidTransform) -> "CellPose":
        """The pose of a Drake RigidTransform."""
        rpy = RollPitchYaw(X_BG.rotation()).vector()
        xyz = X_BG.translation()
        return CellPose(xyz=[float(v) for v in xyz], rpy=[float(v) for v in rpy])


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


@dataclasses.dataclass
class CellMesh:
    """A mesh ``file`` (vertices in G, in the file's units times ``scale``)."""

    name: str = ""
    file: str = ""
    scale: float = 1.0
    X_BG: CellPose = dataclasses.field(default_factory=CellPose)

    def shape(self) -> Shape:
        """The collision shape, in G: the mesh's convex hull."""
        return Convex(self.file, self.scale)

    def visual_shape(self) -> Shape:
        """The drawn shape, in G: the mesh itself."""
        return Mesh(self.file, self.scale)


@dataclasses.dataclass
class ModelGeometry:
    """A collision geometry of a cell model file, posed in B."""

    name: str
    drake_shape: Shape
    X_BG: CellPose

    def shape(self) -> Shape:
        """The Drake shape, in G."""
        return self.drake_shape


CellShape = CellBox | CellCylinder | CellSphere | CellMesh | ModelGeometry


@dataclasses.dataclass
class Cell:
    """The fixed shapes of a robot cell, each posed in the robot's base B."""

    name: str = "cell"
    boxes: list[CellBox] = dataclasses.field(default_factory=list)
    cylinders: list[CellCylinder] = dataclasses.field(default_factory=list)
    spheres: list[CellSphere] = dataclasses.field(default_factory=list)
    meshes: list[CellMesh] = dataclasses.field(default_factory=list)
    models: list[str] = dataclasses.field(default_factory=list)

    def shapes(self) -> list[CellShape]:
        """Every shape: boxes, cylinders, spheres, meshes, then the models'
        collision geometries, in file order."""
        imported = [g for found in self.imported().values() for g in found]
        return [*self.boxes, *self.cylinders, *self.spheres, *self.meshes, *imported]

    def imported(self, source: str = "cell") -> dict[str, list[ModelGeometry]]:
        """Each model file's collision geometries (:func:`model_geometries`),
        parsed once per file: every plant of a clearance check asks again."""
        parsed = self.__dict__.setdefault("_parsed", {})
        for path in self.models:
            if path not in parsed:
                parsed[path] = model_geometries(path, source)
        return {path: parsed[path] for path in self.models}

    def check(self, source: str = "cell") -> "Cell":
        """Returns self; raises a one-line ValueError (starting with ``source``)
        on an empty or repeated name, a size that is not positive and finite, or
        a pose that is not 3 + 3 finite numbers."""
        seen: set[str] = set()
        for kind, shapes in (
            ("boxes", self.boxes),
            ("cylinders", self.cylinders),
            ("spheres", self.spheres),
            ("meshes", self.meshes),
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
        for path, found in self.imported(source).items():
            for g in found:
                if g.name in seen:
                    raise ValueError(
                        f"{source}: '{g.name}' of {path}: the name is used twice"
                    )
                seen.add(g.name)
        return self


def _check_sizes(shape: CellShape, where: str) -> None:
    """Refuses dimensions (m) that are not positive and finite."""
    if isinstance(shape, CellBox):
        dims = {"size": shape.size}
        if len(shape.size) != 3:
            raise ValueError(f"{where}: size: expected 3 lengths, found {shape.size}")
    elif isinstance(shape, CellCylinder):
        dims = {"radius": [shape.radius], "length": [shape.length]}
    elif isinstance(shape, CellMesh):
        dims = {"scale": [shape.scale]}
        if not Path(shape.file).is_file():
            raise ValueError(f"{where}: file: no such file '{shape.file}'")
    else:
        dims = {"radius": [shape.radius]}
    for key, values in dims.items():
        if not all(math.isfinite(v) and v > 0 for v in values):
            value = values if key == "size" else values[0]
            unit = "" if key == "scale" else " m"
            raise ValueError(
                f"{where}: {key}: expected a positive finite{unit}, found {value}"
            )


def model_geometries(path: str, source: str = "cell") -> list[ModelGeometry]:
    """The collision geometries of a cell model file (SDFormat, URDF, or Drake
    model directives ``*.dmd.yaml``), posed in the world = the robot's base,
    named ``<model instance>/<geometry>``.

    Raises:
      ValueError: one line: the file does not parse, or a body of it is not
        welded to the world.
    """
    plant = MultibodyPlant(0.0)
    scene_graph = SceneGraph()
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    parser = Parser(plant)
    try:
        if str(path).endswith(".dmd.yaml"):
            ProcessModelDirectives(LoadModelDirectives(str(path)), plant, parser)
        else:
            parser.AddModels(str(path))
        plant.Finalize()
    except (RuntimeError, ValueError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"{source}: model {path}: {first}") from None
    if plant.num_positions() > 0:
        moving = [plant.get_body(b).name() for b in plant.GetFloatingBaseBodies()]
        raise ValueError(
            f"{source}: model {path}: bodies {', '.join(moving) or '(jointed)'} "
            "are not welded to the world; a cell does not move (weld them)"
        )
    context = plant.CreateDefaultContext()
    inspector = scene_graph.model_inspector()
    found = []
    for g in inspector.GetAllGeometryIds(Role.kProximity):
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(g))
        X_WB = plant.EvalBodyPoseInWorld(context, body)
        X_BG = X_WB @ inspector.GetPoseInFrame(g)
        model = plant.GetModelInstanceName(body.model_instance())
        found.append(
            ModelGeometry(
                name=f"{model}/{inspector.GetName(g).split('::')[-1]}",
                drake_shape=inspector.GetShape(g).Clone(),
                X_BG=CellPose.of(X_BG),
            )
        )
    return found


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
            "cylinders, spheres, meshes, models"
        )
    try:
        cell = yaml_load_typed(schema=Cell, data=text_path.read_text("utf-8"))
    except (RuntimeError, TypeError, ValueError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"cell file {text_path}: {first}") from None
    folder = text_path.parent
    for mesh in cell.meshes:
        mesh.file = str(folder / mesh.file)  # an absolute name stays as it is
    cell.models = [str(folder / m) for m in cell.models]
    return cell.check(f"cell file {text_path}")
