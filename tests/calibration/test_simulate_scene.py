"""simulate-plates / simulate-points with a robot cell: no pose comes closer
than the clearance; without a cell the readings are those of the code before
cells existed (references in tests/calibration/data, written by it), to a
tolerance another CPU meets (the IK's last bits)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from conftest import cell_distances

from rmdrake.calibration.plates.data import read_plane_measurements
from rmdrake.calibration.points.data import read_point_measurements
from rmdrake.cli.commands import main
from rmdrake.kinematics.clearance import default_collision_radius
from rmdrake.model.loading import load_robot
from rmdrake.model.scene import load_cell

DATA = Path(__file__).parent / "data"


def test_simulate_plates_without_scene_is_unchanged(tmp_path, capsys):
    out = tmp_path / "plates.csv"
    assert main(["simulate-plates", "--robot", "rv3sb", "--out", str(out),
                 "--seed", "3"]) == 0  # fmt: skip
    new = read_plane_measurements(out)
    ref = read_plane_measurements(DATA / "plates_rv3sb_seed3.csv")
    np.testing.assert_array_equal(new.plane, ref.plane)
    np.testing.assert_allclose(new.q, ref.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(new.distance, ref.distance, rtol=0, atol=1e-9)


def test_simulate_points_without_scene_is_unchanged(tmp_path, capsys):
    out = tmp_path / "points.csv"
    argv = ["simulate-points", "--robot", "rv3sb", "--out", str(out), "--poses"]
    argv += ["20", "--markers", "2", "--noise", "2e-5", "--seed", "1"]
    assert main(argv) == 0
    new = read_point_measurements(out)
    ref = read_point_measurements(DATA / "points_rv3sb_seed1_p20_m2.csv")
    np.testing.assert_array_equal(new.pose, ref.pose)
    np.testing.assert_allclose(new.q, ref.q, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(new.marker, ref.marker)
    np.testing.assert_allclose(new.p_I, ref.p_I, rtol=0, atol=1e-9)


def test_simulate_plates_with_scene_has_no_colliding_pose(tmp_path, capsys):
    model = load_robot("rv3sb")
    cell = load_cell("rv3sb_table")
    radius = default_collision_radius(model)
    out = tmp_path / "plates.csv"
    argv = ["simulate-plates", "--robot", "rv3sb", "--out", str(out), "--seed", "3"]
    assert main([*argv, "--scene", "rv3sb_table", "--clearance", "0.05"]) == 0
    q = read_plane_measurements(out).q
    assert q.shape == (60, 6)
    assert cell_distances(model, cell, radius, q).min() >= 0.05
    # the cell matters: without it some reading poses come closer
    plain = read_plane_measurements(DATA / "plates_rv3sb_seed3.csv").q
    assert cell_distances(model, cell, radius, plain).min() < 0.05


def test_simulate_points_with_scene_has_no_colliding_pose(tmp_path, capsys):
    model = load_robot("rv3sb")
    cell = load_cell("rv3sb_table")
    out = tmp_path / "points.csv"
    argv = ["simulate-points", "--robot", "rv3sb", "--out", str(out), "--poses"]
    argv += ["20", "--markers", "2", "--seed", "1", "--scene", "rv3sb_table"]
    assert main(argv) == 0
    q = read_point_measurements(out).q
    d = cell_distances(model, cell, default_collision_radius(model), q)
    assert np.all(d >= 0.05)


def test_self_collision_keeps_the_links_apart_too(tmp_path, capsys):
    """--self-collision: every pose keeps the clearance (80 mm) from the cell
    and between non-adjacent links' capsules (oracle: the checker's full signed
    distances; the cell part is checked against Drake on a fresh plant above).
    Without the flag the same run has two links' capsules 60 mm apart."""
    from rmdrake.kinematics.clearance import ClearanceChecker

    model = load_robot("rv3sb")
    out = tmp_path / "points.csv"
    argv = ["simulate-points", "--robot", "rv3sb", "--out", str(out), "--poses"]
    argv += ["20", "--markers", "2", "--seed", "1", "--scene", "rv3sb_table"]
    argv += ["--clearance", "0.08"]
    checker = ClearanceChecker(model=model, cell=load_cell("rv3sb_table"))
    assert main(argv) == 0
    assert checker.distances(read_point_measurements(out).q)[1].min() < 0.08
    assert main([*argv, "--self-collision"]) == 0
    d_cell, d_self = checker.distances(read_point_measurements(out).q)
    assert d_cell.min() >= 0.08 and d_self.min() >= 0.08
