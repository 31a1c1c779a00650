"""The command does not depend on what else runs on the machine: with Dask's
default dashboard port 8787 and Meshcat's 7000..7099 held by another process,
a local Dask cluster and a saved Meshcat page still work and print nothing
extra; a third party's warning is printed in Python's form, not as rmdrake's."""

from __future__ import annotations

import subprocess
import sys
import warnings

import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot

COMMON_PORTS = (8787, *range(7000, 7100))

HOLDER = """
import socket, sys
held = []
for port in {ports!r}:
    s = socket.socket()
    try:
        s.bind(("0.0.0.0", port))
        s.listen()
        held.append(s)
    except OSError:  # already taken by something else: taken all the same
        s.close()
print(len(held), flush=True)
sys.stdin.read()  # until the test closes our stdin
"""


@pytest.fixture
def ports_taken():
    """Another process listening on 8787 and 7000..7099 (those it could bind;
    the others are taken already) for the test's duration."""
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER.format(ports=COMMON_PORTS)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert int(holder.stdout.readline()) >= 0
        yield
    finally:
        holder.stdin.close()
        holder.wait(timeout=30)


def test_a_local_cluster_with_the_common_ports_taken(ports_taken, tmp_path, capsys):
    model = load_robot("rv3sb")
    t, q, qd, qdd = random_fourier_trajectory(
        model, fill=0.8, seed=4, base_frequency=0.25
    ).sample(100.0)
    for i in range(3):
        true, _ = perturb_robot(model, dynamics_std=0.03, seed=i)
        tau = torques(model, q, qd, qdd, standard_parameters(true))
        write_joint_log(tmp_path / f"arm_{i}.csv", JointLog(t, q, tau, qd, qdd))
    argv = ["fleet", "--robot", "rv3sb", "--logs", str(tmp_path / "arm_*.csv"),
            "--out", str(tmp_path / "out"), "--workers", "2"]  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(argv) == 0
    printed = capsys.readouterr()
    assert printed.out.startswith("tasks run on a local Dask cluster of 2 worker")
    assert not [e for e in printed.err.splitlines() if "warning" in e.lower()]
    assert not [str(w.message) for w in caught if "in use" in str(w.message)]


def test_a_saved_meshcat_page_with_the_common_ports_taken(ports_taken, tmp_path):
    out = tmp_path / "rv3sb.html"
    assert main(["show", "--robot", "rv3sb", "--html", str(out)]) == 0
    assert "meshcat" in out.read_text().lower()


def test_only_rmdrakes_own_warnings_carry_its_prefix(monkeypatch, capsys):
    import rmdrake.model.loading
    import rmdrake.pipelines.show

    ours = rmdrake.model.loading.__file__
    summary = rmdrake.pipelines.show.robot_summary

    def warning_summary(model):
        warnings.warn_explicit("a plug-in's note", UserWarning, "/opt/plugin.py", 7)
        warnings.warn_explicit("rmdrake's note", UserWarning, ours, 1)
        return summary(model)

    monkeypatch.setattr(rmdrake.pipelines.show, "robot_summary", warning_summary)
    with warnings.catch_warnings(record=True) as passed_on:  # Python's own show
        warnings.simplefilter("always")
        assert main(["show", "--robot", "rv3sb"]) == 0
    err = capsys.readouterr().err
    assert "rmdrake: warning: rmdrake's note" in err
    assert "plug-in" not in err
    assert [(str(w.message), w.filename) for w in passed_on] == [
        ("a plug-in's note", "/opt/plugin.py")
    ]
