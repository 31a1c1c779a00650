"""The batched rotations against two independent oracles: Drake's
RollPitchYaw (the convention rmdrake's files use) and scipy's Rotation."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix
from scipy.spatial.transform import Rotation

from rmdrake.kinematics.rotations import (
    checked_rotations,
    rotation_angle,
    rotation_from_rpy,
    rpy_from_rotation,
)


@pytest.fixture
def rpy(rng) -> np.ndarray:
    """(200, 3) roll, pitch, yaw in rad, pitch inside (-pi/2, pi/2)."""
    out = rng.uniform(-np.pi, np.pi, (200, 3))
    out[:, 1] *= 0.5
    return out


def test_rotation_from_rpy_is_drakes_and_scipys(rpy):
    R = rotation_from_rpy(rpy)
    drake = np.array([RollPitchYaw(a).ToRotationMatrix().matrix() for a in rpy])
    scipy = Rotation.from_euler("xyz", rpy).as_matrix()  # extrinsic x, y, z
    # Rounding of a product of three rotations: a few ulp of 1.
    np.testing.assert_allclose(R, drake, rtol=0, atol=1e-14)
    np.testing.assert_allclose(R, scipy, rtol=0, atol=1e-14)


def test_rpy_from_rotation_is_drakes_inverse(rpy):
    R = rotation_from_rpy(rpy)
    back = rpy_from_rotation(R)
    drake = np.array([RollPitchYaw(RotationMatrix(r)).vector() for r in R])
    np.testing.assert_allclose(back, drake, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back, rpy, rtol=0, atol=1e-12)


def test_rotation_angle_is_the_geodesic_distance(rpy, rng):
    """Against scipy's magnitude of R_a^T R_b, and exact near zero where an
    arccos of the trace would lose half the digits."""
    R_a = rotation_from_rpy(rpy)
    R_b = rotation_from_rpy(rng.uniform(-1.0, 1.0, rpy.shape))
    scipy = (Rotation.from_matrix(R_a).inv() * Rotation.from_matrix(R_b)).magnitude()
    np.testing.assert_allclose(rotation_angle(R_a, R_b), scipy, rtol=0, atol=1e-12)
    tiny = rotation_from_rpy(np.array([[1e-9, 0.0, 0.0]]))
    angle = rotation_angle(np.eye(3)[None], tiny)
    np.testing.assert_allclose(angle, 1e-9, rtol=1e-6)


def test_checked_rotations_refuses_what_is_not_a_rotation():
    R = np.eye(3)[None].repeat(2, axis=0)
    assert checked_rotations(None, 2) is None
    np.testing.assert_array_equal(checked_rotations(R, 2), R)
    np.testing.assert_allclose(checked_rotations(np.zeros((2, 3)), 2), R)
    mirror = R.copy()
    mirror[1, 2, 2] = -1.0
    with pytest.raises(ValueError, match="target 1 is not a rotation matrix"):
        checked_rotations(mirror, 2)
    with pytest.raises(ValueError, match=r"expected shape \(2, 3, 3\)"):
        checked_rotations(np.zeros((2, 4)), 2)
