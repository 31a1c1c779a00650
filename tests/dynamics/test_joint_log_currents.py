"""Joint logs of motor currents (``i1..in``, NPZ ``i``/``currents``): read to
torques with the drive gains, identified exactly as the torque log they came
from, and the bad inputs refused with one line."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics import identify, standard_parameters, torques
from rmdrake.dynamics.data import stack_samples
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.dynamics.log_samples import prepare_logs

GAINS = np.array([55.0, 80.0, 42.0, 12.0, 9.5, 6.0])  # N m/A, rv3sb-like


@pytest.fixture
def torque_log(rv3sb, rng) -> JointLog:
    """Regressor torques of the shipped rv3sb on random states (positions
    inside its limits), uniform times."""
    N, n = 400, rv3sb.n_joints
    q, qd, qdd = (rng.uniform(-2.0, 2.0, (N, n)) for _ in range(3))
    lim = rv3sb.limits
    q = np.clip(q, lim.lower, lim.upper)
    tau = torques(rv3sb, q, qd, qdd, standard_parameters(rv3sb))
    return JointLog(t=np.arange(N) * 0.01, q=q, tau=tau, qd=qd, qdd=qdd)


def _currents(log: JointLog) -> JointLog:
    i = log.tau / GAINS
    return JointLog(t=log.t, q=log.q, tau=i * GAINS, qd=log.qd, qdd=log.qdd, current=i)


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_currents_log_reads_back_as_gain_times_current(torque_log, tmp_path, suffix):
    log = _currents(torque_log)
    path = write_joint_log(tmp_path / f"i{suffix}", log)
    if suffix == ".csv":
        assert path.read_text().splitlines()[0].split(",")[7:13] == [
            f"i{j}" for j in range(1, 7)
        ]
    back = read_joint_log(path, 6, gains=GAINS)
    np.testing.assert_array_equal(back.current, log.current)
    np.testing.assert_array_equal(back.tau, log.current * GAINS)
    np.testing.assert_allclose(back.tau, torque_log.tau, rtol=1e-14, atol=1e-12)


def test_npz_currents_alias(torque_log, tmp_path):
    i = torque_log.tau / GAINS
    np.savez(tmp_path / "o.npz", times=torque_log.t, positions=torque_log.q, currents=i)
    back = read_joint_log(tmp_path / "o.npz", gains=GAINS)
    np.testing.assert_array_equal(back.tau, i * GAINS)
    assert back.qd is None


def test_currents_identify_as_the_torques(rv3sb, torque_log, tmp_path):
    """Oracle: the torque log itself. Same samples, same OLS base parameters."""
    write_joint_log(tmp_path / "tau.csv", torque_log)
    write_joint_log(tmp_path / "i.csv", _currents(torque_log))
    _, (s_tau,) = prepare_logs([tmp_path / "tau.csv"], 6, idle_speed=0)
    _, (s_i,) = prepare_logs([tmp_path / "i.csv"], 6, gains=GAINS, idle_speed=0)
    np.testing.assert_allclose(s_i.tau, s_tau.tau, rtol=1e-14, atol=1e-12)
    a = identify(rv3sb, stack_samples([s_tau]), method="ols")
    b = identify(rv3sb, stack_samples([s_i]), method="ols")
    scale = np.abs(a.params).max()
    assert np.abs(b.params - a.params).max() < 1e-9 * scale
    truth = a.base.regroup(standard_parameters(rv3sb))
    assert np.abs(a.params - truth).max() < 1e-6 * scale  # noise-free: the truth


def test_torque_log_ignores_gains(torque_log, tmp_path):
    path = write_joint_log(tmp_path / "tau.csv", torque_log)
    np.testing.assert_array_equal(read_joint_log(path, gains=GAINS).tau, torque_log.tau)


def _csv(tmp_path, header: str, rows: int = 3) -> str:
    n = len(header.split(","))
    body = "\n".join(",".join(f"{k + 0.1 * c}" for c in range(n)) for k in range(rows))
    (tmp_path / "bad.csv").write_text(header + "\n" + body + "\n")
    return tmp_path / "bad.csv"


@pytest.mark.parametrize(
    "header, gains, message",
    [
        ("t,q1,q2,i1,i2", None, r"bad.csv: the log holds motor currents \(i\) but no "
         "drive gains"),
        ("t,q1,q2,i1,i2", [1.0, 2.0, 3.0], "gains: expected 2 drive gains"),
        ("t,q1,q2,i1,i2", [1.0, -2.0], "gains: expected positive"),
        ("t,q1,q2,tau1,tau2,i1,i2", [1.0, 2.0], r"both torques \(tau\) and motor "
         r"currents \(i\) given; keep one"),
        ("t,q1,q2,i1", [1.0, 2.0], "missing column"),
        ("t,q1,q2,i1,i2,j1", [1.0, 2.0], "unknown column"),
    ],
)  # fmt: skip
def test_bad_currents_csv_refused_in_one_line(tmp_path, header, gains, message):
    path = _csv(tmp_path, header)
    with pytest.raises(ValueError, match=message) as e:
        read_joint_log(path, gains=gains)
    assert "\n" not in str(e.value)


def test_bad_currents_npz_refused(tmp_path):
    a, t = np.ones((4, 2)), np.arange(4.0)
    np.savez(tmp_path / "both.npz", t=t, q=a, tau=a, currents=a)
    with pytest.raises(ValueError, match=r"both torques \(tau\) and motor currents"):
        read_joint_log(tmp_path / "both.npz", gains=[1.0, 1.0])
    np.savez(tmp_path / "none.npz", t=t, q=a)
    with pytest.raises(ValueError, match=r"missing array 'tau' .* or motor currents"):
        read_joint_log(tmp_path / "none.npz")
    np.savez(tmp_path / "two.npz", t=t, q=a, i=a, currents=a)
    with pytest.raises(ValueError, match="arrays 'i' and 'currents' both given"):
        read_joint_log(tmp_path / "two.npz", gains=[1.0, 1.0])


def test_identify_and_validate_a_currents_log_from_the_cli(
    rv3sb, torque_log, tmp_path, capsys
):
    """`identify --gains` on a currents log writes the same base parameters as
    the torque log and records the gains as the robot's drive gains; the
    written robot then validates the currents log with no further option
    (its drive gains), at zero error."""
    from rmdrake.cli.commands import main
    from rmdrake.model.loading import load_robot

    write_joint_log(tmp_path / "tau.csv", torque_log)
    write_joint_log(tmp_path / "i.csv", _currents(torque_log))
    common = ["--robot", "rv3sb", "--method", "ols", "--idle-speed", "0"]
    gains = ",".join(f"{g:g}" for g in GAINS)
    assert main(["identify", *common, "--log", str(tmp_path / "i.csv"),
                 "--out", str(tmp_path / "i.yaml"), "--gains", gains]) == 0  # fmt: skip
    assert main(["identify", *common, "--log", str(tmp_path / "tau.csv"),
                 "--out", str(tmp_path / "tau.yaml")]) == 0  # fmt: skip
    from_i, from_tau = (
        load_robot(tmp_path / "i.yaml"),
        load_robot(tmp_path / "tau.yaml"),
    )
    np.testing.assert_array_equal(from_i.drive_gain, GAINS)
    assert from_tau.drive_gain is None
    b_i, b_tau = (
        np.array([v["value"] for v in r.calibration["base_parameters"].values()])
        for r in (from_i, from_tau)
    )
    assert np.abs(b_i - b_tau).max() < 1e-9 * np.abs(b_tau).max()
    capsys.readouterr()
    argv = ["validate", "--robot", str(tmp_path / "i.yaml"), "--log",
            str(tmp_path / "i.csv")]  # fmt: skip
    assert main(argv) == 0
    assert "mean" in capsys.readouterr().out
    assert main(["identify", *common, "--log", str(tmp_path / "i.csv"),
                 "--out", str(tmp_path / "x.yaml")]) == 2  # fmt: skip
    assert "no drive gains" in capsys.readouterr().err
    assert not (tmp_path / "x.yaml").exists()
