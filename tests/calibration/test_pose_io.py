"""Pose measurement files: bit-for-bit round trip, the header sniff, and
malformed files refused in one line naming the file."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.poses.data import (
    PoseMeasurements,
    is_pose_header,
    read_pose_header,
    read_pose_measurements,
    write_pose_measurements,
)


def _data(rng: np.random.Generator, N: int = 5) -> PoseMeasurements:
    return PoseMeasurements(
        rng.uniform(-2, 2, (N, 6)), rng.normal(0, 2, (N, 3)), rng.uniform(-1, 1, (N, 3))
    )


def test_round_trip_is_bit_for_bit(tmp_path, rng):
    data = _data(rng)
    path = write_pose_measurements(tmp_path / "poses.csv", data)
    back = read_pose_measurements(path, n_joints=6)
    for key in ("q", "p_IM", "r_IM"):
        assert np.array_equal(getattr(back, key), getattr(data, key))
    assert is_pose_header(read_pose_header(path))


def test_columns_in_any_order(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("rz,x,q2,y,q1,ry,z,rx\n6,1,0.2,2,0.1,5,3,4\n")
    data = read_pose_measurements(path)
    assert np.array_equal(data.q, [[0.1, 0.2]])
    assert np.array_equal(data.p_IM, [[1, 2, 3]])
    assert np.array_equal(data.r_IM, [[4, 5, 6]])


@pytest.mark.parametrize(
    "header, pose",
    [
        ("q1,q2,x,y,z,rx,ry,rz", True),
        ("pose,marker,q1,q2,x,y,z", False),  # points
        ("plane,q1,q2,distance", False),
        ("socket,q1,q2", False),
        ("q1,q2,x,y,z,rx,ry", False),
        ("x,y,z,rx,ry,rz", False),
    ],
)
def test_header_sniff(header, pose):
    assert is_pose_header(header.split(",")) is pose


@pytest.mark.parametrize(
    "text, expected",
    [
        ("q1,q2,x,y,z,rx,ry\n0,0,1,2,3,4,5\n", "missing column(s) rz"),
        ("q1,q2,x,y,z\n0,0,1,2,3\n", "missing column(s) rx,ry,rz"),
        ("x,y,z,rx,ry,rz\n1,2,3,4,5,6\n", "missing column(s) q1..qn"),
        ("q1,q2,x,y,z,rx,ry,rz,w\n0,0,1,2,3,4,5,6,7\n", "unknown column 'w'"),
        ("q1,q2,x,y,z,rx,ry,rz,x\n0,0,1,2,3,4,5,6,7\n", "duplicate column 'x'"),
        ("q1,q2,x,y,z,rx,ry,rz\n0,0,1,2,3,4,5\n", "line 2: 7 columns, not 8"),
        ("q1,q2,x,y,z,rx,ry,rz\n0,0,1,nan,3,4,5,6\n", "column y: 'nan'"),
        ("q1,q2,x,y,z,rx,ry,rz\n0,0,1,2,3,4,5,abc\n", "column rz: 'abc'"),
        ("q1,q2,x,y,z,rx,ry,rz\n", "no data rows"),
        ("q1,q2,q3,x,y,z,rx,ry,rz\n0,0,0,1,2,3,4,5,6\n", "3 joint columns"),
    ],
)
def test_malformed_files_are_refused_in_one_line(tmp_path, text, expected):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        read_pose_measurements(path, n_joints=2)
    message = str(info.value)
    assert expected in message
    assert "\n" not in message and "bad.csv" in message


def test_unreadable_and_binary_files(tmp_path):
    binary = tmp_path / "b.csv"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    for path, expected in (
        (binary, "not a UTF-8"),
        (tmp_path / "no.csv", "cannot read"),
    ):
        with pytest.raises(ValueError, match=expected) as info:
            read_pose_measurements(path)
        assert "\n" not in str(info.value)
