"""The one way rmdrake reads YAML: a bounded safe loader.

Every YAML file rmdrake reads (robot, trajectory, scenario) goes through
:func:`read_yaml` or :func:`load_yaml`, which add these rules to PyYAML's safe
loader:

- **nodes**: at most :data:`MAX_NODES` nodes as written, counted while the
  parser composes them (rmdrake's robot, trajectory, scenario and cell files
  hold hundreds to a few thousand; a larger file is refused after the first
  :data:`MAX_NODES`, not parsed whole);
- **aliases**: at most :data:`MAX_ALIASES` alias uses (``*name``) per document,
  and the document expanded through its aliases at most :data:`MAX_NODES` nodes,
  counted on the node graph *before* any Python object is built (a
  "billion laughs" file is refused before it is expanded);
- **depth**: collections nested at most :data:`MAX_DEPTH` deep;
- **size**: files at most :data:`MAX_BYTES` bytes;
- **duplicate keys**: a mapping that gives a key twice is refused, naming the
  key and its line (YAML forbids it; PyYAML silently keeps the last);
- **errors**: every problem is one ``ValueError`` naming the file and, for a
  parse error, the line and column (1-based).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

__all__ = [
    "yaml_number",
    "yaml_vector",
    "MAX_ALIASES",
    "MAX_BYTES",
    "MAX_DEPTH",
    "MAX_NODES",
    "BoundedSafeLoader",
    "load_yaml",
    "read_yaml",
]

MAX_ALIASES = 100
MAX_NODES = 100_000
MAX_DEPTH = 64
MAX_BYTES = 16 * 1024 * 1024
_MERGE_TAG = "tag:yaml.org,2002:merge"


class BoundedSafeLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` with the alias, depth and duplicate-key rules of the
    module docstring (violations raise ``yaml.YAMLError`` subclasses with a mark;
    :func:`load_yaml` turns them into one-line ``ValueError``)."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._aliases = 0
        self._depth = 0
        self._nodes = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"more than {MAX_ALIASES} aliases (refused: alias expansion)",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        self._nodes += 1
        if self._nodes > MAX_NODES:
            raise yaml.composer.ComposerError(
                None,
                None,
                f"more than {MAX_NODES} nodes (refused: rmdrake's YAML files "
                "hold a few thousand)",
                self.peek_event().start_mark,
            )
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"nested more than {MAX_DEPTH} levels deep",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def compose_document(self) -> Any:
        node = super().compose_document()
        if node is not None:
            _check_expanded_size(node)
        return node

    def construct_mapping(self, node: Any, deep: bool = False) -> dict:
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE_TAG:
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    first = seen.get(key)
                except TypeError:
                    raise yaml.constructor.ConstructorError(
                        None, None, "a mapping key that is not a scalar",
                        key_node.start_mark,
                    ) from None  # fmt: skip
                if first is not None:
                    raise yaml.constructor.ConstructorError(
                        None,
                        None,
                        f"duplicate key {key!r} (first at line {first})",
                        key_node.start_mark,
                    )
                seen[key] = line
        return super().construct_mapping(node, deep=deep)


def _check_expanded_size(root: Any) -> None:
    """Refuses a node graph whose tree expansion (aliases followed) exceeds
    :data:`MAX_NODES`; memoized per node, so the check itself is linear."""
    size: dict[int, int] = {}

    def expanded(node: Any) -> int:
        got = size.get(id(node))
        if got is not None:
            return got
        size[id(node)] = MAX_NODES + 1  # a cycle counts as unbounded
        total = 1
        if isinstance(node, yaml.SequenceNode):
            for child in node.value:
                total += expanded(child)
                if total > MAX_NODES:
                    break
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                total += expanded(k) + expanded(v)
                if total > MAX_NODES:
                    break
        size[id(node)] = total
        return total

    if expanded(root) > MAX_NODES:
        raise yaml.composer.ComposerError(
            None,
            None,
            f"expands to more than {MAX_NODES} nodes through its aliases "
            "(refused: alias expansion)",
            root.start_mark,
        )


def load_yaml(
    text: str, source: str, loader: type[BoundedSafeLoader] = BoundedSafeLoader
) -> Any:
    """Parses YAML ``text`` with the rules of the module docstring.

    Args:
      text: the YAML document.
      source: the file name (or a description) that starts every error message.
      loader: :class:`BoundedSafeLoader` or a subclass of it.

    Raises:
      ValueError: ``"<source>: not valid YAML at line L, column C: <problem>"``
        or another one-line message naming ``source``.
    """
    if len(text) > MAX_BYTES:
        raise ValueError(f"{source}: over {MAX_BYTES // 2**20} MiB, refused as YAML")
    try:
        return yaml.load(text, Loader=loader)  # noqa: S506 (a safe subclass)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = e.problem or e.context or type(e).__name__
        raise ValueError(f"{source}: not valid YAML{where}: {problem}") from None
    except yaml.YAMLError as e:
        raise ValueError(f"{source}: not valid YAML ({type(e).__name__})") from None
    except (ValueError, OverflowError, RecursionError) as e:  # e.g. a bad date
        first = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise ValueError(f"{source}: not valid YAML: {first}") from None


def read_yaml(
    path: str | os.PathLike,
    what: str = "YAML",
    loader: type[BoundedSafeLoader] = BoundedSafeLoader,
) -> Any:
    """Reads and parses the UTF-8 YAML file ``path`` (:func:`load_yaml`).

    Raises:
      ValueError: ``"cannot read <what> '<path>': <reason>"`` for a missing,
        unreadable, oversized or non-UTF-8 file; else as :func:`load_yaml`.
    """
    path = Path(path)
    try:
        if path.stat().st_size > MAX_BYTES:
            raise ValueError(f"over {MAX_BYTES // 2**20} MiB")
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise ValueError(f"cannot read {what} '{path}': {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise ValueError(
            f"cannot read {what} '{path}': not UTF-8 text (byte {e.start})"
        ) from None
    except ValueError as e:
        raise ValueError(f"cannot read {what} '{path}': {e}") from None
    return load_yaml(text, str(path), loader)


_DECIMAL = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def yaml_number(value: Any, what: str) -> float:
    """A finite float from a YAML scalar, else ValueError naming ``what``.

    A string written as a decimal number is taken as one (PyYAML, YAML 1.1,
    reads ``5e5`` and ``5.0e5`` as strings); booleans, NaN and infinities are
    refused."""
    if isinstance(value, str) and _DECIMAL.match(value.strip()):
        value = float(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what}: expected a number, found {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{what}: expected a finite number, found {value!r}")
    return float(value)


def yaml_vector(value: Any, what: str, n: int) -> np.ndarray:
    """(n,) floats from a YAML list of n numbers (:func:`yaml_number` each)."""
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{what}: expected a list of {n} numbers, found {value!r}")
    if len(value) != n:
        raise ValueError(f"{what}: expected {n} values, found {len(value)}")
    return np.array([yaml_number(v, f"{what}[{i}]") for i, v in enumerate(value)])
