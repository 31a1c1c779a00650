"""Reading NPZ archives safely: names, dtypes and shapes are checked from each
member's ``.npy`` header before any array data is decompressed.

Rules (each refusal is one ``ValueError`` line): only the expected array names;
real numbers only (integer or floating; complex arrays are refused rather than
silently losing their imaginary part; objects are never unpickled); the
expected number of dimensions; and the arrays' total size, as their headers
announce it, within :data:`rmdrake.limits.MEMORY_CAP_BYTES` (a compression bomb
or a header announcing 1e12 values is refused without reading its data).
"""

from __future__ import annotations

import math
import os
import zipfile
from pathlib import Path
from typing import BinaryIO

import numpy as np

from rmdrake.limits import check_memory

__all__ = ["read_npz_arrays"]


class _Refused(ValueError):
    """An archive refused from its headers (passed on unchanged)."""


def _header(f: BinaryIO) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(f)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(f)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(f)
    else:
        raise _Refused(f"unsupported .npy version {version}")
    return shape, dtype


def _npz_headers(
    zf: zipfile.ZipFile, ndim: dict[str, int]
) -> dict[str, tuple[str, tuple[int, ...]]]:
    """Member name -> (array name, shape), from the headers only."""
    out: dict[str, tuple[str, tuple[int, ...]]] = {}
    total = 0.0
    expected = ", ".join(ndim)
    for info in zf.infolist():
        key = info.filename[:-4] if info.filename.endswith(".npy") else ""
        if key not in ndim:
            raise _Refused(f"unknown array '{info.filename}' (expected {expected})")
        with zf.open(info) as f:
            try:
                shape, dtype = _header(f)
            except _Refused as e:
                raise _Refused(f"array '{key}': {e}") from None
        if dtype.kind not in "fiu" or dtype.hasobject:
            kind = "complex" if dtype.kind == "c" else f"dtype {dtype}"
            raise _Refused(f"array '{key}': {kind} values refused (expected real)")
        if len(shape) != ndim[key]:
            raise _Refused(
                f"array '{key}': expected {ndim[key]} dimension(s), found shape {shape}"
            )
        total += float(math.prod(shape))
        out[info.filename] = (key, shape)
    try:
        check_memory(total, "the NPZ's arrays (as float64)", "refused before reading")
    except ValueError as e:
        raise _Refused(str(e)) from None
    return out


def read_npz_arrays(
    path: str | os.PathLike, ndim: dict[str, int]
) -> dict[str, np.ndarray]:
    """The arrays of NPZ ``path``, after the header checks of the module
    docstring.

    Args:
      ndim: the allowed array names and the number of dimensions of each.

    Raises:
      ValueError: one line: not a zip archive, a corrupt member, or a refusal.
    """
    path = Path(path)
    if path.is_file() and not zipfile.is_zipfile(path):
        raise ValueError("not an NPZ file (an NPZ is a zip archive of .npy arrays)")
    arrays = {}
    try:
        with zipfile.ZipFile(path) as zf:
            for member, (key, _) in _npz_headers(zf, ndim).items():
                with zf.open(member) as f:
                    arrays[key] = np.lib.format.read_array(f, allow_pickle=False)
    except _Refused:
        raise
    except (OSError, EOFError, ValueError, RuntimeError, zipfile.BadZipFile) as e:
        reason = getattr(e, "strerror", None) or str(e) or type(e).__name__
        raise ValueError(f"cannot read NPZ ({reason})") from None
    return arrays
