"""Hypothesis fuzzing of every loader (issue 10): mutated valid files (byte
flips, truncation, inserted bytes, huge numbers, NaN, wrong types, random YAML
structures) give only the documented ``ValueError`` (one line), never another
exception type, and each call stays under a memory cap (tracemalloc peak).

Reproducible and bounded: derandomized, an explicit ``max_examples`` per test
and no wall-clock deadline (a time bound measures the machine's load; the
memory cap and the refusal are the properties).
"""

from __future__ import annotations

import re
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rmdrake.calibration.plates.data import (
    PlaneMeasurements,
    read_plane_measurements,
    write_plane_measurements,
)
from rmdrake.compensation.programs import read_joint_program, read_tool_targets
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.excitation.trajectory import load_fourier
from rmdrake.io.yaml import MAX_NODES
from rmdrake.model.loading import load_robot
from rmdrake.studies.scenarios import SHIPPED_SCENARIOS, load_scenario

PEAK_CAP = 256 * 2**20  # bytes a loader may allocate on a fuzzed small file
FUZZ = settings(
    max_examples=60,
    deadline=None,  # a wall-clock bound measures the machine, not the loader
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)


def _valid_files(d: Path) -> dict[str, bytes]:
    model = load_robot("rv3sb")
    model.save(d / "r.yaml")
    q = np.tile([0.0, 0.0, 0.5, 0.0, 0.8, 0.0], (4, 1))
    write_plane_measurements(
        d / "p.csv", PlaneMeasurements([0, 0, 1, 1], q, [0.05] * 4)
    )
    traj = random_fourier_trajectory(model, fill=0.5, seed=4)
    traj.save(d / "t.yaml")
    t, q, _, _ = traj.sample(2.0)
    write_joint_log(d / "log.csv", JointLog(t=t, q=q, tau=np.zeros_like(q)))
    np.savez(d / "log.npz", t=t, q=q, tau=np.zeros_like(q))
    (d / "targets.csv").write_text("x,y,z\n0.3,0.1,0.4\n0.3,0.2,0.4\n")
    (d / "q.csv").write_text("q1,q2,q3,q4,q5,q6\n0,0,0.5,0,0.8,0\n")
    (d / "s.yaml").write_bytes(SHIPPED_SCENARIOS.read_bytes())
    return {p.name: p.read_bytes() for p in d.iterdir()}


LOADERS: dict[str, Callable[[Path], object]] = {
    "r.yaml": load_robot,
    "p.csv": read_plane_measurements,
    "t.yaml": load_fourier,
    "log.csv": read_joint_log,
    "log.npz": read_joint_log,
    "targets.csv": read_tool_targets,
    "q.csv": read_joint_program,
    "s.yaml": lambda p: load_scenario(p, "paper_smoke"),
}


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> dict[str, bytes]:
    return _valid_files(tmp_path_factory.mktemp("valid"))


def _only_value_error(loader: Callable[[Path], object], path: Path) -> None:
    """Calls the loader: success or one-line ValueError, under the memory cap."""
    tracemalloc.start()
    try:
        loader(path)
    except ValueError as e:
        assert "\n" not in str(e).strip(), str(e)
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peak < PEAK_CAP, f"{path.name}: peak {peak / 2**20:.0f} MiB"


_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["flip", "cut", "insert", "delete"]),
        st.floats(0, 1, allow_nan=False),
        st.binary(min_size=1, max_size=8)
        | st.sampled_from([b"nan", b"1e400", b"-", b"*a", b"&a", b"[", b"{", b"\x00"]),
    ),
    min_size=1,
    max_size=4,
)


def _mutate(data: bytes, edits: list) -> bytes:
    for kind, where, blob in edits:
        i = int(where * len(data))
        if kind == "flip" and data:
            i = min(i, len(data) - 1)
            data = data[:i] + bytes([data[i] ^ blob[0]]) + data[i + 1 :]
        elif kind == "cut":
            data = data[:i]
        elif kind == "insert":
            data = data[:i] + blob + data[i:]
        else:
            data = data[:i] + data[i + len(blob) :]
    return data


@pytest.mark.parametrize("name", list(LOADERS))
@FUZZ
@given(edits=_EDITS)
def test_mutated_files_give_only_value_errors(valid, tmp_path, name, edits):
    path = tmp_path / name
    path.write_bytes(_mutate(valid[name], edits))
    _only_value_error(LOADERS[name], path)


_SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(-(10**30), 10**30)
    | st.floats()
    | st.text(max_size=8)
)
_YAML_VALUES = st.recursive(
    _SCALARS,
    lambda inner: (
        st.lists(inner, max_size=6)
        | st.dictionaries(st.text(max_size=6), inner, max_size=6)
    ),
    max_leaves=40,
)


@pytest.mark.parametrize("name", ["r.yaml", "t.yaml", "s.yaml"])
@FUZZ
@given(key_path=st.lists(st.integers(0, 10), max_size=3), value=_YAML_VALUES)
def test_yaml_with_a_random_value_gives_only_value_errors(
    valid, tmp_path, name, key_path, value
):
    """A random structure (wrong types, huge numbers, NaN) replaces one node."""
    data = yaml.safe_load(valid[name])
    node = data
    for k in key_path:  # walk down to a container, replace one of its children
        children = list(node) if isinstance(node, dict) else node
        if not isinstance(node, (dict, list)) or not children:
            break
        key = children[k % len(children)] if isinstance(node, dict) else k % len(node)
        if not isinstance(node[key], (dict, list)):
            node[key] = value
            break
        node = node[key]
    else:
        if isinstance(node, dict) and node:
            node[next(iter(node))] = value
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    _only_value_error(LOADERS[name], path)


def test_billion_laughs_is_refused(tmp_path):
    """Aliases that would expand to 10^9 nodes are refused at the parse (the
    loader counts the expansion; a wall-clock bound would only measure the
    machine)."""
    path = tmp_path / "lol.yaml"
    lines = ["a: &a [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 10):
        prev = "a" if i == 1 else f"l{i - 1}"
        lines.append(f"l{i}: &l{i} [" + ", ".join([f"*{prev}"] * 10) + "]")
    path.write_text("name: *l9\n" + "\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"lol.yaml: not valid YAML at line 1.*alias"):
        load_robot(path)


def test_a_million_written_nodes_are_refused_where_the_cap_is_crossed(tmp_path):
    """No aliases, just a million list items (2 MB): refused as the parser
    composes node MAX_NODES + 1, not after parsing the whole file (the mark
    names the column of that node, far before the end of the line)."""
    path = tmp_path / "million.yaml"
    path.write_text("name: x\nlinks: [" + ",".join(["0"] * 1_000_000) + "]\n")
    with pytest.raises(ValueError, match=r"line 2, column (\d+): more than 100000 "
                       r"nodes \(refused") as refused:  # fmt: skip
        load_robot(path)
    column = int(re.search(r"column (\d+)", str(refused.value)).group(1))
    assert column < 2 * (MAX_NODES + 1) + 10  # "0," per item after "links: ["


def test_duplicate_key_is_named_with_its_line(valid, tmp_path):
    path = tmp_path / "t.yaml"
    path.write_bytes(valid["t.yaml"] + b"harmonics: 5\n")
    with pytest.raises(ValueError, match=r"line \d+.*duplicate key 'harmonics'"):
        load_fourier(path)


def test_shipped_scenarios_keep_their_anchor():
    assert load_scenario(SHIPPED_SCENARIOS, "paper_smoke").robot
