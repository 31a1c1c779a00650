"""Time and peak memory of the data-sized commands against the input size N,
and the largest N each handles in 24 GB. Run:

    OPENBLAS_NUM_THREADS=1 python bench/scaling.py            # N = 1e3 .. 1e6
    OPENBLAS_NUM_THREADS=1 python bench/scaling.py --quick    # N = 1e3, 1e4

Commands and their N (inputs written first by the project's own seeded
simulation functions, into a temporary folder unless ``--keep DIR``):

* ``calibrate-plates``: ``rmdrake calibrate --method lm --params paper`` on N
  range-finder readings of a perturbed RV-3SB (``perturb_robot``, seed 1, the
  paper's 17 errors; ``simulate_plates``, 5 plates x N/5 readings,
  ``selection="first"``, seed 1). ``--params auto`` (the default) fits about
  85 candidate sets for its cross-validation: the same slope in memory, about
  20 times the time.
* ``calibrate-points``: ``rmdrake calibrate --params full`` on N tracker
  points (``simulate_points``: N/3 poses x 3 markers, seed 1).
* ``correct``: ``rmdrake correct --allow-unreachable`` of a nominal joint
  program of N well-conditioned poses (``random_point_poses``, seed 0) for
  the robot calibrated from the 1e3 plate readings above.
* ``correct-targets``: the same with the program's tool poses as
  ``x,y,z,roll,pitch,yaw`` targets (the nominal multi-start IK first: 16
  times the IK work; up to ``--targets-max`` = 1e5 by default).
* ``validate`` and ``identify``: ``rmdrake validate`` (the true dynamics) and
  ``rmdrake identify`` (default method) on an N-sample NPZ log at 150 Hz of
  the RV-3SB on a random feasible Fourier trajectory (seed 4), efforts from
  the regressor plus 1 % Gaussian noise (seed 0), as ``bench/validate.py``.

Each point runs the command in its own subprocess (``os.wait4``: wall time
and the child's own peak resident memory, ``ru_maxrss``), ``--repeats``
times (the best time and the largest peak are printed); the inputs are made
in other subprocesses, so that this one stays small (a child's peak counts
the memory of the process it was started from). Per command, a line
gives the memory and time slopes between its two largest N and the largest N
whose extrapolated peak fits in 24 GB (2^30 bytes per GB), with the time
there. The load average is printed: on 2 shared cores, time figures move
with it; memory does not.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

SIZES = (10**3, 10**4, 10**5, 10**6)
QUICK = (10**3, 10**4)
BUDGET = 24 * 2**30  # bytes
RMDRAKE = [sys.executable, "-m", "rmdrake.cli"]


def _true_robot():
    """The perturbed RV-3SB of the calibration inputs (paper's 17 errors,
    0.5 mm / 1 mrad, seed 1)."""
    from rmdrake.model.loading import load_robot
    from rmdrake.model.perturb import perturb_robot

    nominal = load_robot("rv3sb")
    return perturb_robot(nominal, length_std=5e-4, angle_std=1e-3, seed=1)[0]


def make_plates(folder: Path, n: int) -> list[str]:
    from rmdrake.calibration.plates.data import write_plane_measurements
    from rmdrake.calibration.plates.simulate import simulate_plates

    path = folder / f"plates_{n}.csv"
    if not path.exists():
        sim = simulate_plates(
            _true_robot(), plates=5, per_plate=n // 5, seed=1, selection="first"
        )
        write_plane_measurements(path, sim.data)
    out = folder / f"plates_{n}.yaml"
    return ["calibrate", "--robot", "rv3sb", "--measurements", str(path)] + [
        "--out", str(out), "--method", "lm", "--params", "paper", "--no-progress"
    ]  # fmt: skip


def make_points(folder: Path, n: int) -> list[str]:
    from rmdrake.calibration.points.data import write_point_measurements
    from rmdrake.calibration.points.simulate import simulate_points

    path = folder / f"points_{n}.csv"
    if not path.exists():
        sim = simulate_points(_true_robot(), poses=n // 3, markers=3, seed=1)
        write_point_measurements(path, sim.data)
    out = folder / f"points_{n}.yaml"
    return ["calibrate", "--robot", "rv3sb", "--measurements", str(path)] + [
        "--out", str(out), "--params", "full"
    ]  # fmt: skip


def _calibrated(folder: Path) -> Path:
    """A robot calibrated from 1e3 plate readings (made once)."""
    path = folder / "plates_1000.yaml"
    if not path.exists():
        argv = make_plates(folder, 1000)
        subprocess.run([*RMDRAKE, *argv], check=True, capture_output=True)
    return path


def _poses(n: int) -> np.ndarray:
    from rmdrake.calibration.points.simulate import random_point_poses
    from rmdrake.model.loading import load_robot

    return random_point_poses(load_robot("rv3sb"), n, np.random.default_rng(0))


def make_program(folder: Path, n: int) -> list[str]:
    from rmdrake.compensation.programs import JointProgram, write_joint_program

    path = folder / f"program_{n}.csv"
    if not path.exists():
        write_joint_program(path, JointProgram(_poses(n)))
    return ["correct", "--robot", str(_calibrated(folder)), "--targets"] + [
        str(path), "--out", str(folder / f"corrected_{n}.csv"), "--allow-unreachable"
    ]  # fmt: skip


def make_targets(folder: Path, n: int) -> list[str]:
    from rmdrake.compensation.programs import ToolTargets, write_tool_targets
    from rmdrake.kinematics.forward import tool_poses
    from rmdrake.kinematics.rotations import rpy_from_rotation
    from rmdrake.model.loading import load_robot

    path = folder / f"targets_{n}.csv"
    if not path.exists():
        model = load_robot("rv3sb")
        X = tool_poses(model.table, _poses(n), sigma=model.sigma)
        rpy = rpy_from_rotation(X[:, :3, :3])
        write_tool_targets(path, ToolTargets(X[:, :3, 3], rpy))
    return ["correct", "--robot", str(_calibrated(folder)), "--targets"] + [
        str(path), "--out", str(folder / f"solved_{n}.csv"), "--allow-unreachable"
    ]  # fmt: skip


def _log(folder: Path, n: int) -> tuple[Path, Path]:
    """The N-sample NPZ log and the true robot's YAML (made once per N)."""
    from rmdrake.dynamics import standard_parameters
    from rmdrake.dynamics.joint_log import JointLog, write_joint_log
    from rmdrake.dynamics.regressor import torques
    from rmdrake.excitation.design import random_fourier_trajectory
    from rmdrake.model.loading import load_robot

    model = load_robot("rv3sb")
    robot, path = folder / "dynamics_true.yaml", folder / f"log_{n}.npz"
    if not robot.exists():
        model.save(robot)
    if path.exists():
        return path, robot
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    rate = 150.0
    t, q, qd, qdd = traj.sample(rate, periods=n * traj.base_frequency / rate)
    params = standard_parameters(model)
    tau = np.concatenate(  # the regressor chunk by chunk: samples are independent
        [
            torques(
                model, q[a : a + 65536], qd[a : a + 65536], qdd[a : a + 65536], params
            )  # fmt: skip
            for a in range(0, t.size, 65536)
        ]
    )
    std = 0.01 * np.sqrt(np.mean(tau**2, axis=0))
    tau += np.random.default_rng(0).normal(0.0, std, tau.shape)
    write_joint_log(path, JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd))
    return path, robot


