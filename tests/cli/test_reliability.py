"""The reliability matrix of issue 10: hostile invocations of every ``rmdrake``
subcommand. Each gives its documented exit code and exactly one line on stderr
naming the problem, creates no file and leaves every input byte-identical with
its mode; the one exit path maps interrupts, refused results and bugs; the
atomic writer never replaces what it must not."""

from __future__ import annotations

import errno
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rmdrake.calibration.plates.data import PlaneMeasurements, write_plane_measurements
from rmdrake.cli.commands import build_parser, main
from rmdrake.cli.options import PathArg
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.errors import ImplausibleResultError
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.io.atomic import atomic_write_bytes, atomic_write_text
from rmdrake.model.loading import load_robot

R, P, T, L, Q = "{d}/r.yaml", "{d}/p.csv", "{d}/t.yaml", "{d}/log.csv", "{d}/q.csv"
OUT = "{d}/new/out"  # a file no refused command may create (nor its folder)
PATH_IS_INPUT = r"--{out} \S+: is also the input --{inp}; refusing to overwrite"


@pytest.fixture(scope="module")
def sources(tmp_path_factory) -> Path:
    """Small valid inputs of every kind: robot, plates, trajectory, logs, program."""
    d = tmp_path_factory.mktemp("sources")
    model = load_robot("rv3sb")
    model.save(d / "r.yaml")
    q = np.tile([0.0, 0.0, 0.5, 0.0, 0.8, 0.0], (4, 1))
    write_plane_measurements(
        d / "p.csv", PlaneMeasurements([0, 0, 1, 1], q, [0.05] * 4)
    )
    traj = random_fourier_trajectory(model, fill=0.5, seed=4)
    traj.save(d / "t.yaml")
    t, q, _, _ = traj.sample(20.0)
    write_joint_log(d / "log.csv", JointLog(t=t, q=q, tau=np.zeros_like(q)))
    np.savez(d / "log.npz", t=t, q=q, tau=np.zeros_like(q))
    crc = bytearray((d / "log.npz").read_bytes())
    crc[200:260] = b"\xff" * 60  # inside the first array: a bad CRC
    (d / "crc.npz").write_bytes(bytes(crc))
    (d / "notzip.npz").write_text("t,q1\n0,0\n")
    (d / "q.csv").write_text("q1,q2,q3,q4,q5,q6\n0,0,0.5,0,0.8,0\n0.1,0,0.5,0,0.8,0\n")
    (d / "a_folder").mkdir()
    return d


def _setup_readonly(d: Path) -> None:
    (d / "ro.yaml").write_text("keep me\n")
    (d / "ro.yaml").chmod(0o444)


def _setup_links(d: Path) -> None:
    (d / "link.csv").symlink_to(d / "p.csv")
    os.link(d / "log.csv", d / "hard.csv")


def _setup_huge(d: Path) -> None:
    with open(d / "huge.yaml", "wb") as f:  # sparse: 17 MiB of zeros, no disk
        f.truncate(17 * 2**20)


def _setup_bad_robots(d: Path) -> None:
    """Robot YAMLs that load to no real robot: a misspelt key, a negative
    mass, an inertia that is not positive semi-definite."""
    import yaml

    data = load_robot("rv3sb").to_dict()
    typo = dict(data)
    typo["gravty"] = typo.pop("gravity")
    (d / "gravty.yaml").write_text(yaml.safe_dump(typo))
    for name, key, value in (("negmass", "M", -2.0), ("ixx", "XX", -1.04)):
        bad = load_robot("rv3sb").to_dict()
        bad["dynamics"][1][key] = value
        (d / f"{name}.yaml").write_text(yaml.safe_dump(bad))


def _setup_many_joints(d: Path) -> None:
    import yaml

    data = load_robot("rv3sb").to_dict()
    data["mdh"] = [dict(row) for row in data["mdh"] * 200]  # 1200 joints
    (d / "many.yaml").write_text(yaml.safe_dump(data))


