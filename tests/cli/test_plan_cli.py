"""`rmdrake plan`: a small plan end to end (its files and its one-line
recommendation), and every bad input refused with exit code 2 and one line
before any arm runs."""

from __future__ import annotations

import pytest
import yaml

from rmdrake.cli.commands import main
from rmdrake.studies import planning

BASE = [
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
    "--params",
    "paper",
    "--readings",
    "60,120",
    "--target",
    "5e-5",
    "--confidence",
    "0.3",
    "--validation",
    "50",
    "--workers",
    "0",
    "--no-progress",
]


def with_option(name: str, value: str | None) -> list[str]:
    """BASE with ``name`` set to ``value`` (None: removed)."""
    args = list(BASE)
    if name in args:
        i = args.index(name)
        del args[i : i + 2]
    return args if value is None else [*args, f"{name}={value}"]


def refused(capsys, args: list[str]) -> str:
    """Runs ``args``, expects exit code 2; returns the one stderr line."""
    assert main(args) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_plan_writes_its_files_and_the_recommendation(tmp_path, capsys):
    out = tmp_path / "plan"
    assert main([*BASE, "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    line = next(x for x in printed if x.startswith("plan: 60 readings"))
    assert line == (
        "plan: 60 readings (5 plates x 12) meet 0.05 mm on 100 % of 3 arms (95 % "
        "lower bound 36.8 % >= 30 %)"
    )
    assert {p.name for p in out.iterdir()} == {
        "plan.yaml",
        "robots.csv",
        "summary.yaml",
        "plan.png",
    }
    summary = yaml.safe_load((out / "summary.yaml").read_text())
    assert summary["recommendation"]["readings"] == 60
    assert summary["target"] == 5e-5
    rows = (out / "robots.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 3
    assert rows[0].startswith("readings,arm,seed,dalpha2,")
    assert rows[0].endswith(
        ",fitted,held_out_mean,held_out_p95,held_out_max,status,reason"
    )
    # run again: refused, the rows kept; resumed: nothing to run, same bytes
    before = (out / "robots.csv").read_bytes()
    line = refused(capsys, [*BASE, "--out", str(out)])
    assert "robots.csv: exists" in line and "--resume" in line
    assert main([*BASE, "--out", str(out), "--resume"]) == 0
    assert "6 tasks, 6 done, 0 to run" in capsys.readouterr().out
    assert (out / "robots.csv").read_bytes() == before
    # a resume with another plan is refused, naming what differs
    other = with_option("--angle-std", "2e-3")
    line = refused(capsys, [*other, "--out", str(out), "--resume"])
    assert line.startswith("rmdrake: error: ") and "angle_std" in line


def test_points_plan_and_no_plan_meets(tmp_path, capsys):
    args = [
        "plan",
        "--robot",
        "rv3sb",
        "--robots",
        "2",
        "--poses",
        "12",
        "--markers",
        "2",
        "--noise",
        "2e-5",
        "--length-std",
        "2e-4",
        "--angle-std",
        "1e-3",
        "--target",
        "1e-7",
        "--validation",
        "20",
        "--workers",
        "0",
        "--no-progress",
        "--out",
        str(tmp_path),
    ]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "plan: no plan meets 0.0001 mm on >= 95 % of 2 arms; the best, 12 " in out


@pytest.mark.parametrize(
    ("name", "value", "says"),
    [
        ("--length-std", "-1e-4", "argument --length-std: expected a number >= 0"),
        ("--angle-std", "nan", "argument --angle-std: expected a finite number"),
        ("--noise", "-2e-6", "argument --noise: expected a number >= 0"),
        ("--noise", "0.01", "noise: 0.01 m is over 0.1 of the range finder's span"),
        ("--robots", "1e12", "argument --robots: expected an integer"),
        ("--robots", "100000000", "would need"),
        ("--validation", "10000000000", "held-out poses would need"),
        ("--readings", "60,62", "readings 62: not a multiple of the 5 plates"),
        ("--readings", "60,60", "argument --readings: a count given twice"),
        ("--readings", "0", "argument --readings: expected an integer >= 1"),
        ("--robots", "1.5", "argument --robots: expected an integer"),
        ("--target", "0", "argument --target: expected a number > 0"),
        ("--confidence", "1.2", "argument --confidence: expected 0 < value < 1"),
        ("--params", "nonsense", "unknown parameter preset 'nonsense'"),
        ("--stiffness-std", "0.1", "no elastic joint"),
        ("--markers", "3", "--markers: a tracker plan's option"),
        ("--poses-from", "best", "argument --poses-from: invalid choice"),
        ("--scheduler", "a b", "argument --scheduler: expected a scheduler address"),
    ],
)
def test_bad_input_is_refused(tmp_path, capsys, name, value, says):
    out = tmp_path / "plan"
    line = refused(capsys, [*with_option(name, value), "--out", str(out)])
    assert line.startswith("rmdrake: error: ") and says in line
    assert not (out / "robots.csv").exists()


def test_plates_and_poses_exclude_each_other(tmp_path, capsys):
    line = refused(capsys, [*BASE, "--poses", "10", "--out", str(tmp_path)])
    assert "not allowed with argument" in line


def test_resume_needs_a_plan(tmp_path, capsys):
    line = refused(capsys, [*BASE, "--out", str(tmp_path / "none"), "--resume"])
    assert "no plan to resume" in line


def test_help_states_units_and_the_default_execution(capsys):
    assert main(["plan", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for phrase in (
        "--noise SIGMA instrument noise std, m",
        "--length-std M m, std of the true length errors",
        "--angle-std RAD rad, std of the true angle errors",
        "--target M m: an arm meets it",
        "default: a local Dask cluster of one worker process per core, started "
        "when the first task",
    ):
        assert phrase in text


def test_an_interrupt_keeps_the_rows_and_says_resume(tmp_path, capsys, monkeypatch):
    real = planning.plan_arm
    calls = []

    def interrupted(task):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(task)
        return real(task)

    monkeypatch.setattr(planning, "plan_arm", interrupted)
    with pytest.raises(SystemExit) as stop:
        main([*BASE, "--out", str(tmp_path)])
    assert stop.value.code == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"rmdrake: interrupted; the arms done are kept in {tmp_path}/robots.csv: "
        "rerun with --resume to finish the plan"
    ]
    assert len((tmp_path / "robots.csv").read_text().splitlines()) == 1 + 2
    monkeypatch.setattr(planning, "plan_arm", real)
    assert main([*BASE, "--out", str(tmp_path), "--resume"]) == 0
    assert "6 tasks, 2 done, 4 to run" in capsys.readouterr().out
