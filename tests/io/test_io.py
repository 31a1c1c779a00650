"""File I/O: exact round trips of every format, atomic writes that leave no
partial file, and one-line errors that name the file and the problem."""

from __future__ import annotations

import os

import numpy as np
import pytest

from rmdrake.calibration.plates.data import (
    PlaneMeasurements,
    read_plane_measurements,
    write_plane_measurements,
)
from rmdrake.compensation.programs import (
    JointProgram,
    ToolTargets,
    read_joint_program,
    read_tool_targets,
    write_joint_program,
    write_tool_targets,
)
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.io.atomic import atomic_write_bytes, atomic_write_text


def test_atomic_write_replaces_whole_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "out.txt"
    atomic_write_text(path, "first")
    atomic_write_bytes(path, b"second")
    assert path.read_bytes() == b"second"
    assert os.listdir(tmp_path) == ["out.txt"]


def test_plane_measurements_round_trip_bit_for_bit(tmp_path, rng):
    data = PlaneMeasurements(
        np.repeat(np.arange(4), 5),
        rng.uniform(-2.0, 2.0, (20, 6)),
        rng.uniform(0.005, 0.08, 20),
    )
    path = write_plane_measurements(tmp_path / "p.csv", data)
    back = read_plane_measurements(path, 6)
    assert np.array_equal(back.plane, data.plane)
    assert np.array_equal(back.q, data.q)
    assert np.array_equal(back.distance, data.distance)


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
@pytest.mark.parametrize("derivatives", [True, False])
def test_joint_log_round_trip_bit_for_bit(tmp_path, rng, suffix, derivatives):
    n, N = 3, 50
    t = np.arange(N) / 150.0
    extra = {}
    if derivatives:
        extra = {"qd": rng.normal(size=(N, n)), "qdd": rng.normal(size=(N, n))}
    log = JointLog(t=t, q=rng.normal(size=(N, n)), tau=rng.normal(size=(N, n)), **extra)
    back = read_joint_log(write_joint_log(tmp_path / f"log{suffix}", log), n)
    for name in ("t", "q", "tau", "qd", "qdd"):
        a, b = getattr(log, name), getattr(back, name)
        assert (a is None and b is None) or np.array_equal(a, b), name


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("plane,q1,q2,distance\n0,0.1,0.2,nan\n", "distance"),
        ("plane,q1,q2,distance\n0,0.1,abc,0.02\n", ""),
        ("plane,q1,distance\n0,0.1,0.02\n", "2 joint"),
        ("x,y\n1,2\n", "header"),
    ],
)
def test_bad_plane_files_name_the_file(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match="bad.csv") as info:
        read_plane_measurements(path, 2)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_log_is_a_clear_error(tmp_path):
    with pytest.raises((ValueError, FileNotFoundError), match="nothere.csv"):
        read_joint_log(tmp_path / "nothere.csv", 6)


# ---- tool targets and joint programs (rmdrake.compensation, on io's CSV reader) ----
def _same(a, b) -> bool:
    return (a is None and b is None) or np.array_equal(a, b)


@pytest.mark.parametrize("rpy", [True, False])
@pytest.mark.parametrize("t", [True, False])
def test_tool_targets_round_trip_bit_for_bit(tmp_path, rng, rpy, t):
    targets = ToolTargets(
        rng.uniform(-1.5, 1.5, (25, 3)),
        rng.uniform(-np.pi, np.pi, (25, 3)) if rpy else None,
        np.cumsum(rng.uniform(1e-3, 0.1, 25)) if t else None,
    )
    back = read_tool_targets(write_tool_targets(tmp_path / "targets.csv", targets))
    assert all(_same(a, b) for a, b in zip(back, targets, strict=True))


@pytest.mark.parametrize("t", [True, False])
def test_joint_program_round_trip_bit_for_bit(tmp_path, rng, t):
    program = JointProgram(
        rng.uniform(-3.0, 3.0, (40, 6)), np.arange(40) * 0.004 + 1.0 if t else None
    )
    back = read_joint_program(write_joint_program(tmp_path / "q.csv", program), 6)
    assert _same(back.q, program.q) and _same(back.t, program.t)