SETUPS = {
    "bad_robots": _setup_bad_robots,
    "readonly": _setup_readonly,
    "links": _setup_links,
    "fifo": lambda d: os.mkfifo(d / "fifo"),
    "loop": lambda d: (d / "loop.csv").symlink_to(d / "loop.csv"),
    "huge": _setup_huge,
    "degrees": lambda d: (d / "deg.csv").write_text(
        "x,y,z,roll,pitch,yaw\n0.35,0.10,0.45,0,90,0\n"
    ),
    "swapped_urdf": lambda d: (d / "swapped.urdf").write_text(
        '<robot name="r"><link name="a"/><link name="b"/><joint name="j1" '
        'type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="1" upper="-1" effort="10" velocity="1"/></joint></robot>'
    ),
    "wide": lambda d: (d / "wide.csv").write_text(
        ",".join(["pose", "marker", *(f"q{j}" for j in range(5000)), "x", "y", "z"])
        + "\n"
    ),
    "many_joints": _setup_many_joints,
    "long_field": lambda d: (d / "long.csv").write_text(
        "plane,q1,q2,q3,q4,q5,q6,distance\n0," + "1" * 200_000 + ",0,0,0,0,0,0.05\n"
    ),
}
NOT_REGULAR = r"\S+: is {what}, not a regular file; --{opt} reads a regular file"

