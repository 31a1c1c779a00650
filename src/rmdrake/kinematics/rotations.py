"""Rotation matrices and roll-pitch-yaw angles, batched over M rotations.

Roll, pitch, yaw in rad with Drake's RollPitchYaw convention
R = Rz(yaw) Ry(pitch) Rx(roll) (:class:`pydrake.math.RollPitchYaw`, here
vectorised); the angle between two rotations; and the checked orientation
input of :mod:`rmdrake.compensation` (matrices or roll-pitch-yaw).
"""

from __future__ import annotations

import numpy as np

from rmdrake.arrays import as_finite_array

__all__ = [
    "checked_rotations",
    "rotation_angle",
    "rotation_from_rpy",
    "rpy_from_rotation",
    "skew",
]


def skew(v: np.ndarray) -> np.ndarray:
    """(..., 3, 3) cross-product matrices [v]x of (..., 3) vectors:
    skew(v) @ w = v x w.

    >>> skew(np.array([1.0, 2.0, 3.0])).tolist()
    [[0.0, -3.0, 2.0], [3.0, 0.0, -1.0], [-2.0, 1.0, 0.0]]
    """
    v = np.asarray(v, dtype=np.float64)
    z = np.zeros_like(v[..., 0])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


def rotation_from_rpy(rpy: np.ndarray) -> np.ndarray:
    """(M, 3, 3) rotations R = Rz(yaw) Ry(pitch) Rx(roll) of (M, 3) [roll,
    pitch, yaw] in rad (Drake's RollPitchYaw convention).

    Example:

    >>> import numpy as np
    >>> from rmdrake.kinematics import rotation_from_rpy
    >>> R = rotation_from_rpy(np.array([[0.0, 0.0, np.pi / 2]]))
    >>> (R[0].round(6) + 0.0).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    rpy = as_finite_array(rpy, "rpy", (None, 3))
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy.T), np.sin(rpy.T)
    R = np.empty((rpy.shape[0], 3, 3))
    R[:, 0] = np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], 1)
    R[:, 1] = np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], 1)
    R[:, 2] = np.stack([-sp, cp * sr, cp * cr], 1)
    return R


def rpy_from_rotation(R: np.ndarray) -> np.ndarray:
    """(M, 3) [roll, pitch, yaw] in rad of (M, 3, 3) rotations, the inverse of
    :func:`rotation_from_rpy` with pitch in [-pi/2, pi/2] and roll, yaw in
    (-pi, pi] (at pitch = +-pi/2 only roll +- yaw is defined).

    Example:

    >>> import numpy as np
    >>> from rmdrake.kinematics import rotation_from_rpy, rpy_from_rotation
    >>> rpy = np.array([[0.1, -0.2, 0.3]])
    >>> rpy_from_rotation(rotation_from_rpy(rpy)).round(6).tolist()
    [[0.1, -0.2, 0.3]]
    """
    R = as_finite_array(R, "R", (None, 3, 3))
    pitch = np.arctan2(-R[:, 2, 0], np.hypot(R[:, 0, 0], R[:, 1, 0]))
    roll = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    return np.stack([roll, pitch, yaw], axis=1)


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """(M,) angle of R_a^T R_b, rad, accurate near 0 (atan2 of the skew part's
    norm and trace - 1, not arccos).

    Example:

    >>> import numpy as np
    >>> from rmdrake.kinematics import rotation_angle, rotation_from_rpy
    >>> R_a = rotation_from_rpy(np.zeros((1, 3)))
    >>> R_b = rotation_from_rpy(np.array([[0.0, 0.0, 0.25]]))
    >>> rotation_angle(R_a, R_b).round(6).tolist()
    [0.25]
    """
    E = np.einsum("mji,mjk->mik", R_a, R_b)
    skew = np.stack(
        [E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], 1
    )
    trace = E[:, 0, 0] + E[:, 1, 1] + E[:, 2, 2]
    return np.arctan2(np.linalg.norm(skew, axis=1), trace - 1.0)


def checked_rotations(orientation: object, M: int) -> np.ndarray | None:
    """None, or (M, 3, 3) checked rotations from matrices or roll-pitch-yaw.

    Example:

    >>> import numpy as np
    >>> from rmdrake.kinematics import checked_rotations
    >>> checked_rotations(np.zeros((2, 3)), 2).shape  # roll-pitch-yaw of 2 poses
    (2, 3, 3)
    >>> checked_rotations(None, 2) is None
    True
    """
    if orientation is None:
        return None
    arr = as_finite_array(orientation, "orientation", None)
    if arr.shape == (M, 3):
        return rotation_from_rpy(arr)
    if arr.shape != (M, 3, 3):
        raise ValueError(
            f"orientation: expected shape ({M}, 3, 3) (R_BE) or ({M}, 3) (roll, "
            f"pitch, yaw in rad), found {arr.shape}"
        )
    error = np.abs(np.einsum("mji,mjk->mik", arr, arr) - np.eye(3)).max(axis=(1, 2))
    bad = np.flatnonzero((error > 1e-6) | (np.linalg.det(arr) < 0))
    if bad.size:
        k = int(bad[0])
        raise ValueError(
            f"orientation: target {k} is not a rotation matrix (|R^T R - I| = "
            f"{error[k]:.3g}, det = {np.linalg.det(arr[k]):.3g})"
        )
    return arr
