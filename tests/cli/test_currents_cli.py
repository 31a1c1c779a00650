"""``rmdrake identify-gains``: drive gains from a no-load and a loaded log of
motor currents (oracle: the gains the logs were made with), and its bad
inputs refused with exit 2 and one line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics import standard_parameters, torques
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Payload

GAINS = np.array([55.0, 80.0, 42.0, 12.0, 9.5, 6.0])  # N m/A
PAYLOAD = Payload(2.0, np.array([0.0, 0.0, 0.05]), np.zeros(6))


@pytest.fixture
def logs(rv3sb, rng, tmp_path):
    """A no-load and a loaded currents log of rv3sb: regressor torques / GAINS."""
    paths = []
    for name, payload in (("free", None), ("held", PAYLOAD)):
        N, n = 300, rv3sb.n_joints
        q, qd, qdd = (rng.uniform(-2.0, 2.0, (N, n)) for _ in range(3))
        q = np.clip(q, rv3sb.limits.lower, rv3sb.limits.upper)  # a feasible log
        model = dataclasses.replace(rv3sb, payload=payload)
        i = torques(rv3sb, q, qd, qdd, standard_parameters(model)) / GAINS
        log = JointLog(np.arange(N) * 0.01, q, i * GAINS, qd, qdd, current=i)
        paths.append(str(write_joint_log(tmp_path / f"{name}.csv", log)))
    return paths


def test_identify_gains_writes_the_true_gains(logs, tmp_path, capsys):
    out = tmp_path / "rv3sb_gains.yaml"
    argv = ["identify-gains", "--robot", "rv3sb", "--log", logs[0], "--log", logs[1]]
    argv += ["--payload-mass", "2", "--payload-com", "0,0,0.05", "--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    assert (
        "drive gains [N m/A or N/A]: 55, 80, 42, 12, 9.5, 6" in capsys.readouterr().out
    )
    gains = load_robot(str(out)).drive_gain
    assert np.abs(gains / GAINS - 1).max() < 1e-6


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--payload-com", "0,0"], "--payload-com: expected 3 comma-separated"),
        (["--payload-mass", "0"], "--payload-mass"),
        (["--log", "LOG0"], "--log: expected two logs"),
        (["--log", "LOG0", "--log", "TAU"], "tau.csv: a torque log"),
    ],
)
def test_identify_gains_bad_input_exit_2_one_line(
    logs, tmp_path, capsys, extra, message
):
    tau = JointLog(np.arange(5.0), np.ones((5, 6)), np.ones((5, 6)))
    write_joint_log(tmp_path / "tau.csv", tau)
    names = {"LOG0": logs[0], "TAU": str(tmp_path / "tau.csv")}
    extra = [names.get(v, v) for v in extra]
    argv = ["identify-gains", "--robot", "rv3sb", "--payload-mass", "2"]
    argv += ["--out", str(tmp_path / "o.yaml")]
    if "--log" not in extra:
        argv += ["--log", logs[0], "--log", logs[1]]
    assert main(argv + extra) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err, err
    assert not (tmp_path / "o.yaml").exists()


def test_validate_refuses_robots_with_different_gains_on_a_currents_log(
    logs, rv3sb, tmp_path, capsys
):
    """A currents log is a measured torque only through a robot's gains: two
    robots with different gains would each be judged on another torque."""
    for name, gains in (("a", GAINS), ("b", 1.1 * GAINS), ("c", GAINS)):
        dataclasses.replace(rv3sb, drive_gain=gains).save(tmp_path / f"{name}.yaml")
    argv = ["validate", "--log", logs[0], "--robot", str(tmp_path / "a.yaml")]
    assert main([*argv, "--robot", str(tmp_path / "b.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "carry different drive gains" in err[0]
    assert main([*argv, "--robot", str(tmp_path / "c.yaml")]) == 0


def test_identify_gains_refuses_a_payload_the_data_contradict(logs, tmp_path, capsys):
    """A 20 kg payload declared for the 2 kg one the loaded log carries: gains
    10x too high, the identified dynamics 10x the robot's own: refused (exit
    3, nothing written); --force writes with the warning."""
    out = tmp_path / "wrong.yaml"
    argv = ["identify-gains", "--robot", "rv3sb", "--log", logs[0], "--log", logs[1]]
    argv += ["--payload-mass", "20", "--payload-com", "0,0,0.05", "--out", str(out)]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "gains: the identified dynamics predict 10x the torque of robot" in err
    assert not out.exists()
    assert main([*argv, "--force"]) == 0
    assert "warning: implausible result written (forced): gains:" in (
        capsys.readouterr().out
    )
    assert out.exists()
