"""Hostile inputs to the dynamics commands (issue 44): each is refused with
its exit code and one line naming the problem (the option, key, row or bound),
nothing is written and every input is left byte for byte as it was. Tiny
RV-3SB logs the regressor wrote (noise-free), a few seconds each."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.model.robot import Payload

ARMS = 3


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` and its bytes."""
    return {str(p): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _refused(capsys, folder: Path, argv: list[str], code: int, pattern: str) -> str:
    """Runs ``argv``; checks the exit ``code``, one stderr line matching
    ``pattern``, and that no file under ``folder`` was written, changed or
    deleted. Returns the line."""
    before = _snapshot(folder)
    assert main([str(a) for a in argv]) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert re.search(pattern, err[0]), err[0]
    assert _snapshot(folder) == before
    return err[0]


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    """d/arm_00..arm_02.csv (one 4 s period at 50 Hz, q, qd, qdd, tau of
    three RV-3SB arms 3 % apart) and d/arm_00.yaml, a robot file named as an
    arm's output would be."""
    d = tmp_path_factory.mktemp("fleet_hostile")
    model = load_robot("rv3sb")
    traj = random_fourier_trajectory(model, fill=0.8, seed=4, base_frequency=0.25)
    t, q, qd, qdd = traj.sample(50.0)
    for i in range(ARMS):
        true, _ = perturb_robot(model, dynamics_std=0.03, seed=i)
        tau = torques(model, q, qd, qdd, standard_parameters(true))
        write_joint_log(d / f"arm_{i:02d}.csv", JointLog(t, q, tau, qd, qdd))
    model.save(d / "arm_00.yaml")
    traj.save(d / "traj.yaml")
    return d


def _fleet_argv(d: Path, *extra: str, robot: str = "rv3sb") -> list[str]:
    return ["fleet", "--robot", robot, "--logs", str(d / "arm_*.csv"),
            "--out", str(d / "out"), *extra]  # fmt: skip


# ---- perturb --scale ---------------------------------------------------------------
@pytest.mark.parametrize(
    "scale, pattern",
    [
        (
            "fv3=1e9",
            r"scale fv3=1e\+09: beyond the bound of a factor between 1/100 "
            r"and 100",
        ),  # fmt: skip
        ("M2=0.001", r"scale M2=0.001: beyond the bound"),
        ("fv3=1.5,fv3=2", r"--scale: fv3 given twice \(1.5 and 2\)"),
    ],
)
def test_perturb_scale_is_bounded_and_each_key_given_once(
    tmp_path, capsys, scale, pattern
):
    argv = ["perturb", "--robot", "rv3sb", "--out", tmp_path / "t.yaml"]
    _refused(capsys, tmp_path, [*argv, "--scale", scale], 2, pattern)


# ---- fleet: options before any work -----------------------------------------------
@pytest.mark.parametrize(
    "option, pattern",
    [
        (["--trim", "5:1"], r"trim 5:1: END 1 s is not after START 5 s"),
        (["--rate", "1e9"], r"rate 1e\+09 Hz: expected a rate in \(0, 100000\] Hz"),
        (["--decimate", "1000000"], r"decimate 1e\+06: expected an integer in 1..1000"),
        (
            ["--threshold", "1e9"],
            r"--threshold: 1e\+09 sigma: over the bound of 20 "
            r"sigma \(it would hide a worn arm",
        ),  # fmt: skip
    ],
)
def test_fleet_refuses_a_bad_option_up_front(fleet, capsys, option, pattern):
    _refused(capsys, fleet, _fleet_argv(fleet, *option), 2, pattern)


def test_fleet_refuses_another_robots_reference(fleet, capsys):
    """RV-3SB logs against demo_rh: refused by the same-robot rule, not every
    arm flagged at -100 %."""
    argv = _fleet_argv(fleet, "--reference", "demo_rh")
    _refused(capsys, fleet, argv, 2, r"--reference: robot 'demo_rh' has other "
             r"kinematics than robot 'rv3sb'.*give an identification or model of "
             r"robot 'rv3sb'")  # fmt: skip


@pytest.mark.parametrize("option", ["--robot", "--reference"])
def test_fleet_never_writes_over_its_robot_files(fleet, capsys, option):
    """OUT/arm_00.yaml would be the robot (or reference) file itself."""
    robot = str(fleet / "arm_00.yaml") if option == "--robot" else "rv3sb"
    argv = _fleet_argv(fleet, robot=robot)
    if option == "--reference":
        argv += ["--reference", str(fleet / "arm_00.yaml")]
    argv[argv.index("--out") + 1] = str(fleet)
    _refused(capsys, fleet, argv, 2, rf"--out \S+arm_00\.yaml: is also the input "
             rf"{option}; refusing to overwrite")  # fmt: skip


# ---- numbers at the door -----------------------------------------------------------
def _with_value(src: Path, dst: Path, column: str, value: str, row: int = 12) -> Path:
    """``src`` with data row ``row`` (1-based) of ``column`` set to ``value``."""
    lines = src.read_text().splitlines()
    head = lines[0].split(",")
    cells = lines[row].split(",")
    cells[head.index(column)] = value
    lines[row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")
    return dst


@pytest.mark.parametrize(
    "column, value, pattern",
    [
        (
            "q1",
            "1e308",
            r"row 12, column q1: 1e\+308 rad is beyond joint 1's limits "
            r"\(-2.967 .. 2.967 rad\) by over 100x its range",
        ),  # fmt: skip
        (
            "tau3",
            "1e308",
            r"row 12, column tau3: 1e\+308 N m is over 1000x joint 3's "
            r"effort limit",
        ),  # fmt: skip
        (
            "qd2",
            "-1e12",
            r"row 12, column qd2: -1e\+12 rad/s is over 1000x joint 2's "
            r"velocity limit",
        ),  # fmt: skip
    ],
)
@pytest.mark.parametrize("command", ["identify", "identify-payload"])
def test_an_absurd_value_is_refused_naming_its_row_and_column(
    tmp_path, fleet, capsys, command, column, value, pattern
):
    log = _with_value(fleet / "arm_00.csv", tmp_path / "bad.csv", column, value)
    robot = "rv3sb"
    if command == "identify-payload":  # an identified arm: the shipped one's
        robot = str(fleet / "arm_00.yaml")
    argv = [command, "--robot", robot, "--log", log, "--out", tmp_path / "o.yaml"]
    _refused(capsys, tmp_path, argv, 2, rf"bad\.csv: {pattern}")


def test_a_header_of_100000_columns_is_refused_before_its_rows(tmp_path, capsys):
    names = ["t"] + [f"q{j}" for j in range(1, 50_001)]
    names += [f"tau{j}" for j in range(1, 50_001)]
    (tmp_path / "wide.csv").write_text(",".join(names) + "\n" + "0," * 100_000 + "0\n")
    argv = ["identify", "--robot", "rv3sb", "--log", tmp_path / "wide.csv",
            "--out", tmp_path / "o.yaml"]  # fmt: skip
    _refused(capsys, tmp_path, argv, 2, r"wide\.csv: header has \d+ or more columns, "
             r"over the 321 of a log of at most 64 joints")  # fmt: skip


@pytest.mark.parametrize(
    "option, pattern",
    [
        (["--noise", "1e300"], r"--noise 1e\+300 N m: over 1x joint 1's effort limit"),
    ],
)
def test_simulate_bounds_its_sensor_noise(fleet, tmp_path, capsys, option, pattern):
    argv = ["simulate", "--robot", "rv3sb", "--trajectory", fleet / "traj.yaml",
            "--out", tmp_path / "log.csv", *option]  # fmt: skip
    _refused(capsys, tmp_path, argv, 2, pattern)


# ---- identify --trajectory: the motion itself --------------------------------------
def test_identify_accepts_the_log_of_its_trajectory(fleet, tmp_path, capsys):
    argv = ["identify", "--robot", "rv3sb", "--log", fleet / "arm_00.csv",
            "--trajectory", fleet / "traj.yaml", "--method", "ols",
            "--out", tmp_path / "o.yaml"]  # fmt: skip
    assert main([str(a) for a in argv]) == 0, capsys.readouterr().err
    assert (tmp_path / "o.yaml").is_file()


@pytest.mark.parametrize(
    "change, pattern",
    [
        ("rate", r"does not follow --trajectory \S+: joint \d differs by [0-9.]+ rad "
                 r"RMS from its designed q \(tolerance [0-9.]+ rad, 10 % of its"),
        ("amplitude", r"does not follow .*: joint \d differs by [0-9.]+ rad RMS"),
        ("zero", r"does not follow .*joint \d differs by .* rad RMS from its designed "
                 r"q \(tolerance 0.01 rad, a joint moving 0 rad: the floor"),
        ("joints", r"--trajectory \S+: 7 joints, the log \S+arm_00.csv 6: not the "
                   r"excitation of this log"),
    ],
)  # fmt: skip
def test_identify_refuses_a_trajectory_the_log_does_not_follow(
    fleet, tmp_path, capsys, change, pattern
):
    """The log (0.25 Hz) against the same design at 0.1 Hz, 100x its amplitude,
    all zero, or with a seventh joint: refused naming the joint and its RMS
    difference, nothing written."""
    from rmdrake.excitation.trajectory import load_fourier

    traj = load_fourier(fleet / "traj.yaml")
    a, b, q0 = traj.a, traj.b, traj.q0
    if change == "rate":
        traj = dataclasses.replace(traj, base_frequency=0.1)
    elif change == "amplitude":
        traj = dataclasses.replace(traj, a=100 * a, b=100 * b)
    elif change == "zero":
        traj = dataclasses.replace(traj, a=0 * a, b=0 * b, q0=0 * q0)
    else:
        traj = dataclasses.replace(
            traj, a=np.vstack([a, a[:1]]), b=np.vstack([b, b[:1]]), q0=[*q0, 0.0]
        )
    traj.save(tmp_path / "t.yaml")
    argv = ["identify", "--robot", "rv3sb", "--log", fleet / "arm_00.csv",
            "--trajectory", tmp_path / "t.yaml",
            "--out", tmp_path / "o.yaml"]  # fmt: skip
    _refused(capsys, tmp_path, argv, 2, pattern)
    _refused(capsys, fleet, argv, 2, pattern)  # the log intact too


# ---- identify-payload: a payload the logs do not determine -------------------------
def _payload_log(path: Path, payload, *, seed: int, samples: int = 1500) -> Path:
    """``samples`` at 150 Hz of one RV-3SB excitation, the arm carrying
    ``payload`` (None: none), torques with 0.05 N m of noise (``seed``)."""
    arm = load_robot("rv3sb")
    t, q, qd, qdd = random_fourier_trajectory(arm, seed=1).sample(150.0)
    keep = np.unique(np.linspace(0, t.size - 1, samples).astype(int))
    t, q, qd, qdd = t[keep], q[keep], qd[keep], qdd[keep]
    carrying = dataclasses.replace(arm, payload=payload)
    tau = torques(arm, q, qd, qdd, standard_parameters(carrying))
    tau = tau + 0.05 * np.random.default_rng(seed).standard_normal(tau.shape)
    return write_joint_log(path, JointLog(t, q, tau, qd, qdd))


def test_identify_payload_refuses_a_payload_not_seen(tmp_path, capsys):
    """Two logs of the arm without a payload (loaded and unloaded alike):
    the mass is noise (exit 3, "no payload seen", in grams); on 28 samples the
    same. A 0.2 kg payload on the same motion is written."""
    free0 = _payload_log(tmp_path / "free0.csv", None, seed=0)
    free1 = _payload_log(tmp_path / "free1.csv", None, seed=1)
    out = tmp_path / "out" / "with_tool.yaml"
    argv = ["identify-payload", "--robot", "rv3sb", "--out", out]
    for extra in (["--log", free1], ["--log", free1, "--log-unloaded", free0]):
        _refused(
            capsys,
            tmp_path,
            [*argv, *extra],
            3,
            r"refused: payload: no payload "
            r"seen: mass -?[0-9.]+ g \+- [0-9.]+ g \(under 3 std from 0\)",
        )
    short = _payload_log(tmp_path / "short.csv", None, seed=2, samples=28)
    _refused(capsys, tmp_path, [*argv, "--log", short], 3, "no payload seen|not "
             "positive")  # fmt: skip
    light = Payload(0.2, np.array([0, 0, 0.03]), np.array([2e-4, 2e-4, 1e-4, 0, 0, 0]))
    loaded = _payload_log(tmp_path / "light.csv", light, seed=3)
    assert main([str(a) for a in [*argv, "--log", loaded]]) == 0, capsys.readouterr()
    p = load_robot(str(out)).payload
    assert abs(p.mass - 0.2) < 0.01 and np.linalg.norm(p.p_EPcm - light.p_EPcm) < 5e-3


def test_a_payload_com_left_undetermined_is_refused(rv3sb):
    """The rule on a result: a CoM std of 280 mm is refused naming it; an
    inertia std of 1 kg m^2 on 2 kg is a warning."""
    from rmdrake.dynamics.data import JointSamples
    from rmdrake.dynamics.payload import (
        check_payload,
        identify_payload,
        payload_warnings,
    )

    tool = Payload(2.0, np.array([0.03, -0.02, 0.05]), np.array([4e-3] * 3 + [0] * 3))
    t, q, qd, qdd = random_fourier_trajectory(rv3sb, seed=1).sample(150.0)
    carrying = dataclasses.replace(rv3sb, payload=tool)
    tau = torques(rv3sb, q, qd, qdd, standard_parameters(carrying))
    r = identify_payload(rv3sb, JointSamples(t, q, qd, qdd, tau, 150.0))
    assert check_payload(r, rv3sb) == []
    wide = dataclasses.replace(r, com_std=np.array([0.28, 0.01, 0.01]))
    (reason,) = check_payload(wide, rv3sb)
    assert reason.startswith("payload: undetermined: com std 280 mm (over 50 mm)")
    assert payload_warnings(r) == []
    loose = dataclasses.replace(r, phi_std=np.r_[[1.0] * 6, r.phi_std[6:]])
    assert check_payload(loose, rv3sb) == []  # an inertia's std: a warning
    (warning,) = payload_warnings(loose)
    assert re.match(r"payload: inertia undetermined: std 1 kg m\^2 \(a radius of "
                    r"gyration of \d+ mm, over 50 mm\)", warning)  # fmt: skip
