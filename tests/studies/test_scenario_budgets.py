"""Scenario budgets and checks: the shipped scenarios are budgeted by
generations alone, so the same inputs give the same bytes at any load; a
wall-time budget the user sets may stop a design only with a warning naming it,
on stderr and in the file; and a scenario for another robot is checked whole
before its first file."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import time
import types
from pathlib import Path

import pytest
import yaml

from rmdrake.cli.commands import main
from rmdrake.excitation import design as design_module
from rmdrake.excitation.design import WallBudgetWarning, design_excitation
from rmdrake.excitation.trajectory import load_fourier
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.studies.scenarios import (
    SHIPPED_SCENARIOS,
    ExcitationRunConfig,
    load_scenario,
    scenario_names,
)

SRC = Path(__file__).resolve().parents[2] / "src"


def _excitation_configs(config: object, path: str = "") -> list[tuple[str, object]]:
    """(dotted path, config) of every ExcitationRunConfig inside ``config``."""
    found = []
    if isinstance(config, ExcitationRunConfig):
        found.append((path, config))
    for name, value in vars(config).items():
        if hasattr(value, "__dataclass_fields__"):
            found += _excitation_configs(value, f"{path}.{name}")
    return found


def test_every_shipped_scenario_is_budgeted_by_generations_alone():
    raw = yaml.safe_load(SHIPPED_SCENARIOS.read_text(encoding="utf-8").replace("!", ""))

    def keys(node: object) -> set[str]:
        if isinstance(node, dict):
            return set(map(str, node)).union(*(keys(v) for v in node.values()))
        return set()

    assert "design_time" not in keys(raw)
    designs = 0
    for name in scenario_names():
        scenario = load_scenario(SHIPPED_SCENARIOS, name)
        for path, config in _excitation_configs(scenario, name):
            assert config.design_time is None, path
            designs += 1
    assert designs >= 5  # paper (2), paper_smoke (2), demo_rh, the closed loops


class _SlowClock:
    """A perf_counter that advances 10 s at each reading: every wall-time
    budget is spent at the first look, whatever the machine."""

    def __init__(self) -> None:
        self.now = 0.0

    def perf_counter(self) -> float:
        self.now += 10.0
        return self.now


def test_a_wall_budget_that_stops_the_design_warns_and_the_file_says_so(
    monkeypatch, tmp_path
):
    monkeypatch.setattr(design_module, "time", types.SimpleNamespace(
        perf_counter=_SlowClock().perf_counter))  # fmt: skip
    robot = load_robot("rv3sb")
    kw = dict(harmonics=3, maxiter=6, popsize=3, n_random=4, progress=False)
    with pytest.warns(WallBudgetWarning) as caught:
        result = design_excitation(
            robot, max_time=30.0, budget_keys=("design_time", "design_maxiter"), **kw
        )
    message = str(caught[0].message)
    assert message.startswith(
        "excitation design stopped by its wall-time budget design_time = 30 s "
        "after generation "
    )
    assert "of 6" in message and "budget by design_maxiter" in message
    assert result.generations < 6 and result.budget_warning == message
    assert f"warning: {message}" in result.summary()
    path = result.save(tmp_path / "excitation.yaml")
    assert path.read_text().startswith(f"# warning: {message}\n")
    again = load_fourier(path)  # the comment leaves the file readable
    assert (again.a == result.trajectory.a).all()
    # Without a budget the clock is never read for a decision: all generations.
    plain = design_excitation(robot, **kw)
    assert plain.generations == 6 and plain.budget_warning == ""
    assert "warning" not in plain.summary()


_THROTTLED = """
import os, sys, time
os.nice(19)
from rmdrake.cli.commands import main
from rmdrake.excitation.design import ExcitationCost
cost = ExcitationCost.__call__
def slow(self, X):
    time.sleep(0.05)  # every chunk of candidates: a busy machine
    return cost(self, X)
