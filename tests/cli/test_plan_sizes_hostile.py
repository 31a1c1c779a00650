"""Hostile inputs to ``plan`` and to the size options of the point and plate
commands: a tampered ``robots.csv`` on ``--resume`` (errors of -1, NaN,
forged errors, changed true parameters, a FIFO or ``/dev/zero``), a
recommendation from too few arms, a target in the wrong unit, and counts
that would hang or exhaust memory. Each is refused with exit code 2 and one
line naming the row, option or bound; nothing is written and the inputs are
left as they were."""

from __future__ import annotations

import csv
import io
import os
import shutil
from pathlib import Path

import pytest

from rmdrake.cli.commands import main

PLAN = [
    "plan",
    "--robot",
    "rv3sb",
    "--robots",
    "3",
    "--plates",
    "5",
    "--per-plate",
    "12",
    "--noise",
    "2e-6",
    "--length-std",
    "2e-4",
    "--angle-std",
    "1e-3",
    "--target",
    "5e-5",
    "--confidence",
    "0.3",
    "--validation",
    "20",
    "--workers",
    "0",
    "--no-progress",
]


def refused(capsys, argv: list[str], code: int = 2) -> str:
    """Runs ``argv``; expects ``code`` and one stderr line, returned."""
    assert main(argv) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every regular file of ``folder`` by name, its bytes."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


@pytest.fixture(scope="module")
def done_plan(tmp_path_factory) -> Path:
    """A finished tiny plan (3 arms, one plan of 60 readings)."""
    out = tmp_path_factory.mktemp("plan") / "plan"
    assert main([*PLAN, "--out", str(out)]) == 0
    return out


@pytest.fixture
def plan_copy(done_plan, tmp_path) -> Path:
    out = tmp_path / "plan"
    shutil.copytree(done_plan, out)
    return out


def edit_rows(out: Path, edit) -> None:
    """Rewrites robots.csv with ``edit(header, row)`` applied to each row."""
    path = out / "robots.csv"
    rows = list(csv.reader(io.StringIO(path.read_text())))
    header, body = rows[0], rows[1:]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    for row in body:
        cells = dict(zip(header, row, strict=True))
        edit(cells)
        writer.writerow([cells[h] for h in header])
    path.write_text(buf.getvalue())


def resume_refused(capsys, out: Path) -> str:
    before = snapshot(out)
    line = refused(capsys, [*PLAN, "--out", str(out), "--resume"])
    assert line.startswith("rmdrake: error: ")
    assert snapshot(out) == before  # nothing written, the input intact
    return line


# ---- a tampered robots.csv --------------------------------------------------------
def test_a_resume_of_the_untouched_plan_passes(plan_copy, capsys):
    before = (plan_copy / "robots.csv").read_bytes()
    assert main([*PLAN, "--out", str(plan_copy), "--resume"]) == 0
    assert (plan_copy / "robots.csv").read_bytes() == before
    capsys.readouterr()


@pytest.mark.parametrize("value", ["-1", "nan", "inf"])
def test_errors_that_no_calibration_gives_are_refused(plan_copy, capsys, value):
    def edit(cells):
        if cells["arm"] == "1":
            cells["held_out_mean"] = value

    edit_rows(plan_copy, edit)
    line = resume_refused(capsys, plan_copy)
    assert "robots.csv: line 3: held-out errors" in line
    assert "not this plan's file" in line


def test_forged_errors_are_caught_by_the_recomputed_sample(plan_copy, capsys):
    def edit(cells):  # plausible, finite, small: only recomputing tells
        for key in ("held_out_mean", "held_out_p95", "held_out_max"):
            cells[key] = repr(float(cells[key]) / 10)

    edit_rows(plan_copy, edit)
    line = resume_refused(capsys, plan_copy)
    assert "recomputed from arm" in line and "the file says" in line


def test_a_failed_row_with_errors_is_refused(plan_copy, capsys):
    def edit(cells):
        cells["status"], cells["reason"] = "failed", "made up"
        for key in ("held_out_mean", "held_out_p95", "held_out_max"):
            cells[key] = "1e-9"

    edit_rows(plan_copy, edit)
    line = resume_refused(capsys, plan_copy)
    assert "a failed row with held-out errors" in line


def test_changed_true_parameters_are_refused(plan_copy, capsys):
    def edit(cells):
        if cells["arm"] == "2":
            cells["dd3"] = "0.0"

    edit_rows(plan_copy, edit)
    line = resume_refused(capsys, plan_copy)
    assert "line 4: true parameters differ from those drawn from arm 2's seed" in line


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_a_robots_csv_that_is_no_file_is_refused(plan_copy, capsys, kind):
    path = plan_copy / "robots.csv"
    path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "device":
        path.symlink_to("/dev/zero")
    else:
        path.mkdir()
    before = snapshot(plan_copy)
    line = refused(capsys, [*PLAN, "--out", str(plan_copy), "--resume"])
    reason = {
        "fifo": "is a FIFO, not a regular file",
        "device": "is a device, not a regular file",
        "folder": "Is a directory",
    }[kind]
    assert f"robots.csv: {reason}; --resume reads" in line
    assert snapshot(plan_copy) == before


def test_a_plan_yaml_fifo_is_refused(plan_copy, capsys):
    (plan_copy / "plan.yaml").unlink()
    os.mkfifo(plan_copy / "plan.yaml")
    line = refused(capsys, [*PLAN, "--out", str(plan_copy), "--resume"])
    assert "plan.yaml: is a FIFO, not a regular file; --resume reads" in line