def make_validate(folder: Path, n: int) -> list[str]:
    log, robot = _log(folder, n)
    return ["validate", "--robot", str(robot), "--log", str(log)]


def make_identify(folder: Path, n: int) -> list[str]:
    log, _ = _log(folder, n)
    out = folder / f"identified_{n}.yaml"
    return ["identify", "--robot", "rv3sb", "--log", str(log), "--out", str(out)]


CASES: dict[str, tuple[str, Callable[[Path, int], list[str]]]] = {
    "calibrate-plates": ("readings", make_plates),
    "calibrate-points": ("points", make_points),
    "correct": ("program rows", make_program),
    "correct-targets": ("tool targets", make_targets),
    "validate": ("log samples", make_validate),
    "identify": ("log samples", make_identify),
}


def make_inputs(
    points: list[tuple[str, int]], folder: Path
) -> list[tuple[list[str], float]]:
    """(the command's argv, seconds to make its input) of each (command, N)
    of ``points``, made in one child process: this process stays small, since
    Linux counts the resident memory of the process that starts a child in
    the child's peak (the address space it forks from)."""
    out = subprocess.run(
        [sys.executable, __file__, "--make", json.dumps(points), str(folder)],
        check=True,
        capture_output=True,
        text=True,
    )
    return [(argv, made) for argv, made in json.loads(out.stdout.splitlines()[-1])]


