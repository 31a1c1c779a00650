"""Validation of a calibrated model against the truth: tool-point errors on
held-out poses, with and without the best-fit rigid alignment of the base."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rmdrake.calibration import rigid_alignment, tool_point_errors
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import apply_deltas
from rmdrake.model.robot import RobotModel


@pytest.fixture
def q(rv3sb: RobotModel) -> np.ndarray:
    """200 held-out joint vectors within the limits, rad."""
    return np.random.default_rng(0).uniform(
        rv3sb.limits.lower, rv3sb.limits.upper, (200, rv3sb.n_joints)
    )


def test_zero_error_when_the_model_is_the_truth(rv3sb, q):
    for align in (False, True):
        result = tool_point_errors(rv3sb, rv3sb, q, align=align)
        assert result.errors.shape == (200,)
        assert result.max < 1e-12 and result.aligned == align
        np.testing.assert_allclose(result.X_TC, np.eye(4), atol=1e-12)


def test_base_translation_reported_raw_and_removed_by_alignment(rv3sb, q):
    """dd1 and dr1 move the whole arm along x_B and z_B (alpha1 = 0 on the
    RV-3SB): every tool point is off by the same 2.5 mm vector."""
    shift = np.array([0.0015, 0.0, 0.002])
    moved = apply_deltas(rv3sb, ["dd1", "dr1"], [shift[0], shift[2]])
    offsets = tool_points(moved.table, q) - tool_points(rv3sb.table, q)
    np.testing.assert_allclose(
        offsets, np.broadcast_to(shift, offsets.shape), atol=1e-12
    )

    raw = tool_point_errors(moved, rv3sb, q)
    np.testing.assert_allclose(raw.errors, np.linalg.norm(shift), rtol=1e-9)
    assert not raw.aligned
    np.testing.assert_array_equal(raw.X_TC, np.eye(4))
    assert "alignment" not in raw.describe()

    aligned = tool_point_errors(moved, rv3sb, q, align=True)
    assert aligned.aligned and aligned.max < 1e-12
    # X_TC maps the calibrated model's points onto the true ones: -shift.
    np.testing.assert_allclose(aligned.X_TC[:3, :3], np.eye(3), atol=1e-12)
    np.testing.assert_allclose(aligned.X_TC[:3, 3], -shift, atol=1e-12)
    assert "after best-fit rigid alignment" in aligned.describe()


def test_base_rotation_error_is_the_chord(rv3sb, q):
    """dtheta1 = d turns the arm about z_B: the raw error of a point at radius
    rho from the z_B axis is the chord 2 rho sin(d / 2); aligned it vanishes."""
    d = 0.01
    turned = apply_deltas(rv3sb, ["dtheta1"], [d])
    p = tool_points(rv3sb.table, q)
    rho = np.hypot(p[:, 0], p[:, 1])
    raw = tool_point_errors(turned, rv3sb, q)
    np.testing.assert_allclose(raw.errors, 2 * rho * np.sin(d / 2), rtol=1e-9)
    aligned = tool_point_errors(turned, rv3sb, q, align=True)
    assert aligned.max < 1e-12
    angle = Rotation.from_matrix(aligned.X_TC[:3, :3]).as_rotvec()
    np.testing.assert_allclose(angle, [0.0, 0.0, -d], atol=1e-12)


def test_alignment_never_increases_the_rms_error(rv3sb, q):
    """Least squares over rigid motions includes the identity."""
    rng = np.random.default_rng(3)
    names = ["dalpha2", "dd3", "dtheta4", "dr4", "dd1", "dtheta1"]
    other = apply_deltas(rv3sb, names, 1e-3 * rng.standard_normal(len(names)))
    raw = tool_point_errors(other, rv3sb, q)
    aligned = tool_point_errors(other, rv3sb, q, align=True)
    rms = [np.sqrt(np.mean(r.errors**2)) for r in (raw, aligned)]
    assert rms[1] <= rms[0] * (1 + 1e-12)
    assert rms[1] > 1e-6  # not a rigid motion: an error remains


def test_statistics_are_those_of_the_per_pose_errors(rv3sb, q):
    other = apply_deltas(rv3sb, ["dd3", "dr4"], [1e-3, -2e-3])
    result = tool_point_errors(other, rv3sb, q)
    assert result.mean == pytest.approx(np.mean(result.errors), rel=1e-12)
    assert result.max == np.max(result.errors)
    assert np.min(result.errors) <= result.mean <= result.max
    text = result.describe()
    assert f"mean {result.mean * 1e3:.4f} mm" in text
    assert f"max {result.max * 1e3:.4f} mm" in text
    assert "over 200 held-out poses" in text


def test_rigid_alignment_recovers_a_known_transform():
    rng = np.random.default_rng(5)
    source = rng.uniform(-0.5, 0.5, (30, 3))
    R = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    p = np.array([0.1, -0.05, 0.2])
    target = source @ R.T + p
    X = rigid_alignment(source, target)
    np.testing.assert_allclose(X[:3, :3], R, atol=1e-12)
    np.testing.assert_allclose(X[:3, 3], p, atol=1e-12)
    np.testing.assert_array_equal(X[3], [0, 0, 0, 1])
    assert np.linalg.det(X[:3, :3]) == pytest.approx(1.0, abs=1e-12)
