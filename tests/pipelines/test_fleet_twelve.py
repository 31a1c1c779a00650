"""Issue 41's fleet of twelve: 12 RV-3SB arms, each its own 3 % draw of every
dynamic parameter, arm_07 with joint 3's viscous and Coulomb friction +50 %,
run in Drake (the independent oracle) along one 20 s excitation (a random
5-harmonic trajectory at 0.05 Hz) logged at 100 Hz with torque noise of 0.5 %
of each joint's effort limit, simulated by 2 workers. The fixed threshold of
5 sigma (tuned on 21 arms) missed this arm at 4.8 sigma; the family-wise one
(4.31 sigma for 12 x 52 tests at 1 %) must flag it, on joint 3 only, and no
healthy arm. With the build spread given (3 %), the same.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from rmdrake.dynamics.fleet import family_threshold
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.execution import Execution, TaskRunner
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.pipelines.fleet import run_fleet
from rmdrake.pipelines.simulate import simulate_file

ARMS, WORN = 12, 7
RATE, BASE_FREQUENCY, NOISE = 100.0, 0.05, 0.005  # Hz, Hz, share of effort


def _simulate_arm(item: tuple[int, str, str]) -> str:
    """A task (runs in a worker): arm ``index``'s own 3 % draw (arm WORN's
    fv3 and fc3 then x 1.5) run in Drake; writes ``logs/arm_<index>.csv``."""
    index, folder, trajectory = item
    true, _ = perturb_robot(load_robot("rv3sb"), dynamics_std=0.03, seed=index)
    if index == WORN:
        links = true.dynamics.copy()
        links[2, 11:13] *= 1.5
        true = true.with_dynamics(links)
    robot = true.save(Path(folder) / f"true_{index:02d}.yaml")
    noise = list(NOISE * true.limits.effort)
    log = Path(folder) / "logs" / f"arm_{index:02d}.csv"
    path = simulate_file(
        str(robot), trajectory, log, rate=RATE, torque_noise=noise, seed=index,
        echo=lambda _: None,
    )  # fmt: skip
    return str(path)


@pytest.fixture(scope="module")
def twelve(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("twelve")
    nominal = load_robot("rv3sb")
    trajectory = random_fourier_trajectory(
        nominal, fill=0.8, seed=4, base_frequency=BASE_FREQUENCY
    ).save(tmp / "trajectory.yaml")
    items = [(i, str(tmp), str(trajectory)) for i in range(ARMS)]
    t0 = time.perf_counter()
    with TaskRunner(Execution(workers=2), tasks=ARMS) as runner:
        logs = runner.map(_simulate_arm, items, progress=False)
    print(f"12 simulations {time.perf_counter() - t0:.1f} s")
    return nominal, logs, tmp


def _healthy_largest(run) -> float:
    c = run.comparison
    healthy = [i for i, arm in enumerate(c.arms) if arm != "arm_07"]
    return float(np.abs(c.z[healthy]).max())


def test_the_worn_arm_of_twelve_is_flagged_on_joint_3_and_no_other(twelve):
    nominal, logs, tmp = twelve
    lines: list[str] = []
    run = run_fleet(
        nominal, logs, tmp / "out", coulomb_width=DEFAULT_V_EPS,
        execution=Execution(workers=0), echo=lines.append,
    )  # fmt: skip
    c = run.comparison
    assert c.threshold == pytest.approx(family_threshold(12 * 52))  # 4.31
    assert list(run.flagged) == ["arm_07"], lines
    flags = run.flagged["arm_07"]
    assert flags and {f.name for f in flags} <= {"fv3", "fc3"}
    for f in flags:
        assert f.z > c.threshold and 0.35 < f.relative < 0.65  # +50 %
    worn = [float(c.z[WORN, c.names.index(n)]) for n in ("fv3", "fc3")]
    print("worn fv3, fc3 sigma", worn, "healthy largest", _healthy_largest(run))
    assert _healthy_largest(run) < c.threshold - 0.5
    assert any("false alarms 1 % over 12 x 52 tests" in line for line in lines)


def test_with_the_build_spread_given_the_same(twelve):
    nominal, logs, tmp = twelve
    run = run_fleet(
        nominal, logs, tmp / "out_build", coulomb_width=DEFAULT_V_EPS,
        build_spread=0.03, execution=Execution(workers=0), echo=lambda _: None,
    )  # fmt: skip
    c = run.comparison
    worn = [float(c.z[WORN, c.names.index(n)]) for n in ("fv3", "fc3")]
    print("build 3 %: worn fv3, fc3 sigma", worn, "healthy", _healthy_largest(run))
    assert list(run.flagged) == ["arm_07"]
    assert {f.name for f in run.flagged["arm_07"]} == {"fv3", "fc3"}
    assert _healthy_largest(run) < run.comparison.threshold - 0.5
    assert run.comparison.build_spread is not None
