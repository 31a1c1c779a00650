"""Reading a URDF for :mod:`rmdrake.model.urdf.importer`: Drake's parse (its warnings
collected,
not printed) and what Drake does not keep or changes (joint friction and effort,
the robot's name, the links' inertials), read with expat.

Inertials: Drake's parser (1.51) gives a body whose ``<inertial>`` it cannot
turn into a valid spatial inertia (``<mass value="0">`` with a nonzero
``<inertia>``, as pybullet's Panda has on ``panda_link8``; a non-physical
inertia matrix) a plausible stand-in: a solid water sphere of the given mass, or
of 1 kg when the mass is not positive, centred at the inertial origin, with a
warning. A link without ``<inertial>`` and one with mass 0 and a zero inertia are
massless. The importer takes a mass-0 link as massless whatever its inertia,
refuses a negative mass, and keeps Drake's stand-in for a non-physical inertia
of positive mass (right mass and centre of mass, a valid inertia), naming the
link: :func:`body_inertial`."""

from __future__ import annotations

import logging
import math
import os
import xml.parsers.expat
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RigidBody

from rmdrake.drake_log import drake_messages_dropped
from rmdrake.model.dynamic_parameters import standard_from_spatial_inertia

__all__ = ["body_inertial", "link_inertial", "parse_urdf", "urdf_plant"]

_JOINTS = ("revolute", "continuous", "prismatic", "fixed")
_UNUSED_TAGS = ("safety_controller", "calibration")
"""Joint tags Drake's parser ignores with a warning that rmdrake does not use
either (a controller's soft limits and gains, an encoder's reference
position): their warnings are dropped."""
_HANDLED = ("'friction'", "While re-expressing as central", "While parsing inertia")
# Gear ratios and coupled joints: read from the XML (ros_control's
# <mechanicalReduction>, FourBarLinkageTransmission), see the importer.
_HANDLED += ("mechanicalReduction element with a value", "Drake only supports 'Simpl")
_HANDLED += tuple(f"The tag '{tag}' found as a child of" for tag in _UNUSED_TAGS)
_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
# Drake 1.51's parser warns once per joint with Coulomb friction, e.g. for a URDF
# written by robot_to_urdf (which keeps fc in <dynamics friction>):
#   WARNING:drake:/tmp/x.urdf:9: warning: A joint has specified a non-zero value
#   for the 'friction' attribute of a joint/dynamics tag. MultibodyPlant does not
#   currently support non-zero joint friction.
# Harmless here: rmdrake models joint friction itself (fv, fc of the 13 dynamic
# parameters; parse_urdf reads fc from the file) and uses Drake's plant for the
# rigid-body terms only. That message alone is dropped; Drake's others pass.
_FRICTION_IGNORED = (
    "specified a non-zero value for the 'friction' attribute of a joint/dynamics tag"
)


def parse_urdf(path: Path) -> tuple[MultibodyPlant, list[str], dict]:
    """The finalized plant of the URDF (root welded, :func:`urdf_plant`), the
    first lines of Drake's parser warnings (friction and inertial ones dropped:
    those are read here; those on the joint tags ``safety_controller`` and
    ``calibration``, which nothing reads), and the XML's robot name, per-joint
    ``type``, ``effort`` and ``friction``, and per-link inertial (``{"name": str | None,
    "joints": {name: {...}}, "links": {name: {...} or None}}``, None: no
    ``<inertial>``; the entries are text, see :func:`link_inertial`).

    Raises:
      ValueError: one line: the parser's first, the joint of a type that
        leaves the file with several roots (floating), or a joint whose
        ``<limit>`` has lower > upper or a negative velocity or effort (named
        with the attribute; Drake's parser would abort on the first two).
    """
    info = _read_xml(path)  # first: it refuses what Drake's parser aborts on
    with _drake_log() as log:
        try:
            plant = _drake_plant(path)
        except ValueError as e:  # a floating joint leaves two roots: name it
            odd = [(k, v["type"]) for k, v in info["joints"].items()
                   if v["type"] not in _JOINTS]  # fmt: skip
            if "are all roots" not in str(e) or not odd:
                raise
            raise ValueError(
                f"{path}: joint '{odd[0][0]}' is {odd[0][1]}: expected revolute, "
                "prismatic, continuous or fixed"
            ) from None
    return plant, log, info


