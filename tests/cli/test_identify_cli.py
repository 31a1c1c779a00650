"""`rmdrake identify`: a log written from known parameters comes back, the
written robot YAML carries them, and bad logs are refused without output."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import perturb_standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """One period at 150 Hz of a random feasible trajectory on a perturbed
    RV-3SB, torques from the regressor (noise-free), with qd and qdd."""
    tmp = tmp_path_factory.mktemp("identify")
    model = load_robot("rv3sb")
    chi = perturb_standard_parameters(
        standard_parameters(model), np.random.default_rng(3)
    )
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    traj.save(tmp / "traj.yaml")
    t, q, qd, qdd = traj.sample(150.0)
    tau = torques(model, q, qd, qdd, chi)
    write_joint_log(tmp / "log.csv", JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd))
    half = t < 5.0
    write_joint_log(
        tmp / "half.csv",
        JointLog(t=t[half], q=q[half], tau=tau[half], qd=qd[half], qdd=qdd[half]),
    )
    write_joint_log(
        tmp / "later.csv",  # another run of the same motion, 1e9 s later
        JointLog(t=t + 1e9, q=q, tau=tau, qd=qd, qdd=qdd),
    )
    write_joint_log(
        tmp / "five.csv",
        JointLog(t=t, q=q[:, :5], tau=tau[:, :5], qd=qd[:, :5], qdd=qdd[:, :5]),
    )
    write_joint_log(
        tmp / "short.csv",
        JointLog(t=t[:8], q=q[:8], tau=tau[:8], qd=qd[:8], qdd=qdd[:8]),
    )
    return tmp, model, chi


@pytest.mark.parametrize("method", ["ols", "physical"])
def test_identify_recovers_the_parameters_that_made_the_log(case, method, capsys):
    tmp, model, chi = case
    out = tmp / f"identified_{method}.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "log.csv"),
            "--out", str(out), "--method", method,
            "--trajectory", str(tmp / "traj.yaml")]  # fmt: skip
    assert main(argv) == 0
    identified = load_robot(out)
    base = base_parameters(model)
    truth = base.regroup(chi)
    found = base.regroup(standard_parameters(identified))
    # OLS is exact; its standard parameters are the physically consistent
    # projection, which reproduces the base parameters to the solver's accuracy.
    assert np.abs(found - truth).max() < 1e-5 * np.abs(truth).max()
    record = identified.calibration
    assert record["method"] == f"identify/{method}"
    assert len(record["base_parameters"]) == base.count == 52
    assert "52 base parameters identified" in capsys.readouterr().out


@pytest.mark.parametrize(
    "log, extra, message",
    [
        ("half.csv", ["--trajectory", "traj.yaml"], "shorter than one period"),
        ("short.csv", [], r"equations .* for 52 parameters"),
        ("log.csv", ["--method", "sgd"], r"--method: invalid choice: 'sgd'"),
        (
            "log.csv",
            ["--log", "later.csv", "--trajectory", "traj.yaml"],
            "trajectory: applies to a single log, 2 logs given",
        ),
        (
            "log.csv",
            ["--log", "five.csv"],
            r"logs .*log\.csv \(6 joints\) and .*five\.csv \(5 joints\)",
        ),
        ("log.csv", ["--trim", "2:11"], r"log\.csv: trim 2:11: outside the log"),
        ("log.csv", ["--trim", "5:5.04"], r"after trim: observations: 30 equations"),
        ("log.csv", ["--trim", "5-6"], r"trim: expected START:END"),
    ],
)
def test_identify_bad_input_writes_nothing(case, log, extra, message, capsys):
    tmp = case[0]
    out = tmp / "never.yaml"
    extra = [str(tmp / e) if e.endswith((".yaml", ".csv")) else e for e in extra]
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / log),
            "--out", str(out), *extra]  # fmt: skip
    assert main(argv) == 2  # argument errors too: one line, exit 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error:") and len(err.splitlines()) == 1
    assert re.search(message, err)
    assert not out.exists()


def test_identify_from_two_logs_and_a_trim(case, capsys):
    """Two logs (--log twice) and --trim 1:9, applied to each log from its own
    first stamp: the truth comes back (OLS, noise-free; the YAML's standard
    parameters are the physical projection, to 1e-5) and the YAML lists both
    logs and counts every sample of both windows."""
    tmp, model, chi = case
    out = tmp / "two.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "log.csv"),
            "--log", str(tmp / "later.csv"), "--trim", "1:9", "--out", str(out),
            "--method", "ols"]  # fmt: skip
    assert main(argv) == 0
    identified = load_robot(out)
    base = base_parameters(model)
    truth = base.regroup(chi)
    found = base.regroup(standard_parameters(identified))
    assert np.abs(found - truth).max() < 1e-5 * np.abs(truth).max()
    record = identified.calibration
    assert record["logs"] == [str(tmp / "log.csv"), str(tmp / "later.csv")]
    assert record["samples"] == 2 * (1201 - 2)  # 1..9 s at 150 Hz, ends trimmed
    printed = capsys.readouterr().out
    assert "from 2 log(s)" in printed and "kept 1 to 9 s of the log" in printed


@pytest.mark.parametrize(
    "extra, message",
    [
        (
            ["--mass-bounds", "1:2", "--total-mass", "20:30"],
            r"solver status '.*infeasible.*'; total mass bounds 20..30 kg conflict",
        ),
        (["--mass-bounds", "1-2"], r"--mass-bounds: expected LO:HI"),
        (["--total-mass", "1:2,3:4"], r"--total-mass: expected one LO:HI"),
        (["--prior", "PANDA7"], r"prior: robot 'seven' has 7 joints but robot"),
    ],
)
def test_identify_refuses_impossible_bounds_and_priors(case, extra, message, capsys):
    tmp, model, _ = case
    seven = dataclasses.replace(
        model,
        name="seven",
        mdh=np.vstack([model.mdh, model.mdh[-1:]]),
        sigma=None,
        limits=type(model.limits)(
            **{k: np.append(v, v[-1]) for k, v in vars(model.limits).items()}
        ),
        dynamics=np.vstack([model.dynamics, model.dynamics[-1:]]),
    )
    seven.save(tmp / "seven.yaml")
    extra = [str(tmp / "seven.yaml") if e == "PANDA7" else e for e in extra]
    out = tmp / "never.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "log.csv"),
            "--out", str(out), "--method", "physical", *extra]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error:") and len(err.splitlines()) == 1
    assert re.search(message, err)
    assert not out.exists()


def test_identify_ols_writes_the_fitted_model(case, capsys):
    """After --method ols the written per-link dynamics predict the fit's
    torques (the record's base parameters) on the log to 1e-9 relative, and
    the summary shows the masses with the prior's and the bounds hold."""
    tmp, model, chi = case
    out = tmp / "ols_bounded.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "log.csv"),
            "--out", str(out), "--method", "ols", "--mass-bounds", "0.05:40",
            "--total-mass", "5:100"]  # fmt: skip
    assert main(argv) == 0
    written = load_robot(out)
    record = written.calibration
    base = base_parameters(model)
    fitted = np.array([v["value"] for v in record["base_parameters"].values()])
    log = read_joint_log(tmp / "log.csv", n_joints=6)
    Y = base.regressor(model, log.q, log.qd, log.qdd)
    tau_fit = Y @ fitted
    tau_written = Y @ base.regroup(standard_parameters(written))
    assert np.abs(tau_written - tau_fit).max() < 1e-9 * np.abs(tau_fit).max()
    assert max(record["written_model_difference_rms_Nm"]) < 1e-9 * np.abs(tau_fit).max()
    masses = written.dynamics[:, 9]
    assert np.all(masses >= 0.05 - 1e-9) and 5 - 1e-6 <= masses.sum() <= 100 + 1e-6
    printed = capsys.readouterr().out
    assert f"total mass {masses.sum():.3f} kg (prior " in printed
    assert "written dynamics = the fitted model" in printed


