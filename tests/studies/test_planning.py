"""The calibration planning study (:mod:`rmdrake.studies.planning`): the same
bytes wherever the arms run, one true arm across the plan variants, errors
that fall with the readings and scale with the noise, resume after an
interrupt, failed arms as rows, and the points' D-optimal twin."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from rmdrake.calibration.plates.plan import PlatePlan
from rmdrake.calibration.points.plan import PointPlan
from rmdrake.calibration.points.pose_selection import select_d_optimal_poses
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.calibration.registry import KINDS
from rmdrake.calibration.sockets.plan import SocketPlan
from rmdrake.execution import Execution, task_seed
from rmdrake.model.loading import load_robot
from rmdrake.studies import planning
from rmdrake.studies.planning import (
    ArmRow,
    ArmTask,
    PlanConfig,
    draw_arm,
    plan_arm,
    plan_line,
    run_plan,
    summarise_plan,
)

SERIAL = Execution(workers=0)
REAL_PLAN_ARM = planning.plan_arm


@pytest.fixture(scope="module")
def nominal():
    return load_robot("rv3sb")


def small(nominal, **changes) -> PlanConfig:
    """4 arms x 60, 120 readings on 5 plates, 50 held-out poses."""
    options = dict(
        robot=nominal,
        plan=PlatePlan(),
        robots=4,
        noise=2e-6,
        length_std=2e-4,
        angle_std=1e-3,
        readings=(60, 120),
        target=5e-5,
        n_validation=50,
    )
    return PlanConfig(**{**options, **changes})


def run(config, folder, **options):
    options.setdefault("execution", SERIAL)
    return run_plan(config, folder, echo=lambda _: None, progress=False, **options)


def test_same_bytes_serial_and_on_two_workers(nominal, tmp_path):
    config = small(nominal, robots=2)
    a = run(config, tmp_path / "serial")
    b = run(config, tmp_path / "two", execution=Execution(workers=2))
    for name in ("robots.csv", "summary.yaml"):
        assert (tmp_path / "serial" / name).read_bytes() == (
            tmp_path / "two" / name
        ).read_bytes()
    assert a.line == b.line
    assert [(r.readings, r.arm) for r in a.rows] == [
        (v, i) for v in (60, 120) for i in range(2)
    ]


def test_one_true_arm_across_the_variants(nominal, tmp_path):
    config = small(nominal, readings=(60, 90, 120))
    rows = run(config, tmp_path).rows
    for arm in range(config.robots):
        mine = [r for r in rows if r.arm == arm]
        assert len(mine) == 3
        assert len({(r.seed, r.true) for r in mine}) == 1
        drawn = draw_arm(config, arm)
        assert mine[0].seed == drawn.seed == task_seed(config.seed, arm)
        assert mine[0].true == drawn.values
    # the arms differ from one another, and their errors are the std's size
    true = np.array([r.true for r in rows if r.readings == 60])
    assert len({tuple(t) for t in true}) == config.robots
    lengths = [i for i, n in enumerate(config.names) if n[:2] in ("dd", "dr")]
    assert 5e-5 < np.std(true[:, lengths]) < 5e-4


def test_error_falls_as_the_readings_grow(nominal, tmp_path):
    config = small(nominal, robots=6, readings=(60, 240))
    summary = run(config, tmp_path).summary
    few, many = summary["variants"]
    assert few["ok"] == many["ok"] == 6
    assert many["median"] < 0.75 * few["median"]
    assert few["median"] < 1e-4  # 0.1 mm after a 1 mrad / 0.2 mm draw


def test_zero_tolerances_the_nominal_is_the_truth(nominal):
    config = small(nominal, length_std=0.0, angle_std=0.0, noise=1e-7)
    arm = draw_arm(config, 2)
    assert np.array_equal(arm.robot.table, nominal.table)
    assert set(arm.deltas.values()) == {0.0}
    quiet = plan_arm(ArmTask(config, 2, 0))
    loud = plan_arm(ArmTask(dataclasses.replace(config, noise=2e-6), 2, 0))
    exact = plan_arm(ArmTask(dataclasses.replace(config, noise=0.0), 2, 0))
    assert quiet.ok and loud.ok and exact.ok
    assert quiet.fitted == len(config.names) == 17
    # the same readings, scaled noise: the error scales with it (linear regime)
    assert loud.mean / quiet.mean == pytest.approx(20.0, rel=0.01)
    assert quiet.mean < 30 * 1e-7
    assert exact.mean < 1e-12  # noise-free: the truth, to round-off


def _count_calls(monkeypatch, *, stop_after=None, fail_arm=None):
    """Wraps plan_arm (run in this process): counts its calls, interrupts
    after ``stop_after`` of them, raises for arm ``fail_arm``."""
    calls = []
    real = REAL_PLAN_ARM

    def wrapped(task):
        if stop_after is not None and len(calls) == stop_after:
            raise KeyboardInterrupt
        calls.append((task.variant, task.arm))
        if task.arm == fail_arm:
            raise RuntimeError("boom: a crash in the fit")
        return real(task)

    monkeypatch.setattr(planning, "plan_arm", wrapped)
    return calls


def test_resume_runs_only_the_missing_arms(nominal, tmp_path, monkeypatch):
    config = small(nominal)
    whole = run(config, tmp_path / "whole")
    expected = (tmp_path / "whole" / "robots.csv").read_bytes()
    folder = tmp_path / "cut"
    calls = _count_calls(monkeypatch, stop_after=3)
    with pytest.raises(KeyboardInterrupt):
        run(config, folder)
    assert len(calls) == 3
    text = (folder / "robots.csv").read_text()
    assert text.count("\n") == 1 + 3  # the header and the rows done
    with open(folder / "robots.csv", "a") as f:
        f.write("120,3,123,0.0004")  # a row cut by the interrupt
    with pytest.raises(ValueError, match="robots.csv: exists"):
        run(config, folder)  # no --resume: refused, nothing lost
    calls = _count_calls(monkeypatch)
    result = run(config, folder, resume=True)
    # the missing arms, and a sample of the rows kept recomputed to check them
    assert len(calls) == 8 - 3 + planning.RESUME_SAMPLE and result.ran == 5
    assert (folder / "robots.csv").read_bytes() == expected
    assert result.summary == whole.summary
    # nothing left: a resume of a finished plan runs nothing, same bytes
    calls = _count_calls(monkeypatch)
    assert run(config, folder, resume=True).ran == 0
    assert len(calls) == planning.RESUME_SAMPLE  # the sample checked, no task
    assert (folder / "robots.csv").read_bytes() == expected


def test_resume_takes_rows_in_any_order(nominal, tmp_path, monkeypatch):
    config = small(nominal, robots=3)
    run(config, tmp_path / "whole")
    expected = (tmp_path / "whole" / "robots.csv").read_bytes()
    lines = expected.decode().splitlines(keepends=True)
    folder = tmp_path / "partial"
    folder.mkdir()
    (folder / "plan.yaml").write_bytes((tmp_path / "whole" / "plan.yaml").read_bytes())
    kept = [lines[5], lines[1], lines[3]]  # as two workers may finish them
    (folder / "robots.csv").write_text(lines[0] + "".join(kept) + lines[2][:20])
    calls = _count_calls(monkeypatch)
    run(config, folder, resume=True)
    assert len(calls) == 3 + planning.RESUME_SAMPLE  # with the sample checked
    assert (folder / "robots.csv").read_bytes() == expected


def test_resume_refuses_another_plan(nominal, tmp_path):
    config = small(nominal, robots=2, readings=(60,))
    run(config, tmp_path)
    with pytest.raises(ValueError, match="differs.*tolerances.angle_std"):
        run(dataclasses.replace(config, angle_std=2e-3), tmp_path, resume=True)
    with pytest.raises(ValueError, match="no plan to resume"):
        run(config, tmp_path / "empty", resume=True)
    # the target and the confidence enter the summary only: a resume may move
    moved = run(dataclasses.replace(config, target=1e-5), tmp_path, resume=True)
    assert moved.ran == 0 and moved.summary["target"] == 1e-5


def test_a_failing_arm_is_a_failed_row(nominal, tmp_path, monkeypatch):
    config = small(nominal, robots=3, readings=(30, 60), target=0.1)
    _count_calls(monkeypatch, fail_arm=1)
    said = []
    result = run_plan(config, tmp_path, execution=SERIAL, echo=said.append)
    assert (
        "note: 30 readings (5 plates x 6) cannot calibrate 17 parameters and 5 "
        "plates (32 unknowns and 5 degrees of freedom to check the fit need 37 "
        "readings): its arms will fail"
    ) in said
    rows = {(r.readings, r.arm): r for r in result.rows}
    crashed = rows[(60, 1)]
    assert crashed.status == "failed" and crashed.mean is None
    assert crashed.reason == "RuntimeError: boom: a crash in the fit"
    assert crashed.true == draw_arm(config, 1).values  # the arm is still named
    # 30 readings cannot fit 17 parameters and 5 plates: the calibrator says so
    assert rows[(30, 0)].status == "failed"
    assert rows[(30, 0)].reason.startswith(
        "calibration: 30 readings cannot identify 17 parameters and 5 plates"
    )
    few, many = result.summary["variants"]
    assert few["failed"] == 3 and few["fraction"] == 0.0 and few["median"] is None
    assert many["failed"] == 1 and many["ok"] == 2
    assert many["meeting"] == 2 and many["fraction"] == pytest.approx(2 / 3)
    assert result.summary["recommendation"] is None
    assert "on 66.6 %" in result.line
    text = (tmp_path / "robots.csv").read_text()
    assert ",failed,calibration: 30 readings cannot identify" in text
    assert text.count("\n") == 1 + 6


def test_summary_and_line(nominal):
    config = small(nominal, robots=4, readings=(60, 120), confidence=0.2)

    def row(readings, arm, mean):
        status = "ok" if mean is not None else "failed"
        return ArmRow(readings, arm, 0, (), 17, mean, mean, mean, status, "x")

    rows = [row(60, a, m) for a, m in enumerate([1e-5, 2e-5, 9e-5, None])]
    rows += [row(120, a, m) for a, m in enumerate([1e-5, 1e-5, 2e-5, 6e-5])]
    summary = summarise_plan(config, rows)
    assert [v["meeting"] for v in summary["variants"]] == [2, 3]
    assert summary["recommendation"]["readings"] == 120
    # the recommendation asks the 95 % lower bound (24.8 % for 3 of 4), not the
    # fraction, to reach the confidence
    assert plan_line(summary) == (
        "plan: 120 readings (5 plates x 24) meet 0.05 mm on 75 % of 4 arms (95 % "
        "lower bound 24.8 % >= 20 %)"
    )
    even = summarise_plan(dataclasses.replace(config, confidence=0.75), rows)
    assert even["recommendation"] is None and "the best, 120" in even["reason"]
    assert "raise --robots to >= 11" in even["reason"]
    assert yaml.safe_load(yaml.safe_dump(summary)) == summary


def test_config_refuses_bad_plans(nominal):
    with pytest.raises(ValueError, match="readings 62: not a multiple of the 5"):
        small(nominal, readings=(60, 62))
    with pytest.raises(ValueError, match="length_std"):
        small(nominal, length_std=-1e-4)
    with pytest.raises(ValueError, match="no elastic joint"):
        small(nominal, stiffness_std=0.1)
    with pytest.raises(ValueError, match="unknown parameter preset"):
        small(nominal, params="nonsense")
    with pytest.raises(ValueError, match="confidence"):
        small(nominal, confidence=1.5)
    with pytest.raises(ValueError, match="readings 30: not a multiple of the 8 s"):
        small(nominal, plan=SocketPlan(), readings=(40, 30))
    with pytest.raises(ValueError, match="seats random configurations only"):
        small(nominal, plan=SocketPlan(), poses_from="d-optimal")
    with pytest.raises(ValueError, match="per_plate: expected an integer >= 1"):
        small(nominal, plan=PlatePlan(per_plate=0))
    with pytest.raises(ValueError, match="plan: expected the plan of a kind"):
        small(nominal, plan="plates")


@pytest.mark.parametrize("name", list(KINDS))
def test_every_kind_plans_its_own_sizes(nominal, name):
    """Each kind's plan keeps its fixed size and divides the swept readings
    into it; the plan record names the kind and that size only."""
    plan = KINDS[name].plan(2)
    config = small(nominal, plan=plan, readings=(4 * plan.readings, plan.readings))
    assert config.kind == name
    assert [v.readings for v in config.variants] == [plan.readings, 4 * plan.readings]
    assert config.variants[0] == plan
    recorded = config.record()["rows"]["plan"]
    assert recorded["kind"] == name
    assert {k: recorded[k] for k in plan.record()} == plan.record()


def test_points_plan(nominal, tmp_path):
    config = small(
        nominal,
        plan=PointPlan(),
        readings=(12, 36),
        noise=2e-5,
        robots=3,
        target=1e-4,
    )
    result = run(config, tmp_path)
    assert [v["plan"] for v in result.summary["variants"]] == [
        "12 poses (x 3 markers)",
        "36 poses (x 3 markers)",
    ]
    assert all(r.ok for r in result.rows)
    few, many = result.summary["variants"]
    assert many["median"] < few["median"] < 1e-4


def test_d_optimal_tracker_poses(nominal):
    rng = np.random.default_rng(1)
    markers = 0.05 * rng.standard_normal((3, 3))
    q = rng.uniform(nominal.limits.lower, nominal.limits.upper, (40, 6))
    chosen = select_d_optimal_poses(nominal, q, markers, 10)
    assert chosen.size == 10 and np.all(np.diff(chosen) > 0)
    first = simulate_points(nominal, poses=10, seed=3)
    again = simulate_points(nominal, poses=10, seed=3, selection="first")
    assert np.array_equal(first.data.q, again.data.q)  # the default is unchanged
    best = simulate_points(nominal, poses=10, seed=3, selection="d-optimal")
    assert best.data.q.shape == first.data.q.shape
    assert np.array_equal(best.markers, first.markers)  # drawn before the poses
    with pytest.raises(ValueError, match="selection"):
        simulate_points(nominal, poses=10, selection="best")
