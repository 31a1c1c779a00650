"""Files in and out: atomic writes, the bounded YAML loader, safe NPZ reading and
numeric CSV with named columns. Every file rmdrake writes goes through
:mod:`rmdrake.io.atomic`; the measurement and log formats live with their
stage (:mod:`rmdrake.calibration.plates.data`, :mod:`rmdrake.calibration.points.data`,
:mod:`rmdrake.dynamics.joint_log`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.io.atomic": (
            "atomic_write_bytes",
            "atomic_write_text",
            "check_writable",
        ),
        "rmdrake.io.csv": (
            "CSV_ENCODING",
            "read_csv_columns",
            "write_csv_columns",
        ),
    },
)
