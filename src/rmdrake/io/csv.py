"""Numeric CSV files with named columns, the one reader and writer of them.

Every CSV rmdrake reads is UTF-8 (a byte-order mark allowed,
:data:`CSV_ENCODING`); every file it writes goes through
:func:`~rmdrake.io.atomic.atomic_write_text`, so a crash or a bad input never
leaves a half-written or truncated result behind.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from rmdrake.io.atomic import atomic_write_text

__all__ = [
    "CSV_ENCODING",
    "MAX_COLUMNS",
    "csv_rows",
    "read_csv_columns",
    "write_csv_columns",
]

MAX_COLUMNS = 1_000
"""The widest CSV rmdrake reads: a robot of :data:`~rmdrake.model.robot.MAX_JOINTS`
joints needs a few hundred columns at most; a wider header is refused."""
CSV_ENCODING = "utf-8-sig"
"""The encoding of every CSV rmdrake reads: UTF-8, with or without a BOM."""


def csv_rows(text: str, path: str | os.PathLike) -> list[tuple[int, list[str]]]:
    """(line number, cells) of the rows of CSV ``text`` (read from ``path``)
    that are not blank.

    Raises:
      ValueError: one line naming the file and line: a row the csv module
        cannot read (a field over its 131072-character limit, a stray quote).
    """
    reader = csv.reader(io.StringIO(text))
    try:
        return [(reader.line_num, r) for r in reader if any(c.strip() for c in r)]
    except csv.Error as e:
        raise ValueError(f"{path}: line {reader.line_num}: {e}") from None


# ---- numeric CSV with named columns (tool targets, joint programs) -----------------
def read_csv_columns(
    path: str | os.PathLike,
    what: str,
    groups_of: Callable[[list[str]], dict[str, list[str]]],
) -> dict[str, np.ndarray | None]:
    """Reads a numeric CSV whose header names each column once, in any order:
    {group: (M, k) values in the group's column order, or None if absent};
    ``groups_of(header)`` gives {group: column names}, the first group required,
    each other one all or nothing; ``what`` names the content in messages.

    Raises:
      ValueError: one line naming the file, line and column: a missing, unknown
        or duplicate column, a wrong column count, a value that is not a finite
        number, a column ``t`` that is not strictly increasing.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake.io import read_csv_columns, write_csv_columns
    >>> def groups(header):
    ...     return {"t": ["t"], "q": ["q1", "q2"]}
    ...
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp, "log.csv")
    ...     _ = write_csv_columns(path, {"t": np.arange(3.0), "q1": None, "q2": None})
    ...     columns = read_csv_columns(path, "joint log", groups)
    ...
    >>> columns["t"].shape, columns["q"]  # the optional group q is absent
    ((3, 1), None)
    """
    path = Path(path)
    try:
        text = path.read_text(encoding=CSV_ENCODING)
    except OSError as e:
        raise ValueError(f"cannot read {what} '{path}': {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    rows = csv_rows(text, path)
    header = [c.strip() for c in rows[0][1]] if rows else []
    if len(header) > MAX_COLUMNS:
        raise ValueError(
            f"{path}: line 1: {len(header)} columns, over the {MAX_COLUMNS} a "
            f"{what} file may have"
        )
    groups = groups_of(header)
    out: dict[str, list[int] | None] = {}
    for key, cols in groups.items():
        have = [c for c in cols if c in header]
        if (have or not out) and have != cols:
            missing = ",".join(c for c in cols if c not in header)
            raise ValueError(f"{path}: line 1: missing column(s) {missing}")
        out[key] = [header.index(c) for c in cols] if have else None
    known = [c for cols in groups.values() for c in cols]
    for c in header:
        if c not in known or header.count(c) > 1:
            why = "duplicate" if c in known else "unknown"
            raise ValueError(f"{path}: line 1: {why} column {c!r}")
    if len(rows) < 2:
        raise ValueError(f"{path}: no data rows below the header")
    values = np.full((len(rows) - 1, len(header)), np.nan)
    for i, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ValueError(
                f"{path}: line {line}: {len(row)} columns, not {len(header)}"
            )
        for c, cell in enumerate(row):
            try:
                values[i, c] = float(cell)
            except ValueError:
                pass
            if not np.isfinite(values[i, c]):
                raise ValueError(
                    f"{path}: line {line}, column {header[c]}: {cell.strip()!r} is "
                    f"not a finite number"
                )
    if "t" in header and np.any(np.diff(t := values[:, header.index("t")]) <= 0):
        line = rows[int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2][0]
        raise ValueError(f"{path}: line {line}, column t: time not after the last")
    return {k: None if c is None else values[:, c] for k, c in out.items()}


def write_csv_columns(
    path: str | os.PathLike, columns: Mapping[str, np.ndarray | None]
) -> Path:
    """Writes {name: (M,) values, or None to leave the column out} atomically as
    CSV with a header, in full precision (repr: reads back bit for bit).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake.io import write_csv_columns
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_csv_columns(Path(tmp, "log.csv"), {"t": np.array([0.0, 0.5])})
    ...     print(path.read_text(), end="")
    ...
    t
    0.0
    0.5
    """
    names = [k for k, v in columns.items() if v is not None]
    rows = np.column_stack([columns[k] for k in names]).tolist()
    text = "\n".join([",".join(names)] + [",".join(map(repr, r)) for r in rows])
    return atomic_write_text(path, text + "\n")