ExcitationCost.__call__ = slow
argv = sys.argv[1:]
budget = main([*argv, "--out", "budget.yaml", "--max-time", "0.1"])
free = main([*argv, "--out", "free.yaml"])
sys.exit(10 * budget + free)
"""


def test_a_throttled_design_gives_the_same_bytes_or_names_its_budget(tmp_path):
    """A child process at the lowest priority whose cost sleeps: without a
    wall budget its trajectory is the idle run's, byte for byte; with one it is
    either the same bytes (the generations decided) or the run warns naming
    the budget and the file says so."""
    argv = ["excite", "--robot", "rv3sb", "--harmonics", "3", "--maxiter", "4"]
    assert main([*argv, "--out", str(tmp_path / "idle.yaml")]) == 0
    idle = (tmp_path / "idle.yaml").read_bytes()
    child = subprocess.run(
        [sys.executable, "-c", _THROTTLED, *argv],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert child.returncode == 0, child.stderr
    assert (tmp_path / "free.yaml").read_bytes() == idle
    budget = (tmp_path / "budget.yaml").read_bytes()
    if budget != idle:
        line = (
            "rmdrake: warning: excitation design stopped by its wall-time budget "
            "--max-time = 0.1 s after generation "
        )
        assert line in child.stderr
        assert budget.startswith(b"# warning: excitation design stopped by")
    else:
        assert "wall-time budget" not in child.stderr


_TINY = """
tiny:
  robot: arm3.yaml
  show: false
  calibration: null
  identification:
    periods: 1.0
    design_maxiter: 3
    design_popsize: 3
    n_random: 3
    methods: [ols]
    html: false
"""


def _three_joints(robot: RobotModel, path: Path) -> None:
    """Writes the first three joints of ``robot`` as a robot YAML (a small
    arm: its identification study runs in seconds)."""
    data = yaml.safe_load(robot.to_yaml())
    data["name"], data["mdh"] = "arm3", data["mdh"][:3]
    data["limits"] = {k: v[:3] for k, v in data["limits"].items()}
    data["dynamics"] = data["dynamics"][:3]
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def _files(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_the_same_scenario_gives_the_same_bytes_when_a_step_is_slowed(
    monkeypatch, tmp_path
):
    """No wall budget anywhere: a design slowed to many times its idle time
    (and a fresh design, not the memo of the first run) writes the same files,
    byte for byte."""
    scenario = tmp_path / "tiny.yaml"
    scenario.write_text(_TINY)
    _three_joints(load_robot("rv3sb"), tmp_path / "arm3.yaml")
    run = ["run", "--workers", "0", "--scenario-file", str(scenario)]
    assert main([*run, "--scenario", "tiny", "--out", str(tmp_path / "a")]) == 0
    monkeypatch.setattr("rmdrake.studies.identification._DESIGNS", {})
    cost = design_module.ExcitationCost.__call__

    def slow(self, X):
        time.sleep(0.02)
        return cost(self, X)

    monkeypatch.setattr(design_module.ExcitationCost, "__call__", slow)
    assert main([*run, "--scenario", "tiny", "--out", str(tmp_path / "b")]) == 0
    first, second = _files(tmp_path / "a"), _files(tmp_path / "b")
    assert "dynamics/excitation.yaml" in first
    assert first.keys() == second.keys()
    for name in first:
        assert first[name] == second[name], name
    text = (tmp_path / "a" / "dynamics" / "excitation.yaml").read_text()
    assert not text.startswith("#")


# ---- a scenario for another robot, checked whole before its first file --------
def _myarm(path: Path) -> Path:
    """A 6R arm of the user's: the RV-3SB with joint 4's axis parallel to
    joints 2 and 3, so the paper's dr4 is no longer separable."""
    data = yaml.safe_load(load_robot("rv3sb").to_yaml())
    data["name"] = "myarm"
    data["mdh"][3]["alpha"] = 0.0
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


_SMALL_CALIBRATION = (
    "{seeds: 1, per_plate: 8, n_validation: 50, methods: [lm], repeat_methods: [lm]%s}"
)
PANDA = Path(__file__).resolve().parents[3] / "shared/data/panda_gaz2019/panda.yaml"