def _read_xml(path: Path) -> dict:
    """The robot name; per joint, its type, ``<limit effort lower upper
    velocity>`` and ``<dynamics friction>`` (swapped limits and a negative
    velocity or effort refused); per link, its ``<inertial>`` (``origin``,
    ``mass``, ``inertia`` attributes, text); the ``<transmission>`` elements
    (``{"name", "type", "joints": [{"name", "reduction"}], "actuators":
    [{"name", "reduction"}]}``, reductions as text or None), read with expat
    (no namespaces)."""
    info: dict = {"name": None, "joints": {}, "links": {}, "transmissions": []}
    stack: list[str] = []
    current: list[dict] = []
    link: list[str] = []
    text: list[str] = []

    def start(tag, attrs):
        text.clear()
        if tag == "transmission" and stack == ["robot"]:
            info["transmissions"].append(
                {"name": attrs.get("name"), "type": "", "joints": [], "actuators": []}
            )
        elif stack[-2:] == ["robot", "transmission"] and tag in ("joint", "actuator"):
            info["transmissions"][-1][tag + "s"].append(
                {"name": attrs.get("name"), "reduction": None}
            )
        if tag == "robot" and not stack:
            info["name"] = attrs.get("name")
        elif tag == "joint" and stack == ["robot"] and "name" in attrs:
            entry = {"type": attrs.get("type")}
            info["joints"][attrs["name"]] = entry
            current.append(entry)
        elif stack[-2:] == ["robot", "joint"] and current:
            if tag == "limit" and "effort" in attrs:
                current[-1]["effort"] = attrs["effort"]
            if tag == "limit":
                current[-1].update(
                    {k: attrs[k] for k in ("lower", "upper", "velocity") if k in attrs}
                )
            if tag == "dynamics" and "friction" in attrs:
                current[-1]["friction"] = attrs["friction"]
        elif tag == "link" and stack == ["robot"] and "name" in attrs:
            info["links"][attrs["name"]] = None
            link[:] = [attrs["name"]]
        elif tag == "inertial" and stack == ["robot", "link"] and link:
            info["links"][link[0]] = {}
        elif stack == ["robot", "link", "inertial"] and link:
            info["links"][link[0]][tag] = dict(attrs)
        stack.append(tag)

    def end(tag):
        stack.pop()
        if stack[-2:] == ["robot", "transmission"] and tag == "type":
            info["transmissions"][-1]["type"] = "".join(text).strip()
        if stack[-2:] == ["transmission", "joint"] and tag == "mechanicalReduction":
            info["transmissions"][-1]["joints"][-1]["reduction"] = "".join(text)
        if stack[-2:] == ["transmission", "actuator"] and tag == "mechanicalReduction":
            info["transmissions"][-1]["actuators"][-1]["reduction"] = "".join(text)
        if tag == "joint" and stack == ["robot"] and current:
            current.pop()
        if tag == "link" and stack == ["robot"]:
            link.clear()

    parser = xml.parsers.expat.ParserCreate()
    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.CharacterDataHandler = text.append
    try:
        parser.Parse(path.read_bytes(), True)
    except xml.parsers.expat.ExpatError as e:
        raise ValueError(f"{path}: cannot parse URDF: {e}") from None
    for name, entry in info["joints"].items():
        keys = ("effort", "friction", "lower", "upper", "velocity")
        for key in keys if entry["type"] in _JOINTS else ():
            try:
                float(entry.get(key, 0.0))
            except ValueError:
                raise ValueError(
                    f"{path}: joint '{name}': {key} {entry[key]!r} is not a number"
                ) from None
        for key in ("velocity", "effort") if entry["type"] in _JOINTS else ():
            if float(entry.get(key, 0.0)) < 0:  # velocity: Drake's parser aborts
                raise ValueError(
                    f"{path}: joint '{name}': <limit {key}=\"{entry[key]}\"> is "
                    f"negative: the {key} limit is a magnitude (expected > 0"
                    + (
                        ', or effort="0": a kinematic-only model)'
                        if key == "effort"
                        else ")"
                    )
                )
        if entry["type"] in ("revolute", "prismatic") and float(
            entry.get("lower", 0.0)
        ) > float(entry.get("upper", 0.0)):
            raise ValueError(  # Drake's parser aborts on it (joint.h)
                f"{path}: joint '{name}': <limit lower=\"{entry['lower']}\"> is above "
                f'upper="{entry["upper"]}": swapped limits'
            )
    return info


