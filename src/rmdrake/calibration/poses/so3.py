"""Batched SO(3) maps of the pose kind: Exp, Log, the left Jacobian and the
inverse right Jacobian of rotation vectors (rad), vectorised over leading
axes, with Taylor series near 0 and Log exact near pi.

Example::

    import numpy as np
    from rmdrake.calibration.poses.so3 import so3_exp_many, so3_log_many
    r = np.array([[0.1, -0.2, 3.0]])
    assert np.allclose(so3_log_many(so3_exp_many(r)), r)
"""

from __future__ import annotations

import numpy as np

from rmdrake.kinematics.rotations import skew

__all__ = [
    "so3_exp_many",
    "so3_left_jacobian_many",
    "so3_log_many",
    "so3_right_jacobian_inverse_many",
]

_SMALL = 1e-4
"""rad: below it the SO(3) coefficients are their Taylor series."""


def _coefficients(w: np.ndarray) -> tuple[np.ndarray, ...]:
    """theta, sin(t)/t, (1 - cos t)/t^2, (t - sin t)/t^3 of (..., 3) rotation
    vectors, with series near 0."""
    t = np.linalg.norm(w, axis=-1)
    small = t < _SMALL
    ts = np.where(small, 1.0, t)
    t2 = t * t
    a = np.where(small, 1 - t2 / 6, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(ts)) / ts**2)
    c = np.where(small, 1 / 6 - t2 / 120, (ts - np.sin(ts)) / ts**3)
    return t, a, b, c


def so3_exp_many(w: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations Exp(w) of (..., 3) rotation vectors (rad),
    Rodrigues."""
    w = np.asarray(w, dtype=np.float64)
    _, a, b, _ = _coefficients(w)
    W = skew(w)
    return np.eye(3) + a[..., None, None] * W + b[..., None, None] * (W @ W)


def so3_left_jacobian_many(w: np.ndarray) -> np.ndarray:
    """(..., 3, 3) left Jacobians J_l(w) of SO(3): Exp(w + dw) = Exp(J_l(w) dw)
    Exp(w) to first order."""
    w = np.asarray(w, dtype=np.float64)
    _, _, b, c = _coefficients(w)
    W = skew(w)
    return np.eye(3) + b[..., None, None] * W + c[..., None, None] * (W @ W)


def so3_right_jacobian_inverse_many(e: np.ndarray) -> np.ndarray:
    """(..., 3, 3) inverse right Jacobians J_r(e)^-1 of SO(3): Exp(e) Exp(u) =
    Exp(e + J_r(e)^-1 u) to first order in u; angles |e| below 2 pi (stable at
    pi)."""
    e = np.asarray(e, dtype=np.float64)
    t = np.linalg.norm(e, axis=-1)
    small = t < _SMALL
    ts = np.where(small, 1.0, t)
    coef = np.where(
        small, 1 / 12 + t * t / 720, 1 / ts**2 - 1 / (2 * ts * np.tan(ts / 2))
    )
    E = skew(e)
    return np.eye(3) + 0.5 * E + coef[..., None, None] * (E @ E)


def so3_log_many(R: np.ndarray) -> np.ndarray:
    """(..., 3) rotation vectors (angle in [0, pi], rad) of (..., 3, 3)
    rotations; exact near 0 and near pi (the axis from the symmetric part)."""
    R = np.asarray(R, dtype=np.float64)
    v = 0.5 * np.stack(
        [
            R[..., 2, 1] - R[..., 1, 2],
            R[..., 0, 2] - R[..., 2, 0],
            R[..., 1, 0] - R[..., 0, 1],
        ],
        -1,
    )
    s = np.linalg.norm(v, axis=-1)
    c = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    t = np.arctan2(s, c)
    small = t < _SMALL
    factor = np.where(small, 1 + t * t / 6, t / np.where(small, 1.0, np.sin(t)))
    out = factor[..., None] * v
    near_pi = c < -0.9  # sin t small: the axis from (R + R^T)/2 = c I + (1-c) a a^T
    if np.any(near_pi):
        Rn, cn, tn, vn = R[near_pi], c[near_pi], t[near_pi], v[near_pi]
        A = (0.5 * (Rn + np.swapaxes(Rn, -1, -2)) - cn[:, None, None] * np.eye(3)) / (
            1 - cn[:, None, None]
        )
        j = np.argmax(np.diagonal(A, axis1=-2, axis2=-1), axis=-1)
        a = A[np.arange(j.size), :, j]
        a /= np.linalg.norm(a, axis=-1, keepdims=True)
        sign = np.where(np.einsum("ni,ni->n", a, vn) < 0, -1.0, 1.0)
        out[near_pi] = (sign * tn)[:, None] * a
    return out