# (id, argv, exit code, regex the one line matches after "rmdrake: error: ", setup)
CASES = [
    ("simulate-bandwidth-over-nyquist",
     f"simulate --robot rv3sb --trajectory {T} --out {OUT} --bandwidth 1e9", 2,
     r"--bandwidth: 1e\+09 rad/s is over the Nyquist frequency of the 150 Hz rate",
     None),
    ("calibrate-header-of-5000-columns",
     f"calibrate --robot rv3sb --measurements {{d}}/wide.csv --out {OUT}", 2,
     r"\S+/wide.csv: line 1: 5005 columns, over the 1000 a point measurements "
     r"file may have", "wide"),
    ("show-robot-of-1200-joints", "show --robot {d}/many.yaml", 2,
     r"\S+/many.yaml: mdh: 1200 joint rows, over the 64", "many_joints"),
    ("import-urdf-swapped-limits",
     f"import-urdf {{d}}/swapped.urdf --base a --tip b --out {OUT}", 2,
     r"\S+/swapped.urdf: joint 'j1': <limit lower=\"1\"> is above upper=\"-1\"",
     "swapped_urdf"),
    ("calibrate-field-over-the-csv-limit",
     f"calibrate --robot rv3sb --measurements {{d}}/long.csv --out {OUT}", 2,
     r"\S+/long.csv: line \d+: field larger than field limit", "long_field"),
    ("plates-noise-over-the-span",
     f"simulate-plates --robot rv3sb --noise 1 --out {OUT}", 2,
     r"noise: 1 m is over 0.1 of the range finder's span \(5 to 80 mm\)", None),
    ("plates-noise-1e300", f"simulate-plates --robot rv3sb --noise 1e300 --out {OUT}",
     2, r"noise: 1e\+300 m is over 0.1 of the range finder's span", None),
    ("points-noise-over-the-reach",
     f"simulate-points --robot rv3sb --noise 1000 --out {OUT}", 2,
     r"noise: 1000 m is over 0.1 of the reach of robot 'rv3sb'", None),
    ("plates-payload-not-carried",
     f"simulate-plates --robot demo_rh_elastic --payload 0,1e9 --out {OUT}", 2,
     r"payload: no reading with 1e\+09 kg: robot 'demo_rh_elastic' reaches no plate",
     None),
    ("simulate-encoder-coarser-than-the-motion",
     f"simulate --robot rv3sb --trajectory {T} --out {OUT} --encoder-resolution 10",
     2, r"sensors.encoder_resolution: 10 per count on joint 1 is over 0.001 of its "
     r"range", None),
    ("show-port-80", f"show --robot rv3sb --port 80 --html {OUT}", 2,
     r"argument --port: expected a port in 1024\.\.65535, found 80", None),
    ("show-port-70000", f"show --robot rv3sb --port 70000 --html {OUT}", 2,
     r"argument --port: expected a port in 1024\.\.65535, found 70000", None),
    ("show-port-text", "show --robot rv3sb --port http", 2,
     r"argument --port: expected an integer, found 'http'", None),
    ("show-html-is-robot", f"show --robot {R} --html {R}", 2,
     PATH_IS_INPUT.format(out="html", inp="robot"), None),
    ("show-html-folder", "show --robot rv3sb --html {d}/a_folder", 2,
     r"\S+/a_folder: is a folder, expected a file name; nothing written", None),
    ("show-html-through-file", f"show --robot rv3sb --html {P}/x.html", 2,
     r"\S+/p.csv/x.html: cannot write: a folder on its path is a file", None),
    ("show-unknown-robot", f"show --robot nope --html {OUT}", 2,
     r"unknown robot 'nope'", None),
    ("demo-out-existing-file", f"demo --smoke --out {P}", 2,
     r"--out \S+/p.csv: exists and is not a folder", None),
    ("run-out-is-scenario-file", f"run --scenario-file {R} --scenario x --out {R}",
     2, PATH_IS_INPUT.format(out="out", inp="scenario-file"), None),
    ("run-unknown-scenario", f"run --scenario nope --out {OUT}", 2,
     r"scenario file \S+: no scenario 'nope'", None),
    ("plates-out-is-robot", f"simulate-plates --robot {R} --out {R}", 2,
     PATH_IS_INPUT.format(out="out", inp="robot"), None),
    ("plates-zero", f"simulate-plates --robot rv3sb --out {OUT} --plates 0", 2,
     r"argument --plates: expected an integer >= 1, found 0", None),
    ("plates-fraction", f"simulate-plates --robot rv3sb --out {OUT} --per-plate 1.5",
     2, r"argument --per-plate: expected an integer, found '1.5'", None),
    ("plates-noise-nan", f"simulate-plates --robot rv3sb --out {OUT} --noise nan", 2,
     r"argument --noise: expected a finite number, found nan", None),
    ("plates-seed-negative", f"simulate-plates --robot rv3sb --out {OUT} --seed -1",
     2, r"argument --seed: expected an integer >= 0, found -1", None),
    ("plates-out-readonly", "simulate-plates --robot rv3sb --out {d}/ro.yaml", 2,
     r"\S+/ro.yaml: is write-protected; nothing written", "readonly"),
    ("plates-out-fifo", "simulate-plates --robot rv3sb --out {d}/fifo", 2,
     r"\S+/fifo: is not a regular file; nothing written", "fifo"),
    ("calibrate-out-is-measurements",
     f"calibrate --robot rv3sb --measurements {P} --out {P}", 2,
     PATH_IS_INPUT.format(out="out", inp="measurements"), None),
    ("calibrate-out-symlink-to-measurements",
     f"calibrate --robot rv3sb --measurements {P} --out {{d}}/link.csv", 2,
     PATH_IS_INPUT.format(out="out", inp="measurements"), "links"),
    ("calibrate-out-other-spelling",
     f"calibrate --robot rv3sb --measurements {P} --out {{d}}/a_folder/../p.csv", 2,
     PATH_IS_INPUT.format(out="out", inp="measurements"), None),
    ("calibrate-maxiter-negative",
     f"calibrate --robot rv3sb --measurements {P} --out {OUT} --maxiter -1", 2,
     r"argument --maxiter: expected an integer >= 1, found -1", None),
    ("calibrate-f-scale-nan",
     f"calibrate --robot rv3sb --measurements {P} --out {OUT} --f-scale nan", 2,
     r"argument --f-scale: expected a finite number, found nan", None),
    ("calibrate-bound-inf",
     f"calibrate --robot rv3sb --measurements {P} --out {OUT} --angle-bound inf", 2,
     r"argument --angle-bound: expected a finite number, found inf", None),
    ("simulate-out-is-trajectory",
     f"simulate --robot rv3sb --trajectory {T} --out {T}", 2,
     PATH_IS_INPUT.format(out="out", inp="trajectory"), None),
    ("simulate-too-short",
     f"simulate --robot rv3sb --trajectory {T} --out {OUT} --periods 1e-5", 2,
     r"--periods 1e-05: \S+ s is under 3 log periods at --rate 150 Hz", None),
    ("simulate-rate-nan", f"simulate --robot rv3sb --trajectory {T} --out {OUT} "
     "--rate nan", 2, r"argument --rate: expected a finite number, found nan", None),
    ("simulate-accuracy-one", f"simulate --robot rv3sb --trajectory {T} --out {OUT} "
     "--accuracy 1", 2, r"argument --accuracy: expected 0 < value < 1, found 1", None),
    ("simulate-noise-negative", f"simulate --robot rv3sb --trajectory {T} --out {OUT}"
     " --noise 1,-2", 2, r"argument --noise: expected a number >= 0, found -2", None),
    ("simulate-v-eps-negative", f"simulate --robot rv3sb --trajectory {T} --out {OUT}"
     " --v-eps -1", 2, r"argument --v-eps: expected a number > 0, found -1", None),
    ("excite-harmonics-zero", f"excite --robot rv3sb --out {OUT} --harmonics 0", 2,
     r"argument --harmonics: expected an integer >= 1, found 0", None),
    ("excite-base-frequency-negative",
     f"excite --robot rv3sb --out {OUT} --base-frequency -1", 2,
     r"argument --base-frequency: expected a number > 0, found -1", None),
    ("excite-sample-rate-inf", f"excite --robot rv3sb --out {OUT} --sample-rate inf",
     2, r"argument --sample-rate: expected a finite number, found inf", None),
    ("excite-max-time-zero", f"excite --robot rv3sb --out {OUT} --max-time 0", 2,
     r"argument --max-time: expected a number > 0, found 0", None),
    ("excite-out-is-robot", f"excite --robot {R} --out {R}", 2,
     PATH_IS_INPUT.format(out="out", inp="robot"), None),
    ("excite-out-folder", "excite --robot rv3sb --out {d}/a_folder", 2,
     r"\S+/a_folder: is a folder, expected a file name; nothing written", None),
    ("plates-per-plate-huge",
     f"simulate-plates --robot rv3sb --out {OUT} --per-plate 100000000", 2,
     r"plates x per_plate: 5 x 100000000 = 5e\+08 readings is over the cap of "
     r"20000 readings.*", None),
    ("simulate-rate-huge", f"simulate --robot rv3sb --trajectory {T} --out {OUT} "
     "--rate 1e9", 2, r"1 period\(s\) of 10 s at 1e\+09 Hz .* over the 2 GiB",
     None),
    ("identify-rate-huge", f"identify --robot rv3sb --log {L} --out {OUT} "
     "--rate 1e9", 2,
     r".*log.csv: resampling .* at 1e\+09 Hz .* over the 2 GiB memory cap",
     None),
    ("identify-out-is-log", f"identify --robot rv3sb --log {L} --out {L}", 2,
     PATH_IS_INPUT.format(out="out", inp="log"), None),
    ("identify-out-hard-link-to-log",
     f"identify --robot rv3sb --log {L} --out {{d}}/hard.csv", 2,
     PATH_IS_INPUT.format(out="out", inp="log"), "links"),
    ("identify-out-is-trajectory",
     f"identify --robot rv3sb --log {L} --trajectory {T} --out {T}", 2,
     PATH_IS_INPUT.format(out="out", inp="trajectory"), None),
    ("identify-rate-nan", f"identify --robot rv3sb --log {L} --out {OUT} --rate nan",
     2, r"argument --rate: expected a finite number, found nan", None),
    ("identify-cutoff-negative",
     f"identify --robot rv3sb --log {L} --out {OUT} --cutoff -1", 2,
     r"argument --cutoff: expected a number >= 0, found -1", None),
    ("identify-decimate-zero",
     f"identify --robot rv3sb --log {L} --out {OUT} --decimate 0", 2,
     r"argument --decimate: expected an integer >= 1, found 0", None),
    ("identify-coulomb-width-negative",
     f"identify --robot rv3sb --log {L} --out {OUT} --coulomb-width -1", 2,
     r"argument --coulomb-width: expected a number >= 0, found -1", None),
    ("identify-not-zip", f"identify --robot rv3sb --log {{d}}/notzip.npz --out {OUT}",
     2, r"\S+/notzip.npz: not an NPZ file", None),
    ("identify-bad-crc", f"identify --robot rv3sb --log {{d}}/crc.npz --out {OUT}", 2,
     r"\S+/crc.npz: cannot read NPZ \(Bad CRC-32", None),
    ("identify-log-folder", f"identify --robot rv3sb --log {{d}}/a_folder --out {OUT}",
     2, r"\S+/a_folder: Is a directory; --log reads a regular file", None),
    # issue 11: one guard for every path option, inputs regular files, capped
    ("identify-out-is-prior", f"identify --robot rv3sb --log {L} --prior {R} "
     f"--out {R}", 2, PATH_IS_INPUT.format(out="out", inp="prior"), None),
    ("identify-payload-out-is-log-unloaded", f"identify-payload --robot rv3sb "
     f"--log {L} --log-unloaded {{d}}/log.npz --out {{d}}/log.npz", 2,
     PATH_IS_INPUT.format(out="out", inp="log-unloaded"), None),
    ("simulate-out-is-nominal", f"simulate --robot rv3sb --trajectory {T} "
     f"--nominal {R} --out {R}", 2, PATH_IS_INPUT.format(out="out", inp="nominal"),
     None),
    ("validate-plot-is-robot", f"validate --robot {R} --log {L} --plot {R}", 2,
     PATH_IS_INPUT.format(out="plot", inp="robot"), None),
    ("identify-log-fifo", f"identify --robot rv3sb --log {{d}}/fifo --out {OUT}", 2,
     NOT_REGULAR.format(what="a FIFO", opt="log"), "fifo"),
    ("identify-log-dev-zero", f"identify --robot rv3sb --log /dev/zero --out {OUT}",
     2, NOT_REGULAR.format(what="a device", opt="log"), None),
    ("correct-targets-dev-urandom", f"correct --robot rv3sb --targets /dev/urandom "
     f"--out {OUT}", 2, NOT_REGULAR.format(what="a device", opt="targets"), None),
    ("show-robot-fifo", "show --robot {d}/fifo", 2,
     NOT_REGULAR.format(what="a FIFO", opt="robot"), "fifo"),
    ("calibrate-measurements-folder", f"calibrate --robot rv3sb --measurements "
     f"{{d}}/a_folder --out {OUT}", 2,
     r"\S+/a_folder: Is a directory; --measurements reads a regular file", None),
    ("show-robot-over-cap", "show --robot {d}/huge.yaml", 2,
     r"\S+/huge.yaml: 17 MiB is over the 16 MiB cap of a robot file \(--robot\)",
     "huge"),
    ("excite-out-trailing-slash", "excite --robot rv3sb --out {d}/new/", 2,
     r"\S+/new/?: names a folder \(ends in /\), expected a file name", None),
    # issue 11: a robot is validated once, on load, for every command
    ("show-robot-typo", "show --robot {d}/gravty.yaml", 2,
     r"\S+/gravty.yaml: unknown key 'gravty': did you mean 'gravity'\?",
     "bad_robots"),
    ("export-urdf-negative-mass", f"export-urdf --robot {{d}}/negmass.yaml "
     f"--out {OUT}", 2,
     r"\S+/negmass.yaml: dynamics\[1\] \(link 2\): mass M = -2 kg is negative",
     "bad_robots"),
    ("export-urdf-inertia", f"export-urdf --robot {{d}}/ixx.yaml --out {OUT}", 2,
     r"\S+/ixx.yaml: dynamics\[1\] \(link 2\): inertia XX..ZZ is not positive "
     "semi-definite", "bad_robots"),
    ("plates-negative-mass", f"simulate-plates --robot {{d}}/negmass.yaml "
     f"--out {OUT}", 2, r"\S+/negmass.yaml: dynamics\[1\] \(link 2\): mass",
     "bad_robots"),
    ("excite-inertia", f"excite --robot {{d}}/ixx.yaml --out {OUT}", 2,
     r"\S+/ixx.yaml: dynamics\[1\] \(link 2\): inertia", "bad_robots"),
    ("validate-negative-mass", f"validate --robot {{d}}/negmass.yaml --log {L}", 2,
     r"\S+/negmass.yaml: dynamics\[1\] \(link 2\): mass", "bad_robots"),
    # issue 11: correct and simulate refuse what the physics forbids
    ("correct-payload-1e9", f"correct --robot demo_rh_elastic --targets {Q} "
     f"--out {OUT} --payload 1e9", 2, r"payload 1e\+09 kg: pre-deflection of "
     r"joint 2 is \S+ deg, over the \S+ deg it bends at its effort limit .* "
     "cannot hold this payload", None),
    ("correct-nominal-other-robot", f"correct --robot rv3sb --nominal demo_rh "
     f"--targets {Q} --out {OUT}", 2, r"nominal: robot 'demo_rh' has other "
     r"kinematics than robot 'rv3sb' \(joint 1 r 2.5 vs 0.35", None),
    ("correct-targets-in-degrees", f"correct --robot rv3sb --targets {{d}}/deg.csv "
     f"--out {OUT}", 2, r"\S+/deg.csv: row 1 pitch = 90 is beyond \+-2 pi rad: "
     "angles are in rad, not degrees", "degrees"),
    ("simulate-nominal-other-robot", f"simulate --robot rv3sb --nominal demo_rh "
     f"--trajectory {T} --out {OUT}", 2, r"nominal: robot 'demo_rh' has other "
     "kinematics than robot 'rv3sb'", None),
    ("plates-out-symlink-loop", "simulate-plates --robot rv3sb --out {d}/loop.csv",
     2, r"\S+/loop.csv: is a symbolic link that loops or points nowhere", "loop"),
    ("identify-out-readonly", f"identify --robot rv3sb --log {L} --out {{d}}/ro.yaml",
     2, r"\S+/ro.yaml: is write-protected; nothing written", "readonly"),
    ("correct-out-is-targets", f"correct --robot rv3sb --targets {Q} --out {Q}", 2,
     PATH_IS_INPUT.format(out="out", inp="targets"), None),
    ("correct-out-is-robot", f"correct --robot {R} --targets {Q} --out {R}", 2,
     PATH_IS_INPUT.format(out="out", inp="robot"), None),
    ("correct-targets-folder", f"correct --robot rv3sb --targets {{d}}/a_folder "
     f"--out {OUT}", 2, r"\S+/a_folder: Is a directory", None),
    ("identify-gains-on-a-torque-log", f"identify --robot rv3sb --log {L} "
     f"--gains 50 --out {OUT}", 2, r"--gains given, but \S+/log.csv holds joint "
     r"torques \(tau\), not motor currents \(i\)", None),
    ("correct-missing-targets", f"correct --robot rv3sb --targets {{d}}/nope.csv "
     f"--out {OUT}", 2, r"\S+/nope.csv: No such file or directory", None),
]  # fmt: skip