def link_inertial(info: dict, link: str, path: Path) -> np.ndarray:
    """The 10 standard parameters ``XX XY XZ YY YZ ZZ MX MY MZ M`` of URDF link
    ``link`` about its frame's origin in its axes (kg m^2, kg m, kg), from the
    file's ``<inertial>`` (``info`` from :func:`parse_urdf`): zero without one or
    with mass 0 (whatever its ``<inertia>``); missing entries read as 0 (as
    Drake reads them); a non-physical inertia is kept as written.

    Raises:
      ValueError: one line: an entry is not a number, the mass is negative.
    """
    entry = info["links"].get(link) or {}
    origin, inertia = entry.get("origin", {}), entry.get("inertia", {})
    try:
        m = float(entry.get("mass", {}).get("value", 0.0))
        xyz = [float(x) for x in origin.get("xyz", "0 0 0").split()]
        rpy = [float(x) for x in origin.get("rpy", "0 0 0").split()]
        ixx, ixy, ixz, iyy, iyz, izz = (float(inertia.get(k, 0.0)) for k in _INERTIA)
    except ValueError as e:
        raise ValueError(f"{path}: link '{link}': <inertial>: {e}") from None
    if len(xyz) != 3 or len(rpy) != 3 or not all(map(math.isfinite, [m, *xyz])):
        raise ValueError(f"{path}: link '{link}': <inertial> origin or mass")
    if m < 0.0:
        raise ValueError(f"{path}: link '{link}': <mass value> {m} is negative")
    if m == 0.0:
        return np.zeros(10)
    R = RollPitchYaw(rpy).ToRotationMatrix().matrix()
    I_c = R @ np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]) @ R.T
    c = np.array(xyz)
    I_o = I_c + m * ((c @ c) * np.eye(3) - np.outer(c, c))
    return np.array([*I_o[0], I_o[1, 1], I_o[1, 2], I_o[2, 2], *(m * c), m])


def body_inertial(info: dict, body: RigidBody, path: Path) -> tuple[np.ndarray, str]:
    """The 10 standard parameters of ``body`` (a link of the file, ``info`` from
    :func:`parse_urdf`) about its origin in its axes (kg m^2, kg m, kg) that the
    import uses, and how they came: ``""`` (the file's, as Drake parsed them),
    ``"massless"`` (mass 0 with a nonzero inertia: zero, where Drake has a 1 kg
    sphere) or ``"stand-in"`` (a non-physical inertia: Drake's sphere of the
    file's mass at its centre of mass).

    Raises:
      ValueError: one line, as :func:`link_inertial`.
    """
    mine = link_inertial(info, body.name(), path)
    if mine[9] == 0.0:
        return mine, ("massless" if body.default_mass() != 0.0 else "")
    drake = standard_from_spatial_inertia(body.default_spatial_inertia())
    same = np.allclose(drake, mine, rtol=1e-9, atol=1e-12 * max(1.0, mine[9]))
    return drake, ("" if same else "stand-in")


@contextmanager
def _drake_log():
    """Collects the first lines of Drake's parser warnings instead of printing
    them (friction and inertial warnings dropped: fc and the inertials are read
    from the file; those on the unused tags ``safety_controller`` and
    ``calibration`` too)."""
    lines: list[str] = []

    class _Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            text = record.getMessage().splitlines()[0]
            if not any(k in text for k in _HANDLED):
                lines.append(text)

    logger = logging.getLogger("drake")
    handler, propagate = _Keep(logging.WARNING), logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        yield lines
    finally:
        logger.removeHandler(handler)
        logger.propagate = propagate


def urdf_plant(path: str | os.PathLike, gravity: np.ndarray | None = None):
    """A finalized continuous MultibodyPlant of a URDF serial arm.

    The URDF's root link (the one link that is no joint's child) is welded to the
    world unless the URDF attaches it itself. Gravity defaults to Drake's
    (0, 0, -9.81) m/s^2. The plant has no joint friction (Drake's parser
    ignores ``<dynamics friction>``; its warning saying so is not printed).

    Raises:
      ValueError: unreadable or invalid URDF, or several root links.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import load_robot, robot_to_urdf
    >>> from rmdrake.dynamics import urdf_plant
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp, "rv3sb.urdf")
    ...     _ = path.write_text(robot_to_urdf(load_robot("rv3sb")))
    ...     plant = urdf_plant(path)
    ...
    >>> plant.num_positions(), plant.is_finalized()
    (6, True)
    """
    path = Path(path)
    _read_xml(path)  # refuses what Drake's parser would abort on
    return _drake_plant(path, gravity)


def _drake_plant(path: Path, gravity: np.ndarray | None = None) -> MultibodyPlant:
    """:func:`urdf_plant` once the XML pass has accepted the file."""
    plant = MultibodyPlant(0.0)
    try:
        with drake_messages_dropped(_FRICTION_IGNORED):
            instances = Parser(plant).AddModels(str(path))
    except Exception as e:  # Drake raises RuntimeError with a long message
        msg = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise ValueError(f"{path}: cannot parse URDF: {msg}") from None
    children = {
        plant.get_joint(i).child_body().index() for i in plant.GetJointIndices()
    }
    roots = [
        plant.get_body(b)
        for inst in instances
        for b in plant.GetBodyIndices(inst)
        if b not in children
    ]
    if len(roots) > 1:
        names = ", ".join(f"'{b.name()}'" for b in roots)
        raise ValueError(
            f"{path}: not a serial chain: links {names} are all roots (no joint "
            "attaches them)"
        )
    if roots:
        plant.WeldFrames(plant.world_frame(), roots[0].body_frame(), RigidTransform())
    if gravity is not None:
        plant.mutable_gravity_field().set_gravity_vector(gravity)
    plant.Finalize()
    return plant
