"""Scenarios: the shipped file loads into typed dataclasses, a user's copy with
other values runs from the command line, and a typo fails with one line that
names the key."""

from __future__ import annotations

import os
import time

import pytest

from rmdrake.cli.commands import main
from rmdrake.model.loading import load_robot
from rmdrake.studies.runner import LISTED_FILES, files_written, written_summary
from rmdrake.studies.scenarios import (
    SHIPPED_SCENARIOS,
    CalibrationStudyConfig,
    Scenario,
    load_scenario,
    scenario_names,
)
from rmdrake.systems.station_config import StationConfig


def test_shipped_scenarios_load():
    names = scenario_names()
    assert {"paper", "paper_smoke", "demo_rh"} <= set(names)
    for name in names:
        scenario = load_scenario(SHIPPED_SCENARIOS, name)
        assert isinstance(scenario, Scenario)
        # Sections may be null (paper_closed_loop runs only the compensation).
        for section in (scenario.identification, scenario.compensation):
            if section is not None:
                assert isinstance(section.station, StationConfig)
    paper = load_scenario(SHIPPED_SCENARIOS, "paper")
    assert paper.robot == "rv3sb" and paper.calibration.seeds == 20
    assert paper.calibration.params == "paper" and paper.calibration.noise == 2e-6
    smoke = load_scenario(SHIPPED_SCENARIOS, "paper_smoke")
    assert (
        smoke.calibration.de_maxiter == 3 and smoke.identification.design_maxiter == 2
    )
    # Fields a scenario does not name keep their defaults.
    assert smoke.calibration.plates == CalibrationStudyConfig().plates


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("calibration: {plattes: 4}", r"calibration\.plattes: unknown key.*'plates'"),
        ("robott: rv3sb", r"robott: unknown key.*'robot'"),
        (
            "identification: {station: {log_perod: 0.01}}",
            r"identification\.station\.log_perod: unknown key.*'log_period'",
        ),
        ("calibration: {seeds: many}", "scenario 'mine'"),
        (  # a section given as a scalar (found by the loader fuzz test)
            "compensation: {tracking: paths}",
            r"compensation\.tracking: expected a mapping of TrackingStudyConfig",
        ),
        ("compensation: {tracking: null}", r"compensation\.tracking: expected a"),
    ],
)
def test_bad_keys_and_values_fail_with_one_line(tmp_path, body, message):
    path = tmp_path / "s.yaml"
    path.write_text(f"mine:\n  {body}\n")
    with pytest.raises(ValueError, match=message) as info:
        load_scenario(path, "mine")
    assert "\n" not in str(info.value)


def test_unknown_scenario_lists_the_known_ones(tmp_path):
    with pytest.raises(ValueError, match="no scenario 'nope' .*paper_smoke"):
        load_scenario(SHIPPED_SCENARIOS, "nope")


def test_users_copy_runs_from_the_command_line(tmp_path, capsys):
    """A copied scenario with another robot file, noise and sizes runs with no
    Python; the robot path is relative to the scenario file."""
    load_robot("rv3sb").save(tmp_path / "my_arm.yaml")
    path = tmp_path / "mine.yaml"
    path.write_text(
        "quick:\n"
        "  robot: my_arm.yaml\n"
        "  show: false\n"
        "  calibration:\n"
        "    seeds: 1\n"
        "    plates: 4\n"
        "    per_plate: 10\n"
        "    noise: 5.0e-6\n"
        "    n_validation: 50\n"
        "    methods: [lm]\n"
        "    repeat_methods: []\n"
        "    html: false\n"
        "  identification: null\n"
    )
    out = tmp_path / "out"
    argv = ["run", "--scenario-file", str(path), "--scenario", "quick"]
    assert main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "4 plates x 10 readings" in printed and "50 held-out poses" in printed
    assert (out / "kinematics" / "kinematic_calibration_fig3.png").is_file()
    assert not (out / "dynamics").exists()
    # The last lines name the files written, relative to --out, which exist.
    done = printed[printed.rindex("== done in") :].splitlines()
    assert done[0].endswith(f"open these in {out}/ (HTML in a browser):")
    assert done[1:] == ["  kinematics/kinematic_calibration_fig3.png"]
    assert all((out / line.strip()).is_file() for line in done[1:])