def test_columns_may_come_in_any_order(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("yaw,z,t,x,pitch,y,roll\n6,3,0.5,1,5,2,4\n")
    back = read_tool_targets(path)
    assert back.p_BE.tolist() == [[1, 2, 3]] and back.rpy.tolist() == [[4, 5, 6]]
    assert back.t.tolist() == [0.5]
    path.write_text("q2,t,q1\n2,0,1\n4,1,3\n")
    assert read_joint_program(path).q.tolist() == [[1, 2], [3, 4]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("x,y,z\n0.1,0.2,abc\n", "line 2, column z: 'abc' is not a finite number"),
        ("x,y,z\n\n0.1,0.2,inf\n", "line 3, column z"),
        ("x,y,z\n0.1,0.2\n", "line 2: 2 columns, not 3"),
        ("x,y,z,roll\n1,2,3,4\n", "line 1: missing column(s) pitch,yaw"),
        ("x,y,w\n1,2,3\n", "missing column(s) z"),
        ("x,y,z,x\n1,2,3,1\n", "duplicate column 'x'"),
        ("x,y,z,speed\n1,2,3,1\n", "unknown column 'speed'"),
        ("t,x,y,z\n0,1,2,3\n0,1,2,3\n", "line 3, column t"),
        ("x,y,z\n", "no data rows"),
    ],
)
def test_bad_target_files_name_file_line_and_column(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match="bad.csv") as info:
        read_tool_targets(path)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "n_joints", "message"),
    [
        ("t,q1,q2\n0,1,2\n", 6, "line 1: 2 joint columns, expected 6"),
        ("q1,q2,q4\n1,2,3\n", None, "missing column(s) q3"),
        ("q1,q2\n1,nan\n", None, "line 2, column q2"),
        ("t,q1\n1,0\n0.5,0\n", None, "line 3, column t"),
    ],
)
def test_bad_program_files_name_file_line_and_column(tmp_path, text, n_joints, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match="bad.csv") as info:
        read_joint_program(path, n_joints)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_target_file_and_bad_writes(tmp_path):
    with pytest.raises(ValueError, match="cannot read tool targets .*nothere.csv"):
        read_tool_targets(tmp_path / "nothere.csv")
    with pytest.raises(ValueError, match="p_BE: expected finite"):
        write_tool_targets(tmp_path / "a.csv", ToolTargets(np.full((2, 3), np.nan)))
    with pytest.raises(ValueError, match="t: expected strictly increasing"):
        write_joint_program(tmp_path / "b.csv", JointProgram(np.zeros((2, 6)), [1, 1]))
    assert os.listdir(tmp_path) == []


def test_csv_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Spreadsheets save UTF-8 CSV with a byte-order mark; it is not part of
    the header. A binary file is refused naming it."""
    from rmdrake.calibration.plates.data import (
        read_plane_measurements,
        write_plane_measurements,
    )
    from rmdrake.compensation.programs import (
        ToolTargets,
        read_tool_targets,
        write_tool_targets,
    )

    data = PlaneMeasurements(
        plane=np.array([0, 0, 1]), q=np.zeros((3, 2)), distance=np.full(3, 0.1)
    )
    plain = write_plane_measurements(tmp_path / "p.csv", data)
    marked = tmp_path / "bom.csv"
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    np.testing.assert_array_equal(read_plane_measurements(marked).q, data.q)
    targets = write_tool_targets(
        tmp_path / "t.csv", ToolTargets(np.ones((2, 3)), None, None)
    )
    marked_t = tmp_path / "bom_t.csv"
    marked_t.write_bytes(b"\xef\xbb\xbf" + targets.read_bytes())
    np.testing.assert_array_equal(read_tool_targets(marked_t).p_BE, np.ones((2, 3)))
    binary = tmp_path / "bin.csv"
    binary.write_bytes(bytes(range(128, 256)))
    with pytest.raises(ValueError, match=r"bin.csv: not a UTF-8 text file"):
        read_plane_measurements(binary)