def _make_all(points: list[tuple[str, int]], folder: Path) -> None:
    """Prints (argv, seconds) of each (command, N) of ``points`` as JSON, its
    input written in ``folder`` (the child of :func:`make_inputs`)."""
    made = []
    for name, n in points:
        t0 = time.perf_counter()
        argv = CASES[name][1](folder, n)
        made.append((argv, time.perf_counter() - t0))
    print(json.dumps(made))


def measure(argv: list[str]) -> tuple[float, float, int]:
    """(wall s, peak resident MB, exit status) of ``rmdrake argv`` in a child
    process (its own ``ru_maxrss``, from ``os.wait4``)."""
    t0 = time.perf_counter()
    child = subprocess.Popen(
        [*RMDRAKE, *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - t0
    child.returncode = os.waitstatus_to_exitcode(status)
    err = child.stderr.read().decode(errors="replace").strip().splitlines()
    child.stderr.close()
    if child.returncode:
        print(f"    exit {child.returncode}: {err[-1] if err else ''}", flush=True)
    return wall, usage.ru_maxrss / 1024, child.returncode  # kB on Linux


def largest_fitting(sizes: list[int], mb: list[float], wall: list[float]) -> str:
    """The line of one command: slopes between its two largest N and the
    largest N whose linearly extrapolated peak fits :data:`BUDGET`."""
    if len(sizes) < 2:
        return "one size only: no slope"
    (n0, n1), (m0, m1), (t0, t1) = sizes[-2:], mb[-2:], wall[-2:]
    slope = (m1 - m0) / (n1 - n0)  # MB per item
    rate = (t1 - t0) / (n1 - n0)  # s per item
    if slope <= 0:
        return f"memory flat between N = {n0:.0e} and {n1:.0e}: no bound found"
    n_max = n1 + (BUDGET / 2**20 - m1) / slope
    t_max = t1 + rate * (n_max - n1)
    there = f" (about {t_max:.3g} s there)" if rate > 0 else ""
    return (
        f"{slope * 1e3:.3g} kB per item, {rate * 1e6:.3g} us per item: "
        f"24 GB at N = {n_max:.3g}{there}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e3, 1e4")
    parser.add_argument("--sizes", help="comma-separated N (default 1e3..1e6)")
    parser.add_argument("--commands", help=f"subset of {','.join(CASES)}")
    parser.add_argument(
        "--targets-max", type=float, default=1e5, help="largest N of correct-targets"
    )
    parser.add_argument(
        "--repeats", type=int, default=1, help="runs per point: best time, max peak"
    )
    parser.add_argument("--keep", type=Path, help="folder for the inputs (kept)")
    parser.add_argument("--make", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.make:  # the child of make_inputs()
        points = [(c, int(n)) for c, n in json.loads(args.make[0])]
        _make_all(points, Path(args.make[1]))
        return
    sizes = [int(float(s)) for s in args.sizes.split(",")] if args.sizes else None
    sizes = sizes or list(QUICK if args.quick else SIZES)
    names = args.commands.split(",") if args.commands else list(CASES)
    if args.quick and not args.commands:
        names.remove("correct-targets")  # 16 IK starts per target: not quick
    print(f"load average {os.getloadavg()[0]:.2f}; N = {sizes}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        summary = []
        points = [
            (name, n)
            for name in names
            for n in sizes
            if name != "correct-targets" or n <= args.targets_max
        ]
        inputs = dict(zip(points, make_inputs(points, folder), strict=True))
        for name in names:
            unit = CASES[name][0]
            done: tuple[list[int], list[float], list[float]] = ([], [], [])
            for n in sizes:
                if (name, n) not in inputs:
                    continue
                argv, made = inputs[name, n]
                runs = [measure(argv) for _ in range(args.repeats)]
                wall = min(r[0] for r in runs)
                mb = max(r[1] for r in runs)
                code = max(r[2] for r in runs)
                print(
                    f"{name:17} N = {n:>9,} {unit}: {wall:8.2f} s, peak {mb:8.0f} MB"
                    f" (input made in {made:.1f} s)",
                    flush=True,
                )
                if code == 0:
                    for values, v in zip(done, (n, mb, wall), strict=True):
                        values.append(v)
            summary.append(f"{name:17} {largest_fitting(*done)}")
    total = time.perf_counter() - start
    print(f"load average {os.getloadavg()[0]:.2f}; total {total:.1f} s")
    print("\n".join(summary))


if __name__ == "__main__":
    main()