def test_identify_terms_option(case, capsys):
    """--terms no-rotor,offset fits a log with offsets and no rotor inertia: the
    written YAML has the model: entry, tau0 equal to the truth, Ia = 0; a bad
    --terms is one line, exit 2, nothing written."""
    from rmdrake.dynamics.joint_log import read_joint_log
    from rmdrake.model.dynamic_parameters import extended_parameters
    from rmdrake.model.robot import DynamicTerms

    tmp, model, chi = case
    links = chi.reshape(6, 13).copy()
    links[:, 10] = 0.0  # a torque sensor on the link side sees no rotor
    tau0 = np.array([0.8, -1.5, 0.6, -0.2, 0.1, -0.05])
    true = dataclasses.replace(model, dynamics=links, tau0=tau0)
    log = read_joint_log(tmp / "log.csv")
    tau = torques(true, log.q, log.qd, log.qdd, extended_parameters(true))
    write_joint_log(tmp / "offset.csv", dataclasses.replace(log, tau=tau))
    out = tmp / "terms.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "offset.csv"),
            "--out", str(out), "--method", "ols",
            "--terms", "no-rotor,offset"]  # fmt: skip
    assert main(argv) == 0
    assert "54 base parameters" in capsys.readouterr().out
    found = load_robot(out)
    assert found.terms == DynamicTerms(rotor_inertia=False, offset=True)
    np.testing.assert_allclose(found.tau0, tau0, atol=1e-5)
    assert np.all(found.dynamics[:, 10] == 0.0) and found.fcn is None
    bad = tmp / "bad_terms.yaml"
    argv[argv.index("no-rotor,offset")] = "no-rotr"
    argv[argv.index(str(out))] = str(bad)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "terms" in err and "\n" not in err and not bad.exists()