def test_the_last_line_counts_per_folder_past_a_dozen_files(tmp_path):
    """Past LISTED_FILES files, their count per folder; files an earlier run
    left are not counted as written."""
    for k in range(LISTED_FILES):
        (tmp_path / "a").mkdir(exist_ok=True)
        (tmp_path / "a" / f"f{k}.png").write_bytes(b"")
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "scene.html").write_text("")
    (tmp_path / "top.html").write_text("")
    (tmp_path / "notes.txt").write_text("")
    old = tmp_path / "b" / "old.png"
    old.write_bytes(b"")
    os.utime(old, (0, 0))
    started = time.time() - 5
    assert len(files_written(tmp_path, started)) == LISTED_FILES + 2
    assert written_summary(tmp_path, started).splitlines() == [
        f"{LISTED_FILES + 2} files to open in {tmp_path}/ (HTML in a browser):",
        "  ./: 1 HTML, 0 PNG",
        f"  a/: 0 HTML, {LISTED_FILES} PNG",
        "  b/: 1 HTML, 0 PNG",
    ]
    (tmp_path / "a" / "f0.png").unlink()
    (tmp_path / "top.html").unlink()
    listed = written_summary(tmp_path, started).splitlines()
    assert len(listed) == 1 + LISTED_FILES
    assert (
        listed[1:3] == ["  a/f1.png", "  a/f10.png"] and listed[-1] == "  b/scene.html"
    )


def test_run_with_a_typo_exits_2_with_one_line(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text("mine:\n  calibration: {seedz: 1}\n")
    argv = ["run", "--scenario-file", str(path), "--scenario", "mine"]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "calibration.seedz: unknown key" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("calibration: {plates: 0}", r"calibration\.plates: expected an integer in"),
        ("calibration: {plates: -5}", r"calibration\.plates: .* found -5"),
        ("calibration: {noise: -1}", r"calibration\.noise: expected a number >= 0"),
        ("calibration: {noise: .nan}", r"calibration\.noise: .* found nan"),
        ("calibration: {methods: [lm, ga]}", r"calibration\.methods: expected one"),
        ("calibration: {seeds: 0}", r"calibration\.seeds: expected an integer"),
        ("calibration: {n_validation: 1000000000000}", r"n_validation: expected"),
        ("calibration: {mean_error: -1e-3}", r"calibration\.mean_error: expected"),
        ("identification: {periods: 1e9}", r"identification\.periods: expected"),
        ("compensation: {tracking: {speeds: [0.5, 2.0]}}", r"tracking\.speeds"),
        (
            "compliance: {readings_integration_schemes: [radau3, rk9]}",
            r"readings_integration_schemes: expected one or more of .*rk9",
        ),
        (
            "compliance: {readings_integration_schemes: [radau3]}",
            r"readings_integration_schemes: expected one scheme per calibration "
            r"payload \(2\) or none, found 1",
        ),
    ],
)
def test_run_refuses_a_bad_value_before_any_file(tmp_path, capsys, body, message):
    """Values are checked on load with the rules of VALUE_RULES, so `run`
    refuses them before its first file (it used to write rv3sb.html,
    kinematics/ and true_robot.yaml first)."""
    path = tmp_path / "s.yaml"
    path.write_text(f"mine:\n  {body}\n")
    with pytest.raises(ValueError, match=message) as info:
        load_scenario(path, "mine")
    assert "\n" not in str(info.value)
    out = tmp_path / "out"
    argv = ["run", "--scenario-file", str(path), "--scenario", "mine"]
    assert main([*argv, "--out", str(out)]) == 2
    assert not out.exists()
