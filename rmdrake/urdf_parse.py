"""Reading a URDF for :mod:`rmdrake.urdf`: Drake's parse (its warnings collected,
not printed) and what Drake does not keep (joint friction and effort, the
robot's name), read with expat."""

from __future__ import annotations

import logging
import xml.parsers.expat
from contextlib import contextmanager
from pathlib import Path

from pydrake.multibody.plant import MultibodyPlant

from rmdrake.dynamics.chain import urdf_plant

__all__ = ["parse_urdf"]

_JOINTS = ("revolute", "continuous", "prismatic", "fixed")


def parse_urdf(path: Path) -> tuple[MultibodyPlant, list[str], dict]:
    """The finalized plant of the URDF (root welded, :func:`urdf_plant`), the
    first lines of Drake's parser warnings (friction ones dropped: the friction
    is read here), and the XML's robot name and per-joint ``type``, ``effort``
    and ``friction`` (``{"name": str | None, "joints": {name: {...}}}``).

    Raises:
      ValueError: one line: the parser's first, or the joint of a type that
        leaves the file with several roots (floating).
    """
    with _drake_log() as log:
        try:
            plant = urdf_plant(path)
        except ValueError as e:  # a floating joint leaves two roots: name it
            odd = [(k, v["type"]) for k, v in _read_xml(path)["joints"].items()
                   if v["type"] not in _JOINTS]  # fmt: skip
            if "are all roots" not in str(e) or not odd:
                raise
            raise ValueError(
                f"{path}: joint '{odd[0][0]}' is {odd[0][1]}: expected revolute, "
                "prismatic, continuous or fixed"
            ) from None
    return plant, log, _read_xml(path)


def _read_xml(path: Path) -> dict:
    """The robot name and, per joint, its type, ``<limit effort>`` and
    ``<dynamics friction>`` (text), read with expat (no namespaces)."""
    info: dict = {"name": None, "joints": {}}
    stack: list[str] = []
    current: list[dict] = []

    def start(tag, attrs):
        if tag == "robot" and not stack:
            info["name"] = attrs.get("name")
        elif tag == "joint" and stack == ["robot"] and "name" in attrs:
            entry = {"type": attrs.get("type")}
            info["joints"][attrs["name"]] = entry
            current.append(entry)
        elif stack[-2:] == ["robot", "joint"] and current:
            if tag == "limit" and "effort" in attrs:
                current[-1]["effort"] = attrs["effort"]
            if tag == "dynamics" and "friction" in attrs:
                current[-1]["friction"] = attrs["friction"]
        stack.append(tag)

    def end(tag):
        stack.pop()
        if tag == "joint" and stack == ["robot"] and current:
            current.pop()

    parser = xml.parsers.expat.ParserCreate()
    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(path.read_bytes(), True)
    except xml.parsers.expat.ExpatError as e:
        raise ValueError(f"{path}: cannot parse URDF: {e}") from None
    for name, entry in info["joints"].items():
        for key in ("effort", "friction") if entry["type"] in _JOINTS else ():
            try:
                float(entry.get(key, 0.0))
            except ValueError:
                raise ValueError(
                    f"{path}: joint '{name}': {key} {entry[key]!r} is not a number"
                ) from None
    return info


@contextmanager
def _drake_log():
    """Collects the first lines of Drake's parser warnings instead of printing
    them (friction warnings dropped: fc is read from the file)."""
    lines: list[str] = []

    class _Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            text = record.getMessage().splitlines()[0]
            if "'friction'" not in text:
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
