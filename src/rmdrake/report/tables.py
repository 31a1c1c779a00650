"""The studies' plain text: tables whose header lines up with their rows (each
column as wide as its widest cell, header included), and target lines that say
how far a missed target is and why."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["aligned_table", "target_check"]


def aligned_table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    groups: Sequence[tuple[str, int]] = (),
    gap: int = 2,
) -> list[str]:
    """The lines of a text table: the first column left-aligned, the others
    right-aligned, ``gap`` spaces between columns, no trailing spaces.

    Args:
      header: one name per column.
      rows: the cells, already formatted, as many per row as ``header``.
      groups: (label, number of columns) spans over the columns after the
        first, in order, printed as a line above ``header``, each label
        left-aligned over its span (a span too narrow for its label is
        widened); columns not covered get no label.

    Raises:
      ValueError: a row of another length, or spans covering more columns
        than there are.
    """
    n = len(header)
    for row in rows:
        if len(row) != n:
            raise ValueError(f"expected {n} cells per row, found {len(row)}: {row}")
    if sum(span for _, span in groups) > n - 1:
        raise ValueError(f"groups span more than the {n - 1} columns after the first")
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows, strict=True)]
    starts, first = [], 1
    for label, span in groups:
        last = first + span - 1
        room = sum(widths[first : last + 1]) + gap * (span - 1)
        widths[last] += max(0, len(label) - room)
        starts.append((first, label))
        first = last + 1

    def line(cells: Sequence[str]) -> str:
        parts = [f"{cells[0]:<{widths[0]}}"]
        parts += [f"{c:>{w}}" for c, w in zip(cells[1:], widths[1:], strict=True)]
        return (" " * gap).join(parts).rstrip()

    lines = []
    if groups:
        offsets = [0]
        for w in widths:
            offsets.append(offsets[-1] + w + gap)
        text = ""
        for col, label in starts:
            text = f"{text:<{offsets[col]}}{label}"
        lines.append(text.rstrip())
    lines.append(line([str(h) for h in header]))
    lines += [line([str(c) for c in row]) for row in rows]
    return lines


def target_check(
    name: str,
    value: float,
    op: str,
    goal: float,
    *,
    reason: str,
    unit: str = "",
    digits: str = ".3g",
) -> str:
    """One target of a study: ``name value op goal: met`` when ``value op
    goal`` holds, else ``name value (target op goal; reason)``: the measured
    value, the target and what the figure rests on, never a bare verdict.

    Args:
      name: what is measured, e.g. ``"full / oracle ="``.
      op: ``"<="`` or ``">="``.
      reason: said when the target is missed (the run's own figures that
        explain it).
      unit: appended to the value and the goal, e.g. ``" mm"``.
      digits: the value's and the goal's format.

    Raises:
      ValueError: another ``op``.
    """
    if op not in ("<=", ">="):
        raise ValueError(f"op: expected '<=' or '>=', found {op!r}")
    met = value <= goal if op == "<=" else value >= goal
    measured, target = f"{value:{digits}}{unit}", f"{goal:{digits}}{unit}"
    if met:
        return f"{name} {measured} {op} {target}: met"
    return f"{name} {measured} (target {op} {target}; {reason})"
