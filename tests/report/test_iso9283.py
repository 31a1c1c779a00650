"""ISO 9283 test points and pose figures against hand-computed cases."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rmdrake.report.iso9283 import cube_test_points, pose_accuracy


def test_cube_points_lie_on_the_diagonal_plane_at_ten_percent():
    c, L = np.array([0.4, -0.1, 0.5]), 0.2
    R = Rotation.from_euler("xyz", [0.3, -0.2, 0.7]).as_matrix()
    P = cube_test_points(c, L, R)
    assert P.shape == (5, 3)
    np.testing.assert_allclose(P[0], c, atol=1e-15)
    e1, e2, e3 = R.T
    normal = np.cross(e1, (e2 + e3) / np.sqrt(2))
    np.testing.assert_allclose((P - c) @ normal, 0.0, atol=1e-15)  # one plane
    # Each point is 10 % of the plane's diagonal from a cube vertex.
    diagonal = np.sqrt(L**2 + 2 * L**2)
    vertices = c + 0.5 * L * np.array(
        [
            s1 * e1 + s2 * e2 + s3 * e3
            for s1 in (1, -1)
            for s2 in (1, -1)
            for s3 in (1, -1)
        ]
    )
    for p in P[1:]:
        d = np.linalg.norm(vertices - p, axis=1).min()
        assert d == pytest.approx(0.1 * diagonal, rel=1e-12)
    np.testing.assert_allclose(P[1:].mean(axis=0), c, atol=1e-15)


def test_pose_accuracy_of_a_known_offset_and_spread():
    commanded = np.zeros((2, 3))
    # Point 1: every cycle 1 mm off in x -> AP 1 mm, RP 0.
    # Point 2: cycles at +-0.1 mm in y around 0.5 mm in z -> AP 0.5 mm,
    # l_j = 0.1 mm each -> RP = 0.1 mm (no spread of l).
    attained = np.array(
        [
            [[1e-3, 0, 0]] * 4,
            [[0, 1e-4, 5e-4], [0, -1e-4, 5e-4], [0, 1e-4, 5e-4], [0, -1e-4, 5e-4]],
        ]
    )
    r = pose_accuracy(commanded, attained)
    np.testing.assert_allclose(r.AP, [1e-3, 5e-4], rtol=1e-12)
    np.testing.assert_allclose(r.RP, [0.0, 1e-4], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(r.errors[1], np.hypot(1e-4, 5e-4), rtol=1e-12)


def test_repeatability_uses_mean_plus_three_sample_std(rng):
    p = rng.normal(size=(1, 30, 3)) * 1e-5
    r = pose_accuracy(np.zeros((1, 3)), p)
    l = np.linalg.norm(p[0] - p[0].mean(axis=0), axis=1)
    assert r.RP[0] == pytest.approx(l.mean() + 3 * np.std(l, ddof=1), rel=1e-12)


@pytest.mark.parametrize(
    ("commanded", "attained", "message"),
    [
        (np.zeros((2, 3)), np.zeros((3, 4, 3)), "attained: expected shape"),
        (np.zeros((1, 3)), np.zeros((1, 1, 3)), "at least 2 cycles"),
        (np.full((1, 3), np.nan), np.zeros((1, 2, 3)), "commanded: expected finite"),
    ],
)
def test_bad_input(commanded, attained, message):
    with pytest.raises(ValueError, match=message):
        pose_accuracy(commanded, attained)
    with pytest.raises(ValueError, match="side"):
        cube_test_points(np.zeros(3), -1.0)