def _refused(tmp_path: Path, capsys, robot: str, body: str) -> str:
    """Runs scenario ``mine`` (``robot``, then ``body``); asserts exit 2 and
    nothing in --out; returns the one line on stderr."""
    path = tmp_path / "mine.yaml"
    path.write_text(f"mine:\n  robot: {robot}\n{textwrap.indent(body, '  ')}\n")
    out = tmp_path / "out"
    argv = ["run", "--workers", "0", "--scenario-file", str(path)]
    code = main([*argv, "--scenario", "mine", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert "\n" not in err and err.startswith("rmdrake: error: scenario 'mine'")
    assert not out.exists() or not any(out.iterdir())
    return err


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        (  # the paper's parameters on another arm: the key, the value to write
            f"calibration: {_SMALL_CALIBRATION % ''}\nidentification: null",
            r"calibration\.params: paper is rank 16 of 17 on robot 'myarm': drop "
            r"dr4 .*write `calibration: \{params: auto\}`.*`params: dalpha2,",
        ),
        (  # auto with the paper's DE, which cannot cross-validate
            "calibration: {params: auto, methods: [de, lm]}\nidentification: null",
            r"calibration\.methods: de cannot take params auto",
        ),
        (
            "calibration: null\nidentification: null\ncompensation:\n"
            "  tracking: {speeds: []}",
            r"compensation\.tracking\.speeds: expected one or more entries.*seeds: 0",
        ),
        (
            "calibration: null\nidentification: null\ncompensation:\n"
            "  params: auto\n  cube_q: [0.0, 0.6, 1.0, 0.0, 1.0, 0.0]",
            r"compensation\.cube_q, cube_side: the nominal robot cannot reach",
        ),
        (
            "calibration: null\nidentification: null\ncompliance: {}",
            r"compliance: robot 'myarm' has no compliance .*`compliance: null`",
        ),
    ],
)
def test_a_scenario_the_robot_cannot_run_is_refused_before_any_file(
    tmp_path, capsys, body, expected
):
    robot = _myarm(tmp_path / "myarm.yaml")
    assert re.search(expected, _refused(tmp_path, capsys, robot.name, body))


def test_an_elastic_arm_s_controller_is_checked_before_any_file(tmp_path, capsys):
    body = "calibration: null\nidentification: {design_maxiter: 2, periods: 1.0}"
    err = _refused(tmp_path, capsys, "demo_rh_elastic", body)
    assert "identification.station: controller.bandwidth: 40 rad/s is above" in err


@pytest.mark.skipif(not PANDA.is_file(), reason=f"needs {PANDA}")
@pytest.mark.parametrize(
    ("body", "expected"),
    [
        (
            f"calibration: {_SMALL_CALIBRATION % ''}\nidentification: null",
            r"calibration\.params: preset 'paper' .* 7 joints.*"
            r"`calibration: \{params: auto\}`",
        ),
        (
            "calibration: null\nidentification: {}",
            r"identification: robot 'panda' has no 'dynamics' section.*"
            r"`identification: null`",
        ),
    ],
)
def test_the_panda_yaml_is_refused_naming_the_key(tmp_path, capsys, body, expected):
    assert re.search(expected, _refused(tmp_path, capsys, str(PANDA), body))


def test_params_auto_runs_in_a_scenario_as_in_the_cli(tmp_path, capsys):
    """The CLI's default parameter choice runs on the arm where ``paper`` is
    rank-deficient: errors drawn on every parameter, the set chosen from the
    readings."""
    _myarm(tmp_path / "myarm.yaml")
    path = tmp_path / "mine.yaml"
    calibration = _SMALL_CALIBRATION % ", params: auto, html: false"
    path.write_text(
        f"mine:\n  robot: myarm.yaml\n  show: false\n  calibration: {calibration}\n"
        "  identification: null\n"
    )
    out = tmp_path / "out"
    argv = ["run", "--workers", "0", "--scenario-file", str(path)]
    assert main([*argv, "--scenario", "mine", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "(auto)" in printed and (out / "kinematics").is_dir()
