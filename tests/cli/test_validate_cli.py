"""`rmdrake validate`: side-by-side figures of two robots on a log written from
the true one with known noise, the Fig. 7 plot, and bad input refused in one
line with nothing written."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel

NOISE = 0.01  # torque noise std, as a fraction of each joint's torque RMS


def five_joints(model: RobotModel) -> RobotModel:
    """``model`` less its last joint (for joint-count mismatches)."""
    limits = model.limits
    cut = {f.name: getattr(limits, f.name)[:5] for f in dataclasses.fields(limits)}
    return dataclasses.replace(
        model,
        mdh=model.mdh[:5],
        sigma=model.sigma[:5],
        dynamics=model.dynamics[:5],
        limits=dataclasses.replace(limits, **cut),
    )


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """A 10 s, 150 Hz log of the RV-3SB with Gaussian torque noise (1 % of each
    joint's torque RMS), the true robot, one 30 % too heavy, one without
    dynamics, a 5-joint robot and a 5-joint log."""
    tmp = tmp_path_factory.mktemp("validate")
    model = load_robot("rv3sb")
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    t, q, qd, qdd = traj.sample(150.0)
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    std = NOISE * np.sqrt(np.mean(tau**2, axis=0))
    noisy = tau + np.random.default_rng(1).normal(0.0, std, tau.shape)
    write_joint_log(tmp / "log.csv", JointLog(t=t, q=q, tau=noisy, qd=qd, qdd=qdd))
    write_joint_log(tmp / "log5.csv", JointLog(t=t, q=q[:, :5], tau=noisy[:, :5]))
    model.save(tmp / "true.yaml")
    dyn = np.array(model.dynamics)
    dyn[:, :10] *= 1.3
    model.with_dynamics(dyn).save(tmp / "heavy.yaml")
    model.with_dynamics(None).save(tmp / "nodyn.yaml")
    five_joints(model).save(tmp / "five.yaml")
    return tmp, std


def table(out: str) -> dict[str, list[float]]:
    """Printed rows: joint (or 'mean') -> numbers in the row, in order."""
    rows = {}
    for line in out.splitlines():
        key = line.split(maxsplit=1)[0] if line[:1].strip() else ""  # not notes
        if key.isdigit() or key == "mean":
            rows[key] = [
                float(x) for x in re.findall(r"[-+]?\d[\d.]*(?:e[-+]?\d+)?", line)
            ]
    return rows


def test_two_robots_side_by_side_and_the_plot(case, capsys):
    tmp, std = case
    png = tmp / "fig7.png"
    argv = ["validate", "--robot", str(tmp / "true.yaml"),
            "--robot", str(tmp / "heavy.yaml"), "--log", str(tmp / "log.csv"),
            "--plot", str(png)]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    header = next(line for line in out.splitlines() if line.startswith("joint"))
    assert header.index("true.yaml") < header.index("heavy.yaml")
    rows = table(out)
    assert list(rows) == ["1", "2", "3", "4", "5", "6", "mean"]
    # Row j: j, measured RMS, true RMS, true rel. %, heavy RMS, heavy rel. %.
    fig = np.array([rows[str(j)] for j in range(1, 7)])
    np.testing.assert_array_equal(fig[:, 0], np.arange(1, 7))
    # The true robot's error is the injected noise (std within 5 sampling
    # standard deviations of its RMS over ~1500 samples: 9 %), and its relative
    # error that over the measured RMS, i.e. about NOISE.
    np.testing.assert_allclose(fig[:, 2], std, rtol=0.09)
    np.testing.assert_allclose(fig[:, 3], 100 * fig[:, 2] / fig[:, 1], rtol=1e-2)
    np.testing.assert_allclose(fig[:, 3], 100 * NOISE, rtol=0.09)
    assert np.all(fig[:3, 4] > 3 * fig[:3, 2])  # 30 % too heavy: arm joints
    mean = rows["mean"]
    assert mean[4] > 2 * mean[2]  # mean relative error, heavy vs true
    np.testing.assert_allclose(mean[1], fig[:, 2].mean(), rtol=1e-3)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {png}" in out


def test_one_robot_without_plot_writes_nothing(case, capsys):
    tmp = case[0]
    before = set(tmp.iterdir())
    argv = ["validate", "--robot", str(tmp / "true.yaml"), "--log",
            str(tmp / "log.csv"), "--coulomb-width", "0.001"]  # fmt: skip
    assert main(argv) == 0
    assert "tanh(qd / 0.001)" in capsys.readouterr().out
    assert set(tmp.iterdir()) == before


def test_several_logs_are_prepared_apart_and_stacked(case, capsys):
    """The same log given twice (its copy 1e9 s later) doubles the samples and
    leaves every figure as it was (no sample mixed at the boundary), and
    --trim keeps each log's window."""
    tmp = case[0]
    log = read_joint_log(tmp / "log.csv")
    later = JointLog(t=log.t + 1e9, q=log.q, tau=log.tau, qd=log.qd, qdd=log.qdd)
    write_joint_log(tmp / "later.csv", later)
    one = ["validate", "--robot", str(tmp / "true.yaml"), "--log", str(tmp / "log.csv")]
    assert main(one) == 0
    single = capsys.readouterr().out
    assert main([*one, "--log", str(tmp / "later.csv")]) == 0
    double = capsys.readouterr().out
    n1 = int(re.search(r"(\d+) samples", single).group(1))
    assert int(re.search(r"(\d+) samples", double).group(1)) == 2 * n1
    rows_1, rows_2 = table(single), table(double)
    assert list(rows_1) == list(rows_2)
    for key in rows_1:
        np.testing.assert_allclose(rows_2[key], rows_1[key], rtol=1e-3)
    assert main([*one, "--trim", "2:8"]) == 0
    n_trim = int(re.search(r"(\d+) samples", capsys.readouterr().out).group(1))
    assert abs(n_trim - 0.6 * n1) <= 3


@pytest.mark.parametrize(
    "robots, log, plot, message",
    [
        (["nodyn.yaml"], "log.csv", "p.png", r"robot nodyn\.yaml: has no 'dynamics'"),
        (
            ["true.yaml", "five.yaml"],
            "log.csv",
            "p.png",
            r"expected one joint count, found true\.yaml 6, five\.yaml 5",
        ),
        (["true.yaml"], "log5.csv", "p.png", "log has 5 joints, expected 6"),
        (["five.yaml"], "log.csv", "p.png", "log has 6 joints, expected 5"),
        (["true.yaml"], "log.csv", "log.csv", "--plot .*is also the input --log"),
        (["true.yaml"], "log.csv", "true.yaml", "--plot .*is also the input --robot"),
        (["true.yaml"], "missing.csv", "p.png", "missing.csv"),
    ],
)
def test_bad_input_exits_2_with_one_line(case, robots, log, plot, message, capsys):
    tmp = case[0]
    before = {p: p.stat().st_mtime_ns for p in tmp.iterdir()}
    argv = ["validate", "--log", str(tmp / log), "--plot", str(tmp / plot)]
    for robot in robots:
        argv += ["--robot", str(tmp / robot)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith("rmdrake: error:")
    assert re.search(message, err), err
    assert {p: p.stat().st_mtime_ns for p in tmp.iterdir()} == before


def test_a_log_the_robot_does_not_explain_is_refused(case, tmp_path, capsys):
    """Joint 2's torque logged with the other sign: the figures are printed,
    then refused (exit 3) naming the sign; --force prints it as a warning."""
    tmp = case[0]
    log = read_joint_log(tmp / "log.csv")
    tau = log.tau.copy()
    tau[:, 1] *= -1
    flipped = tmp_path / "flipped.csv"
    write_joint_log(flipped, dataclasses.replace(log, tau=tau))
    argv = ["validate", "--robot", str(tmp / "true.yaml"), "--log", str(flipped)]
    assert main(argv) == 3
    captured = capsys.readouterr()
    assert "torque prediction error per joint" in captured.out
    assert "sign: joint 2's torque negated leaves" in captured.err
    assert main([*argv, "--force"]) == 0
    assert "warning: implausible (forced): true.yaml: " in capsys.readouterr().out


def test_the_logged_motion_in_its_cell(case, capsys):
    """--scene prints the motion's nearest approach to the cell (oracle: Drake's
    signed distances on a fresh plant over the same samples, the log's 1500
    subsampled to 400 evenly); --html replays it with the cell."""
    from conftest import cell_distances

    from rmdrake.kinematics.clearance import default_collision_radius
    from rmdrake.model.scene import load_cell
    from rmdrake.pipelines.validate import MAX_FRAMES

    tmp, _ = case
    page = tmp / "motion.html"
    argv = ["validate", "--robot", str(tmp / "true.yaml"), "--log",
            str(tmp / "log.csv"), "--scene", "rv3sb_table",
            "--html", str(page)]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    got = re.search(r"comes within (-?[\d.]+) mm of it at t = ([\d.]+) s", out)
    if got is None:  # the motion enters the cell: its penetration, and a warning
        got = re.search(r"enters it: penetration ([\d.]+) mm at t = ([\d.]+) s", out)
        assert re.search(r"warning: link 'link\d' enters the cell 'rv3sb_table'", out)
        got = (-float(got.group(1)), float(got.group(2)))
    else:
        got = (float(got.group(1)), float(got.group(2)))
    model, log = load_robot("rv3sb"), read_joint_log(tmp / "log.csv")
    keep = np.unique(np.linspace(0, len(log.t) - 1, MAX_FRAMES).astype(int))
    d = cell_distances(model, load_cell("rv3sb_table"),
                       default_collision_radius(model), log.q[keep])  # fmt: skip
    assert abs(got[0] - 1e3 * d.min()) < 0.06  # printed to 0.1 mm
    assert abs(got[1] - log.t[keep][np.argmin(d)]) < 0.006
    assert page.stat().st_size > 100_000
    assert f"({len(keep)} frames of the logged motion)" in out