def _snapshot(folder: Path) -> dict[str, tuple[bytes | None, int]]:
    """{relative path: (content of a regular file, mode)} of everything below."""
    return {
        str(p.relative_to(folder)): (
            p.read_bytes() if p.is_file() and not p.is_symlink() else None,
            p.lstat().st_mode,
        )
        for p in sorted(folder.rglob("*"))
    }


@pytest.fixture
def inputs(sources, tmp_path) -> Path:
    """A private copy of the sources: a refused command must leave it as it was."""
    return Path(shutil.copytree(sources, tmp_path / "in"))


def _one_line(capfd) -> str:
    """The one line on stderr (whatever wrote it: Python, tqdm or Drake)."""
    err = capfd.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got:\n{err}"
    return lines[0]


@pytest.mark.parametrize(
    "argv, code, pattern, setup", [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_refused_with_one_line_and_nothing_written(
    inputs, capfd, argv, code, pattern, setup
):
    if setup:
        SETUPS[setup](inputs)
    before = _snapshot(inputs)
    assert main(argv.format(d=inputs).split()) == code
    assert re.fullmatch(f"rmdrake: error: {pattern}.*", _one_line(capfd))
    assert _snapshot(inputs) == before  # no output, no temp file, inputs whole


#: Options whose text is not a file name (a new option must be declared as one).
NOT_PATHS = {"scenario", "base", "tip", "name", "exclude", "params", "trim"}
NOT_PATHS |= {"mass_bounds", "total_mass", "terms", "help"}


def test_every_path_option_is_declared_with_a_path_type():
    """check_paths finds paths by their type, so an option that takes text
    with no type must be one of the known non-path options: a new file option
    cannot miss the guard."""
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    untyped = {
        f"{name} --{action.dest}"
        for name, p in sub.choices.items()
        for action in p._actions
        if action.type is None and action.nargs != 0 and action.choices is None
        and action.dest not in NOT_PATHS
    }  # fmt: skip
    assert not untyped, f"options without a type (a path type?): {sorted(untyped)}"
    args = build_parser().parse_args(["identify", "--robot", "r", "--log", "l",
                                      "--prior", "p", "--out", "o"])  # fmt: skip
    roles = {k: v.role for k, v in vars(args).items() if isinstance(v, PathArg)}
    assert roles == {"robot": "input", "prior": "input", "out": "output"}
    assert [v.kind for v in args.log] == ["log"]


def test_correction_bounds_are_the_calibration_bounds_summed():
    from rmdrake.pipelines.correct import correction_bounds

    bound = correction_bounds(load_robot("rv3sb"))
    assert np.allclose(np.rad2deg(bound), 90.0)  # 3 angles x 6 joints x 5 deg


def test_read_only_folder_is_refused_before_work(inputs, capfd, monkeypatch):
    folder = inputs / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    if os.geteuid() == 0:  # root writes anywhere: deny it as for any other user
        access = os.access
        monkeypatch.setattr(
            os, "access", lambda p, mode: Path(p) != folder and access(p, mode)
        )
    before = _snapshot(inputs)
    argv = ["simulate-plates", "--robot", "rv3sb", "--out", str(folder / "m.csv")]
    assert main(argv) == 2
    line = _one_line(capfd)
    assert line.endswith(f"folder {folder} is not writable; nothing written")
    assert _snapshot(inputs) == before


# ---- the one exit path: interrupt, refused result, a bug, Drake's assertion ------
def _raise(error: BaseException):
    def handler(*args, **kwargs):
        raise error

    return handler


EXITS = [
    ("interrupt", KeyboardInterrupt(), 130, r"rmdrake: interrupted; nothing written"),
    ("bug", ZeroDivisionError("division by zero"), 1,
     r"rmdrake: internal error: ZeroDivisionError: division by zero \(rerun with "
     r"--debug for the traceback\)"),
    ("drake-assertion", SystemExit("Failure at meshcat.cc:773 in Impl():\n x"), 1,
     r"rmdrake: internal error: SystemExit: Failure at meshcat.cc:773 in Impl\(\): x "
     r"\(rerun with --debug for the traceback\)"),
    ("permission", PermissionError(errno.EACCES, "Permission denied", "/x/y.yaml"), 2,
     r"rmdrake: error: /x/y.yaml: Permission denied"),
    ("multi-line-message", ValueError("r.yaml: bad\n  line 3"), 2,
     r"rmdrake: error: r.yaml: bad line 3"),
]  # fmt: skip


@pytest.mark.parametrize(
    "error, code, pattern", [e[1:] for e in EXITS], ids=[e[0] for e in EXITS]
)
def test_one_exit_path(monkeypatch, capfd, tmp_path, error, code, pattern):
    monkeypatch.setattr("rmdrake.model.loading.load_robot", _raise(error))
    assert (
        main(["show", "--robot", "rv3sb", "--html", str(tmp_path / "s.html")]) == code
    )
    assert re.fullmatch(pattern, _one_line(capfd))
    assert not any(tmp_path.iterdir())


def test_implausible_result_is_refused_with_exit_3(monkeypatch, capfd, inputs):
    reasons = ["residual RMS 44984 um, 2e4 x the noise 2 um", "dalpha2 -90 deg"]
    error = ImplausibleResultError(reasons)
    monkeypatch.setattr("rmdrake.pipelines.calibrate.calibrate_file", _raise(error))
    before = _snapshot(inputs)
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(inputs / "p.csv")]
    assert main([*argv, "--out", str(inputs / "cal.yaml")]) == 3
    err = capfd.readouterr().err.splitlines()
    assert err[-3:] == [
        "rmdrake: refused: the result contradicts its data (2 reasons)",
        f"  {reasons[0]}",
        f"  {reasons[1]}",
    ]
    assert _snapshot(inputs) == before


@pytest.mark.parametrize("command", ["calibrate", "identify"])
def test_force_reaches_the_pipeline(monkeypatch, capfd, inputs, command):
    seen = {}

    def pipeline(robot, data, out, **options):
        seen.update(options)
        return Path(out)

    monkeypatch.setattr(f"rmdrake.pipelines.{command}.{command}_file", pipeline)
    data = ["--measurements", str(inputs / "p.csv")]
    if command == "identify":
        data = ["--log", str(inputs / "log.csv")]
    argv = [command, "--robot", "rv3sb", *data, "--out", str(inputs / "x.yaml")]

    def force() -> bool:  # calibrate: in its CalibrationConfig
        return seen["config"].force if command == "calibrate" else seen["force"]

    assert main(argv) == 0 and force() is False
    assert main([*argv, "--force"]) == 0 and force() is True


@pytest.mark.parametrize("where", ["before", "after"])
def test_debug_shows_the_traceback_and_keeps_the_code(monkeypatch, capfd, where):
    monkeypatch.setattr(
        "rmdrake.model.loading.load_robot", _raise(ZeroDivisionError("boom"))
    )
    argv = ["show", "--robot", "rv3sb"]
    assert main(["--debug", *argv] if where == "before" else [*argv, "--debug"]) == 1
    err = capfd.readouterr().err.strip().splitlines()
    assert err[0] == "Traceback (most recent call last):"
    assert "ZeroDivisionError: boom" in err[-2]
    assert err[-1].startswith("rmdrake: internal error: ZeroDivisionError: boom")


def test_run_interrupted_says_the_written_files_are_whole(monkeypatch, capfd, tmp_path):
    monkeypatch.setattr(
        "rmdrake.studies.runner.run_scenario", _raise(KeyboardInterrupt())
    )
    assert main(["run", "--scenario", "paper_smoke", "--out", str(tmp_path)]) == 130
    assert _one_line(capfd) == (
        f"rmdrake: interrupted; the files written in {tmp_path} are whole"
    )


def test_ctrl_c_exits_130_with_one_line_and_no_file(tmp_path):
    """A real SIGINT to the console script in the middle of an excitation design."""
    out = tmp_path / "e.yaml"
    argv = [sys.executable, "-m", "rmdrake.cli", "excite", "--robot", "rv3sb"]
    proc = subprocess.Popen(
        [*argv, "--out", str(out), "--max-time", "60"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    err = ""
    try:
        while "%)" not in err:  # the DE's progress line: its generations run
            err += proc.stderr.read(16)
            assert proc.poll() is None, "excite ended before the interrupt"
        proc.send_signal(signal.SIGINT)
        err += proc.stderr.read()
        assert proc.wait(timeout=30) == 130
    finally:
        proc.kill()
    assert err.strip().splitlines()[-1] == "rmdrake: interrupted; nothing written"
    assert "Traceback" not in err and not out.exists()


# ---- the atomic writer ---------------------------------------------------------
def test_write_protected_file_is_not_replaced(tmp_path):
    path = tmp_path / "ro.yaml"
    path.write_text("keep me\n")
    path.chmod(0o444)
    with pytest.raises(ValueError, match=r"ro.yaml: is write-protected"):
        atomic_write_text(path, "new")
    assert path.read_text() == "keep me\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o444
    assert [p.name for p in tmp_path.iterdir()] == ["ro.yaml"]


def test_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("old")
    path.chmod(0o640)
    atomic_write_bytes(path, b"new")
    assert path.read_bytes() == b"new"
    assert stat.S_IMODE(path.stat().st_mode) == 0o640


def test_failed_write_leaves_target_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "x.csv"
    path.write_text("old")

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(ValueError, match=r"x.csv: cannot write: No space left"):
        atomic_write_text(path, "new")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["x.csv"]


@pytest.mark.parametrize(
    "target, message",
    [
        ("folder", r"folder: is a folder, expected a file name"),
        ("file/x.csv", r"file/x.csv: cannot write: a folder on its path is a file"),
    ],
)
def test_unwritable_targets_are_one_line_value_errors(tmp_path, target, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match=message):
        atomic_write_text(tmp_path / target, "new")
    assert (tmp_path / "file").read_text() == "x"
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["file", "folder"]
