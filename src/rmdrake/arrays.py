"""Numeric input checked at the boundary: float arrays of a known shape, finite.

Every public function that takes arrays from a user (a file, the command line,
a caller's numpy array) converts them here, so that a NaN, a string or a wrong
shape fails at once with a message naming the argument, not deep inside a solver.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["as_finite_array", "per_joint"]


def as_finite_array(
    value: object,
    what: str,
    shape: Sequence[int | None] | None = None,
) -> np.ndarray:
    """Converts ``value`` to a float64 array and checks it, or raises ValueError.

    Args:
      value: anything ``np.asarray`` accepts.
      what: name used in the error message (for example ``"limits.lower"``).
      shape: expected shape; ``None`` entries accept any length on that axis.

    Raises:
      ValueError: naming ``what``, when the value is not numeric, has the wrong
        shape, or holds NaN or infinite entries.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected numbers, found {value!r}") from None
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == a for s, a in zip(shape, arr.shape, strict=True)
        )
        if not ok:
            parts = ["any" if s is None else str(s) for s in shape]
            want = "(" + ", ".join(parts) + ("," if len(parts) == 1 else "") + ")"
            raise ValueError(f"{what}: expected shape {want}, found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(
            f"{what}: expected finite numbers, found {arr[tuple(bad)]} at index "
            f"{tuple(int(i) for i in bad)}"
        )
    return arr


def per_joint(value: object, n: int, what: str, unit: str) -> np.ndarray:
    """``value`` (one number or n) as an (n,) array of finite values >= 0, or
    ValueError naming ``what`` (and the joint, 1-based)."""
    arr = as_finite_array(value, what)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    arr = as_finite_array(arr, what, (n,))
    if np.any(arr < 0):
        j = int(np.flatnonzero(arr < 0)[0])
        raise ValueError(
            f"{what}: expected >= 0 {unit}, found {arr[j]} (joint {j + 1})"
        )
    return arr
