"""Resource limits checked *before* rmdrake allocates: one memory cap and the
message that names the quantity to lower.

Every array whose size a user controls (harmonics, samples, rates, durations,
the arrays of an NPZ file) is estimated first with :func:`check_memory`; an
estimate over :data:`MEMORY_CAP_BYTES` (2 GiB) is refused with one line instead
of a ``MemoryError`` or the kernel's OOM killer.
"""

from __future__ import annotations

import math

__all__ = ["MEMORY_CAP_BYTES", "check_memory", "format_bytes"]

MEMORY_CAP_BYTES = 2 * 2**30


def format_bytes(n: float) -> str:
    """``n`` bytes as B, KiB, MiB, GiB or TiB with three significant digits."""
    for unit in ("B", "KiB", "MiB", "GiB"):
        if abs(n) < 1024:
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} TiB"


def check_memory(values: float, what: str, hint: str = "", itemsize: int = 8) -> None:
    """Refuses an allocation of ``values`` items of ``itemsize`` bytes (default
    float64) over :data:`MEMORY_CAP_BYTES`.

    Args:
      values: the estimated number of items (a float, so products of user
        numbers cannot overflow; NaN and infinity are refused).
      what: what would be allocated, e.g. ``"simulate: 1.5e9 samples x 25 columns"``.
      hint: what to lower, appended after a semicolon.

    Raises:
      ValueError: ``"<what> would need 13.4 GiB, over the 2 GiB memory cap;
        <hint>"``.
    """
    need = float(values) * itemsize
    if math.isfinite(need) and need <= MEMORY_CAP_BYTES:
        return
    size = format_bytes(need) if math.isfinite(need) else "unbounded memory"
    cap = format_bytes(MEMORY_CAP_BYTES)
    tail = f"; {hint}" if hint else ""
    raise ValueError(f"{what} would need {size}, over the {cap} memory cap{tail}")
