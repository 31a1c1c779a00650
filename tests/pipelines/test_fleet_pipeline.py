"""`rmdrake fleet`'s pipeline on a simulated fleet: 21 RV-3SB arms, each its
own draw of 3 % manufacturing spread on every dynamic parameter
(``perturb_robot(dynamics_std=0.03)``), one of them (arm_07) with a worn joint
3 (viscous and Coulomb friction +50 % on top of its draw), run in Drake (the
independent oracle: the station's plant, its friction law and its torque
sensors, not the regressor) along one excitation, their logs written by tasks
of the execution layer on a local cluster of 2 workers.

Sizes: a random 5-harmonic trajectory at 0.25 Hz (one 4 s period) logged at
100 Hz with white torque noise of 0.2 % of each joint's effort limit. Measured
on the 2-core test machine (shared): the 21 simulations 16 to 26 s, the 21
identifications (wls, in this process) 2.4 to 4.6 s. Found: arm_07 flagged
with joint 3 viscous friction +49 % (8.2 sigma) and Coulomb friction +52 %
(6.5 sigma), nothing else; the largest sigma on a healthy arm 3.5 (fc2 of
arm_14).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np
import pytest

from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.fleet import compare_fleet
from rmdrake.dynamics.friction import DEFAULT_V_EPS
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.execution import Execution, TaskRunner
from rmdrake.model.dynamic_parameters import extended_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.pipelines.fleet import (
    FLEET_CSV,
    fleet_summary,
    reference_parameters,
    run_fleet,
)
from rmdrake.pipelines.simulate import simulate_file

ARMS, WORN = 21, 7
RATE, BASE_FREQUENCY, NOISE = 100.0, 0.25, 0.002  # Hz, Hz, share of effort


def _true_arm(index: int):
    """Arm ``index``'s true robot: its own 3 % draw; arm WORN's joint 3
    friction (fv3, fc3) then 50 % higher."""
    true, _ = perturb_robot(load_robot("rv3sb"), dynamics_std=0.03, seed=index)
    if index == WORN:
        links = true.dynamics.copy()
        links[2, 11:13] *= 1.5
        true = true.with_dynamics(links)
    return true


def _simulate_arm(item: tuple[int, str, str]) -> str:
    """A task (runs in a worker): draws arm ``index``, runs it in Drake along
    the trajectory, writes ``logs/arm_<index>.csv``; returns its path."""
    index, folder, trajectory = item
    true = _true_arm(index)
    robot = true.save(Path(folder) / f"true_{index:02d}.yaml")
    noise = list(NOISE * true.limits.effort)
    log = Path(folder) / "logs" / f"arm_{index:02d}.csv"
    path = simulate_file(
        str(robot), trajectory, log, rate=RATE, torque_noise=noise, seed=index,
        echo=lambda _: None,
    )  # fmt: skip
    return str(path)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fleet")
    nominal = load_robot("rv3sb")
    trajectory = random_fourier_trajectory(
        nominal, fill=0.8, seed=4, base_frequency=BASE_FREQUENCY
    ).save(tmp / "trajectory.yaml")
    items = [(i, str(tmp), str(trajectory)) for i in range(ARMS)]
    t0 = time.perf_counter()
    with TaskRunner(Execution(workers=2), tasks=ARMS) as runner:
        assert runner.parallel
        logs = runner.map(_simulate_arm, items, progress=False)
    simulated = time.perf_counter() - t0
    lines: list[str] = []
    t0 = time.perf_counter()
    run = run_fleet(
        nominal, logs, tmp / "out", coulomb_width=DEFAULT_V_EPS,
        execution=Execution(workers=0), echo=lines.append,
    )  # fmt: skip
    identified = time.perf_counter() - t0
    print(f"21 simulations {simulated:.1f} s, 21 identifications {identified:.1f} s")
    return tmp, nominal, run, lines


def test_the_worn_arm_and_joint_are_flagged_and_no_healthy_arm(fleet):
    _, _, run, lines = fleet
    assert not run.failed
    assert list(run.flagged) == ["arm_07"]
    flags = run.flagged["arm_07"]
    assert {f.name for f in flags} == {"fv3", "fc3"}
    for f in flags:
        assert f.z > 5 and 0.4 < f.relative < 0.6  # +50 % on a 3 % spread
        assert f.text().startswith(("joint 3 viscous friction +4",
                                    "joint 3 Coulomb friction +5",
                                    "joint 3 Coulomb friction +4"))  # fmt: skip
    c = run.comparison
    healthy = [i for i, arm in enumerate(c.arms) if arm != "arm_07"]
    largest = float(np.abs(c.z[healthy]).max())
    assert largest < 4.5  # measured 3.5
    assert lines[-1] == fleet_summary(run)
    assert lines[-1].startswith("fleet: 21 arms, 1 flagged: arm_07 (joint 3 ")
    assert any(line.startswith("arm_07: joint 3 viscous friction") for line in lines)


def test_identified_parameters_match_the_drake_truth_within_their_std(fleet):
    """The oracle: each arm's base parameters as Drake ran it (its true YAML
    regrouped) against what the fleet identified, in identified stds. This
    checks the stds the flags are measured in, too."""
    tmp, nominal, run, _ = fleet
    base = base_parameters(nominal, terms=nominal.dynamic_terms)
    for arm in run.arms:
        true = load_robot(tmp / f"true_{arm.arm[-2:]}.yaml")
        truth = base.regroup(extended_parameters(true)[: base.width])
        z = (arm.values - truth) / arm.std
        assert np.abs(z).max() < 6, (arm.arm, base.names[np.argmax(np.abs(z))])
        assert 0.6 < np.sqrt(np.mean(z**2)) < 1.6


def test_files_written(fleet):
    tmp, _, run, _ = fleet
    out = tmp / "out"
    assert sorted(p.name for p in out.glob("*.yaml")) == [
        f"arm_{i:02d}.yaml" for i in range(ARMS)
    ]
    with open(out / FLEET_CSV, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["arm"] for r in rows] == [f"arm_{i:02d}" for i in range(ARMS)]
    assert {r["status"] for r in rows} == {"ok"}
    worn = rows[WORN]
    assert worn["flags"].startswith("joint 3 viscous friction +")
    assert worn["largest_sigma_parameter"] in ("fv3", "fc3")
    assert all(r["flags"] == "" for i, r in enumerate(rows) if i != WORN)
    record = load_robot(out / "arm_07.yaml").calibration["base_parameters"]
    assert float(worn["fv3"]) == record["fv3"]["value"]
    assert float(worn["fv3_std"]) == record["fv3"]["std"]


def test_reference_mode_on_the_fleet(fleet):
    """Against the nominal robot (its dynamics regrouped, no stds) and
    against a healthy arm's identified YAML (its record, with stds): the worn
    arm and joint again, and no healthy arm."""
    tmp, nominal, run, _ = fleet
    c = run.comparison
    names = c.names
    values, std = reference_parameters(nominal, nominal, names)
    assert std is None
    base = base_parameters(nominal, terms=nominal.dynamic_terms)
    np.testing.assert_array_equal(
        values, base.regroup(extended_parameters(nominal)[: base.width])
    )
    healthy = load_robot(tmp / "out" / "arm_00.yaml")
    ref_values, ref_std = reference_parameters(nominal, healthy, names)
    np.testing.assert_array_equal(ref_values, c.values[0])
    np.testing.assert_array_equal(ref_std, c.std[0])
    for ref, ref_s in ((values, None), (ref_values, ref_std)):
        against = compare_fleet(
            c.arms, names, c.values, c.std, reference=ref, reference_std=ref_s
        )
        assert list(against.flagged) == ["arm_07"]
        assert {f.name for f in against.flagged["arm_07"]} <= {"fv3", "fc3"}
    with pytest.raises(ValueError, match="no dynamics"):
        reference_parameters(nominal, nominal.with_dynamics(None), names)
