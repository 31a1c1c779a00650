"""The studies' text: tables whose header lines up with the rows, and target
lines that give the measured value and a reason, never a bare verdict."""

from __future__ import annotations

import pytest

from rmdrake.report.tables import aligned_table, target_check


def test_columns_line_up_with_their_header():
    lines = aligned_table(
        ["variant", "P1", "P2", "mean"],
        [["nominal controller", "0.9774", "12.9032", "1.5"], ["oracle", "0", "0", "0"]],
        groups=[("AP", 2)],
    )
    group, header, *rows = lines
    assert group == " " * (len("nominal controller") + 2) + "AP"  # over P1's field
    for name in ("P1", "P2", "mean"):  # right-aligned: the ends coincide
        end = header.index(name) + len(name)
        assert all(row[end - 1] != " " for row in rows)
        assert all(len(row) == len(header) for row in rows)
    assert rows[0].startswith("nominal controller  ")
    assert all(line == line.rstrip() for line in lines)


def test_a_label_wider_than_its_columns_widens_them():
    group, header, row = aligned_table(
        ["v", "a"], [["x", "1"]], groups=[("a long label", 1)]
    )
    assert group.strip() == "a long label" and len(header) == len(row) >= len(group)


def test_bad_rows_and_groups_are_refused():
    with pytest.raises(ValueError, match="expected 2 cells"):
        aligned_table(["a", "b"], [["1"]])
    with pytest.raises(ValueError, match="groups span"):
        aligned_table(["a", "b"], [["1", "2"]], groups=[("g", 2)])


def test_a_met_target_says_met_and_a_missed_one_says_how_and_why():
    assert (
        target_check("n / f =", 133.0, ">=", 10, reason="r") == "n / f = 133 >= 10: met"
    )
    missed = target_check("f / o =", 10.2, "<=", 2, reason="the oracle is exact")
    assert missed == "f / o = 10.2 (target <= 2; the oracle is exact)"
    assert "not met" not in missed
    line = target_check(
        "mean", 0.0412, "<=", 0.03, unit=" mm", digits=".4f", reason="x"
    )
    assert line == "mean 0.0412 mm (target <= 0.0300 mm; x)"
    with pytest.raises(ValueError, match="op"):
        target_check("a", 1.0, "<", 2.0, reason="")