# ---- the recommendation and the target -------------------------------------------
def test_one_arm_recommends_nothing(tmp_path, capsys):
    argv = [*PLAN, "--robots", "1", "--confidence", "0.95", "--out", str(tmp_path)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    line = out.splitlines()[-2]  # before "wrote ..."
    assert "no plan meets 0.05 mm on >= 95 % of 1 arm;" in line
    assert "95 % lower bound 5 %" in line and "raise --robots to >= 59" in line


@pytest.mark.parametrize("value", ["1", "1.0"])
def test_confidence_one_is_refused(tmp_path, capsys, value):
    line = refused(capsys, [*PLAN, "--confidence", value, "--out", str(tmp_path / "p")])
    assert "--confidence: expected 0 < value < 1" in line
    assert not (tmp_path / "p").exists()


def test_a_target_over_the_reach_is_refused(tmp_path, capsys):
    out = tmp_path / "p"
    line = refused(capsys, [*PLAN, "--target", "10", "--out", str(out)])
    assert line.startswith("rmdrake: error: target: 10 m is over 0.1 of the reach")
    assert "mm? give m" in line
    assert not out.exists()


# ---- counts that would hang or exhaust memory --------------------------------------
@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (
            ["simulate-points", "--poses", "10000000"],
            "poses x markers: 10000000 x 3 = 3e+07 points is over the cap of 100000",
        ),
        (
            ["simulate-points", "--markers", "1000000"],
            "markers: 1000000 is over the cap of 100 markers",
        ),
        (
            ["simulate-poses", "--poses", "10000000"],
            "poses: 10000000 is over the cap of 100000 poses",
        ),
        (
            ["simulate-plates", "--plates", "1000", "--per-plate", "1000"],
            "plates x per_plate: 1000 x 1000 = 1e+06 readings is over the cap of 20000",
        ),
    ],
    ids=["poses", "markers", "frames", "plates"],
)
def test_simulate_counts_over_their_cap(tmp_path, capsys, argv, says):
    out = tmp_path / "m.csv"
    line = refused(capsys, [*argv, "--robot", "rv3sb", "--out", str(out)])
    assert line.startswith("rmdrake: error: ") and says in line
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--poses", "20", "--markers", "1000"], "markers: 1000 is over the cap"),
        (["--frames", "1000000"], "frames: 1000000 is over the cap of 100000"),
        (["--plates", "5", "--readings", "60,100000"], "over the cap of 20000"),
    ],
    ids=["markers", "frames", "readings"],
)
def test_plan_counts_over_their_cap(tmp_path, capsys, extra, says):
    argv = ["plan", "--robot", "rv3sb", "--robots", "2", "--noise", "1e-5"]
    argv += ["--target", "1e-4", "--workers", "0", *extra]
    line = refused(capsys, [*argv, "--out", str(tmp_path / "p")])
    assert says in line
    assert not (tmp_path / "p").exists()


@pytest.fixture
def points(tmp_path) -> Path:
    path = tmp_path / "points.csv"
    argv = ["simulate-points", "--robot", "rv3sb", "--poses", "12", "--seed", "1"]
    assert main([*argv, "--out", str(path)]) == 0
    return path


@pytest.mark.parametrize("folds", ["50", "1", "21"])
def test_folds_over_the_cap_are_refused_up_front(points, tmp_path, capsys, folds):
    before = points.read_bytes()
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(points)]
    line = refused(capsys, [*argv, "--out", str(out), "--folds", folds])
    assert "argument --folds: expected 2..20 folds" in line and folds in line
    assert not out.exists() and points.read_bytes() == before


def test_folds_over_the_pose_count_are_refused(points, tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(points)]
    argv += ["--params", "offsets", "--out", str(out), "--folds", "13"]
    line = refused(capsys, argv)
    assert "folds: expected 2..12 (the pose count), found 13" in line
    assert not out.exists()


def test_a_point_fit_over_the_memory_cap_is_refused(points, tmp_path, capsys):
    import rmdrake.limits

    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(points)]
    with pytest.MonkeyPatch.context() as m:  # a tiny cap stands for a huge file
        m.setattr(rmdrake.limits, "MEMORY_CAP_BYTES", 10_000)
        line = refused(capsys, [*argv, "--params", "offsets", "--out", str(out)])
    assert "36 points x 50 unknowns (the LM's Jacobian) would need" in line
    assert not out.exists()


def test_calibrate_refuses_more_plate_readings_than_the_cap(tmp_path, capsys):
    """200 000 readings ran for minutes without a word; over the cap (the one
    ``simulate-plates`` keeps to) they are refused before the fit."""
    import numpy as np

    from rmdrake.calibration.plates.checks import MAX_PLATE_READINGS
    from rmdrake.calibration.plates.data import (
        PlaneMeasurements,
        write_plane_measurements,
    )

    n = MAX_PLATE_READINGS + 1
    q = np.tile([0.0, 0.0, 0.5, 0.0, 0.8, 0.0], (n, 1))
    path = tmp_path / "p.csv"
    write_plane_measurements(
        path, PlaneMeasurements(np.arange(n) % 5, q, np.full(n, 0.05))
    )
    line = refused(
        capsys,
        ["calibrate", "--robot", "rv3sb", "--measurements", str(path), "--out",
         str(tmp_path / "c.yaml")],
    )  # fmt: skip
    assert f"{n} readings, over the cap of {MAX_PLATE_READINGS}" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]