def test_mass_bounds_from_the_robot_yaml(case, capsys):
    """A robot YAML's mass_bounds entry is what --mass-bounds and
    --total-mass would be: the same infeasible pair is refused the same way,
    and the entry round-trips through the YAML."""
    tmp, model, _ = case
    bounds = {"links": [1.0, 2.0], "total": [20.0, 30.0]}
    data = {**model.to_dict(), "mass_bounds": bounds}
    robot = RobotModel.from_dict(data)
    np.testing.assert_array_equal(robot.mass_bounds.links, [[1.0, 2.0]] * 6)
    assert RobotModel.from_dict(robot.to_dict()).mass_bounds.to_dict() == {
        "links": [[1.0, 2.0]] * 6,
        "total": [20.0, 30.0],
    }
    robot.save(tmp / "bounded.yaml")
    out = tmp / "never_bounded.yaml"
    argv = ["identify", "--robot", str(tmp / "bounded.yaml"),
            "--log", str(tmp / "log.csv"), "--out", str(out)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "total mass bounds 20..30 kg conflict" in err and not out.exists()
    for bad, message in (
        ({"links": [2.0, 1.0]}, r"mass_bounds.links\[0\]: expected 0 <= LO <= HI"),
        ({"links": [[0, 1]] * 5}, r"mass_bounds.links: expected one \[LO, HI\] or 6"),
        ({"total": [1.0]}, r"mass_bounds.total: expected \[LO, HI\]"),
        ({"tota": [1, 2]}, r"mass_bounds: expected a mapping with links"),
    ):
        with pytest.raises(ValueError, match=message):
            RobotModel.from_dict({**model.to_dict(), "mass_bounds": bad})


@pytest.mark.parametrize(
    "unit, message",
    [
        (1000.0, r"  unit: the 99th-percentile \|torque\| of joints 1, 2, 3"),
        (0.0, r"  torque log: joint\(s\) 1, 2, 3, 4, 5, 6 constant"),
    ],
)
def test_identify_refuses_absurd_torque_logs_before_the_fit(
    case, unit, message, capsys
):
    """A log in N mm (1000x) or all-zero torques: exit 3, nothing written;
    --force still writes, the reason recorded."""
    tmp = case[0]
    log = read_joint_log(tmp / "log.csv")
    bad = tmp / f"unit{unit:g}.csv"
    write_joint_log(bad, dataclasses.replace(log, tau=unit * log.tau))
    out = tmp / f"absurd{unit:g}.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(bad), "--out", str(out),
            "--method", "ols"]  # fmt: skip
    assert main(argv) == 3
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()
    assert main([*argv, "--force"]) == 0
    assert load_robot(out).calibration["warnings"][0].startswith(message[2:7])


@pytest.mark.parametrize(
    "prior, message",
    [
        ("negative", r"prior: robot 'rv3sb' is not physical: link 2: mass"),
        ("demo_rh", r"prior: robot 'demo_rh' has other kinematics than robot 'rv3sb"),
    ],
)
def test_identify_refuses_a_prior_not_physical_or_of_another_robot(
    case, prior, message, capsys
):
    tmp, model, _ = case
    if prior == "negative":
        dyn = np.array(model.dynamics)
        dyn[1, 9] = 0.0  # loads (a negative mass is refused at load) but no body
        model.with_dynamics(dyn).save(tmp / "negative.yaml")
        prior = str(tmp / "negative.yaml")
    out = tmp / "never.yaml"
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / "log.csv"),
            "--out", str(out), "--method", "ols", "--prior", prior]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err), err
    assert not out.exists()
