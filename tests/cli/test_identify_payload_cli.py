"""``rmdrake identify-payload`` and ``rmdrake excite --payload``: the payload
written into the robot YAML (oracle: the payload the logs were made with), and
the refusals: exit 2 (bad input, unidentifiable) or 3 (absurd mass)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import fourier_series, load_fourier
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Payload, RobotModel

TOOL = Payload(
    2.0, np.array([0.03, -0.02, 0.05]), np.array([4e-3, 5e-3, 3e-3, 0, 0, 0])
)


def _log(model: RobotModel, path, *, sign: float = 1.0, joints: int = 6) -> str:
    """A 10 s log (t, q, tau, qd, qdd) of a random excitation with ``model``'s
    regressor torques (``sign`` -1: the payload's torque reversed)."""
    arm = dataclasses.replace(model, payload=None)
    tr = random_fourier_trajectory(arm, seed=1)
    t = np.arange(1500) / 150.0
    q, qd, qdd = (
        x[0]
        for x in fourier_series(
            t, base_frequency=tr.base_frequency, q0=tr.q0, a=tr.a[None], b=tr.b[None]
        )
    )
    tau_arm = torques(arm, q, qd, qdd, standard_parameters(arm))
    tau = tau_arm + sign * (
        torques(arm, q, qd, qdd, standard_parameters(model)) - tau_arm
    )
    cut = slice(0, joints)
    log = JointLog(t, q[:, cut], tau[:, cut], qd[:, cut], qdd[:, cut])
    return str(write_joint_log(path, log))


def test_identify_payload_writes_the_payload(rv3sb, tmp_path, capsys):
    log = _log(dataclasses.replace(rv3sb, payload=TOOL), tmp_path / "loaded.csv")
    free = _log(rv3sb, tmp_path / "free.csv")
    out = tmp_path / "with_tool.yaml"
    argv = ["identify-payload", "--robot", "rv3sb", "--log", log, "--out", str(out)]
    assert main([*argv, "--log-unloaded", free]) == 0, capsys.readouterr().err
    text = capsys.readouterr().out
    assert "payload mass 2 kg" in text and "centre of mass" in text
    p = load_robot(str(out)).payload
    assert p.mass == pytest.approx(2.0, rel=1e-9)
    np.testing.assert_allclose(p.p_EPcm, TOOL.p_EPcm, atol=1e-9)
    np.testing.assert_allclose(p.inertia, TOOL.inertia, atol=1e-9)


def test_identify_payload_refusals(rv3sb, tmp_path, capsys):
    out = str(tmp_path / "x.yaml")
    loaded = _log(dataclasses.replace(rv3sb, payload=TOOL), tmp_path / "loaded.csv")
    bare = tmp_path / "bare.yaml"
    dataclasses.replace(rv3sb, dynamics=None).save(bare)
    cases = [
        (["--robot", str(bare), "--log", loaded], 2, "has no dynamics"),
        (
            ["--robot", "rv3sb", "--log", _log(rv3sb, tmp_path / "five.csv", joints=5)],
            2,
            "5 joints, expected 6",
        ),  # fmt: skip
        (
            [
                "--robot",
                "rv3sb",
                "--log",
                _log(
                    dataclasses.replace(rv3sb, payload=TOOL),
                    tmp_path / "neg.csv",
                    sign=-1.0,
                ),
            ],
            3,
            "not positive",
        ),  # fmt: skip
        (
            [
                "--robot",
                "rv3sb",
                "--log",
                _log(
                    dataclasses.replace(rv3sb, payload=TOOL.with_mass(5000.0)),
                    tmp_path / "big.csv",
                ),
            ],
            3,
            "effort limit",
        ),  # fmt: skip
    ]
    for argv, code, words in cases:
        assert main(["identify-payload", *argv, "--out", out]) == code
        err = capsys.readouterr().err.strip()
        assert words in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "x.yaml").exists()


def test_excite_payload_conditions_the_payload(tmp_path, capsys):
    out = tmp_path / "payload.yaml"
    argv = ["excite", "--robot", "rv3sb", "--out", str(out), "--maxiter", "3"]
    assert main([*argv, "--payload"]) == 0, capsys.readouterr().err
    assert "cond(A of the payload)" in capsys.readouterr().out
    assert load_fourier(out).harmonics == 5
