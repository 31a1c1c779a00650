"""File I/O shared by every part of rmdrake: atomic writes and input checks.

Every file rmdrake writes goes through :func:`atomic_write_text` or
:func:`atomic_write_bytes`: the data is written to a temporary file in the target
folder, flushed, fsync'ed and renamed over the target, so a crash or a bad input
never leaves a half-written or truncated result behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = [
    "atomic_write_bytes",
    "atomic_write_text",
    "as_finite_array",
]


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Writes ``data`` to ``path`` atomically (temp file + fsync + rename).

    The parent folder is created if missing. Returns the resolved path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual mode
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path.resolve()


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Writes UTF-8 ``text`` to ``path`` atomically; see :func:`atomic_write_bytes`."""
    return atomic_write_bytes(path, text.encode("utf-8"))


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
