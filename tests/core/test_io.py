"""File I/O: exact round trips of every format, atomic writes that leave no
partial file, and one-line errors that name the file and the problem."""

from __future__ import annotations

import os

import numpy as np
import pytest

from rmdrake.io import (
    JointLog,
    PlaneMeasurements,
    atomic_write_bytes,
    atomic_write_text,
    read_joint_log,
    read_plane_measurements,
    write_joint_log,
    write_plane_measurements,
)


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
