"""`rmdrake fleet` on a small fleet: 11 RV-3SB arms (3 % spread each, arm_03's
joint 3 friction doubled) whose logs the regressor wrote (noise-free; the
Drake-simulated fleet is tests/pipelines/test_fleet.py) and one log that is
not a log: the YAMLs and fleet.csv are written, the bad arm is a failed row,
the exit code is 3 and the summary the last line; bad options are exit 2 with
one line. `fleet --history` on one arm's six dated logs whose joint 2 Coulomb
friction grows: it alone is flagged; undated logs and fleet-only options are
exit 2 with one line."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot

GOOD, WORN = 11, 3


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """logs/arm_00..arm_10.csv (one 4 s period at 100 Hz, q, qd, qdd, tau)
    and logs/arm_11.csv, which is not a joint log."""
    tmp = tmp_path_factory.mktemp("fleet_cli")
    model = load_robot("rv3sb")
    t, q, qd, qdd = random_fourier_trajectory(
        model, fill=0.8, seed=4, base_frequency=0.25
    ).sample(100.0)
    for i in range(GOOD):
        true, _ = perturb_robot(model, dynamics_std=0.03, seed=i)
        chi = standard_parameters(true).copy()
        if i == WORN:
            chi[2 * 13 + 11 : 2 * 13 + 13] *= 2.0  # fv3, fc3
        tau = torques(model, q, qd, qdd, chi)
        log = JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd)
        write_joint_log(tmp / "logs" / f"arm_{i:02d}.csv", log)
    (tmp / "logs" / f"arm_{GOOD:02d}.csv").write_text("t,q1\nnot,a log\n")
    return tmp


def test_a_fleet_with_a_bad_log_writes_the_others_and_exits_3(logs, capsys):
    out = logs / "out"
    argv = ["fleet", "--robot", "rv3sb", "--logs", str(logs / "logs" / "*.csv"),
            "--out", str(out), "--workers", "2"]  # fmt: skip
    out.mkdir()
    (out / "arm_11.yaml").write_text("an earlier run's arm_11\n")
    assert main(argv) == 3
    printed = capsys.readouterr()
    err = printed.err.strip().splitlines()  # the progress bar's lines, then one
    assert [e for e in err if e.startswith("rmdrake")] == err[-1:]
    assert err[-1].startswith("rmdrake: refused: 1 of 12 arms not identified (arm_11)")
    lines = printed.out.strip().splitlines()
    assert lines[0].startswith("tasks run on a local Dask cluster of 2 worker")
    last = lines[-1]
    assert re.match(
        r"fleet: 12 arms, 1 flagged: arm_03 \(joint 3 viscous friction \+\d+ % "
        r"\(\d+\.\d sigma\), joint 3 Coulomb friction \+\d+ % \(\d+\.\d sigma\)\); "
        r"1 failed: arm_11 \(failed: .*arm_11\.csv",
        last,
    ), last
    assert "arm_11: failed: " in printed.out
    assert sorted(p.name for p in out.glob("*.yaml")) == [  # the earlier one kept
        f"arm_{i:02d}.yaml" for i in range(GOOD + 1)
    ]
    assert (out / "arm_11.yaml").read_text() == "an earlier run's arm_11\n"
    assert f"note: {out / 'arm_11.yaml'} is an earlier run's" in printed.out
    with open(out / "fleet.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["arm"] for r in rows] == [f"arm_{i:02d}" for i in range(GOOD + 1)]
    assert [r["status"] for r in rows] == ["ok"] * GOOD + ["failed"]
    bad = rows[-1]
    assert "arm_11.csv" in bad["reason"] and bad["yaml"] == "" and bad["fv3"] == ""
    assert rows[WORN]["flags"].startswith("joint 3 viscous friction +")
    assert float(rows[WORN]["largest_sigma"]) > 5
    assert all(float(r["largest_sigma"]) < 5 for r in rows[:GOOD] if r != rows[WORN])
    true, _ = perturb_robot(load_robot("rv3sb"), dynamics_std=0.03, seed=WORN)
    worn = [float(rows[WORN][k]) for k in ("fv3", "fc3")]  # noise-free: exact
    np.testing.assert_allclose(worn, 2.0 * true.dynamics[2, 11:13], rtol=1e-6)


def test_paths_as_the_shell_expands_them(logs, capsys):
    """Several --logs paths (an unquoted glob), in this process: exit 0, the
    summary last; --reference of the nominal robot flags the same arm."""
    paths = [str(logs / "logs" / f"arm_{i:02d}.csv") for i in range(GOOD)]
    argv = ["fleet", "--robot", "rv3sb", "--logs", *paths,
            "--out", str(logs / "out2"), "--workers", "0"]  # fmt: skip
    assert main(argv) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("fleet: 11 arms, 1 flagged: arm_03 (joint 3 viscous")
    assert main([*argv, "--reference", "rv3sb", "--threshold", "4"]) == 0
    printed = capsys.readouterr().out
    assert "with reference 'rv3sb'" in printed and "beyond 4 sigma" in printed
    last = printed.strip().splitlines()[-1]
    assert last.startswith("fleet: 11 arms, 1 flagged: arm_03")


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--logs", "NOWHERE/*.csv"], r"--logs '.*/nowhere/\*\.csv': no file matches"),
        (["--logs", "NOWHERE/arm.csv"], r"no file matches"),
        (["--logs", "LOGS/arm_01.csv", "COPY/arm_01.csv"], r"both are arm 'arm_01'"),
        (["--logs", "LOGS/arm_01.csv", "--method", "physical"], r"invalid choice"),
        (["--logs", "LOGS/arm_01.csv", "--threshold", "0"], r"--threshold"),
        (["--logs", "LOGS/arm_01.csv", "--workers", "1", "--scheduler", "x:8786"],
         r"not allowed with"),
    ],
)  # fmt: skip
def test_bad_options_are_one_line_exit_2(logs, tmp_path, extra, message, capsys):
    (tmp_path / "COPY").mkdir()
    (tmp_path / "COPY" / "arm_01.csv").write_text("t\n")
    where = {"NOWHERE": str(tmp_path / "nowhere"), "LOGS": str(logs / "logs")}
    where["COPY"] = str(tmp_path / "COPY")
    extra = [re.sub(r"^(NOWHERE|LOGS|COPY)", lambda m: where[m[1]], e) for e in extra]
    out = tmp_path / "out"
    assert main(["fleet", "--robot", "rv3sb", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error:") and len(err.splitlines()) == 1
    assert re.search(message, err), err
    assert not out.exists()


@pytest.fixture(scope="module")
def history_logs(tmp_path_factory):
    """One arm's logs on the 1st of 6 months, 4 s at 100 Hz each with torque
    noise of 0.5 % of the effort limits (the regressor's torques): its joint 2
    Coulomb friction grows 40 % a year (in the logs' dates), nothing else."""
    tmp = tmp_path_factory.mktemp("history_cli")
    model = load_robot("rv3sb")
    t, q, qd, qdd = random_fourier_trajectory(
        model, fill=0.8, seed=4, base_frequency=0.25
    ).sample(100.0)
    true, _ = perturb_robot(model, dynamics_std=0.03, seed=2)
    rng = np.random.default_rng(5)
    for month in range(1, 7):
        chi = standard_parameters(true).copy()
        chi[13 + 12] *= 1 + 0.4 * (month - 1) / 12  # fc2
        tau = torques(model, q, qd, qdd, chi)
        tau += 0.005 * model.limits.effort * rng.standard_normal(tau.shape)
        log = JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd)
        write_joint_log(tmp / "logs" / f"arm2_2026-{month:02d}-01.csv", log)
    return tmp


def test_history_flags_the_growing_friction_and_writes_its_files(history_logs, capsys):
    out = history_logs / "out"
    dated = str(history_logs / "logs" / "*.csv")
    argv = ["fleet", "--history", "--robot", "rv3sb", "--out", str(out),
            "--logs", dated, "--workers", "0"]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert printed[-1].startswith(
        "history: 6 fits over 5.0 months, 1 flagged: joint 2 Coulomb friction +"
    ), printed[-1]
    assert any("false alarms 1 % over 52 tests" in line for line in printed)
    for name in ("history.csv", "history_fits.csv", "history.png"):
        assert (out / name).stat().st_size > 0
    assert len(list(out.glob("arm2_2026-0*-01.yaml"))) == 6


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--build-spread", "3%"], r"--build-spread: not with --history"),
        (["--logs", "UNDATED"], r"expected one date YYYY-MM-DD in its name"),
    ],
)
def test_history_bad_options_are_one_line_exit_2(
    history_logs, logs, tmp_path, extra, message, capsys
):
    undated = str(logs / "logs" / "arm_01.csv")
    extra = [undated if e == "UNDATED" else e for e in extra]
    dated = str(history_logs / "logs" / "*.csv")
    argv = ["fleet", "--history", "--robot", "rv3sb", "--out", str(tmp_path / "o"),
            "--logs", dated, *extra]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error:") and len(err.splitlines()) == 1
    assert re.search(message, err), err
