"""`rmdrake identify`: a log written from known parameters comes back, the
written robot YAML carries them, and bad logs are refused without output."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rmdrake.cli import main
from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.parameters import perturb_standard_parameters
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation import random_fourier_trajectory
from rmdrake.io import JointLog, write_joint_log
from rmdrake.robot import load_robot


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
    ],
)
def test_identify_bad_input_writes_nothing(case, log, extra, message, capsys):
    tmp = case[0]
    out = tmp / "never.yaml"
    extra = [str(tmp / e) if e.endswith(".yaml") else e for e in extra]
    argv = ["identify", "--robot", "rv3sb", "--log", str(tmp / log),
            "--out", str(out), *extra]  # fmt: skip
    assert main(argv) == 2  # argument errors too: one line, exit 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error:") and len(err.splitlines()) == 1
    assert re.search(message, err)
    assert not out.exists()
