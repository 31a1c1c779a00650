"""Files in and out: atomic writes, the bounded YAML loader, safe NPZ reading and
numeric CSV with named columns. Every file rmdrake writes goes through
:mod:`rmdrake.io.atomic`; the measurement and log formats live with their
stage (:mod:`rmdrake.calibration.plates.data`, :mod:`rmdrake.calibration.points.data`,
:mod:`rmdrake.dynamics.joint_log`).
"""

from __future__ import annotations

from rmdrake.io.atomic import (  # noqa: F401
    atomic_write_bytes,
    atomic_write_text,
    check_writable,
)
from rmdrake.io.csv import (  # noqa: F401
    CSV_ENCODING,
    read_csv_columns,
    write_csv_columns,
)

__all__ = [
    "CSV_ENCODING",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_writable",
    "read_csv_columns",
    "write_csv_columns",
]
