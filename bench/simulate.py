"""Station speed: simulating one 10 s period of a Fourier excitation at 150 Hz.

For each robot (default rv3sb and demo_rh): a "true" robot (each link's inertial
parameters scaled by one factor in [0.85, 1.15], Ia, fv, fc by [0.8, 1.2], seeded)
under the default controller on the shipped nominal model, following a seeded
eq. 17-feasible trajectory (5 harmonics, 0.1 Hz, half the limits), logging at
150 Hz. Printed per robot: build time; best wall and CPU time of
:func:`rmdrake.systems.RunStation` over ``--repeats`` runs; integrator steps and
derivative evaluations; the torque-oracle residual max |tau_log - Y @ chi_true| /
max |tau| (smooth sign in the regressor, see tests/systems/test_station.py); tracking
error. With ``--cli`` also the end-to-end wall time of the ``rmdrake simulate``
command (process start, imports, YAML, simulation, CSV write). Run:

    OPENBLAS_NUM_THREADS=1 python bench/simulate.py [--robots rv3sb demo_rh]
        [--repeats 3] [--accuracy 1e-4] [--cli]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402

import rmdrake.systems.station as station_module  # noqa: E402
from rmdrake import load_robot, random_fourier_trajectory  # noqa: E402
from rmdrake.dynamics import SerialChain, regressor, standard_parameters  # noqa: E402
from rmdrake.dynamics.friction import DEFAULT_V_EPS  # noqa: E402
from rmdrake.systems import MakeStation, RunStation  # noqa: E402
from rmdrake.systems.station_config import StationConfig  # noqa: E402


def perturbed(model, seed: int):
    rng = np.random.default_rng(seed)
    d = np.array(model.dynamics)
    d[:, :10] *= rng.uniform(0.85, 1.15, (model.n_joints, 1))
    d[:, 10:] *= rng.uniform(0.8, 1.2, (model.n_joints, 3))
    return model.with_dynamics(d)


class _CountingSimulator(Simulator):
    """Keeps the last Simulator RunStation made, to read integrator counts."""

    last: Simulator | None = None

    def __init__(self, *args) -> None:
        super().__init__(*args)
        _CountingSimulator.last = self


def bench_robot(name: str, repeats: int, accuracy: float, cli: bool) -> None:
    nominal = load_robot(name)
    true = perturbed(nominal, seed=2)
    traj = random_fourier_trajectory(nominal, seed=1, fill=0.5)
    t0 = time.perf_counter()
    config = StationConfig()
    config.simulator.accuracy = accuracy
    station = MakeStation(
        config, true_model=true, trajectory=traj, nominal_model=nominal
    )
    build = time.perf_counter() - t0
    wall, cpu = np.inf, np.inf
    station_module.Simulator = _CountingSimulator
    try:
        for _ in range(repeats):
            w0, c0 = time.perf_counter(), time.process_time()
            log = RunStation(station, periods=1.0)
            wall = min(wall, time.perf_counter() - w0)
            cpu = min(cpu, time.process_time() - c0)
    finally:
        station_module.Simulator = Simulator
    integrator = _CountingSimulator.last.get_integrator()
    Y = regressor(
        SerialChain.from_model(true),
        log.q,
        log.qd,
        log.qdd,
        coulomb_width=DEFAULT_V_EPS,
    )
    resid = np.abs(Y @ standard_parameters(true) - log.tau).max(0)
    rel = resid / np.abs(log.tau).max(0)
    err = np.degrees(np.abs(log.q - traj.q(log.t)).max(0))
    duration = traj.period
    steps = integrator.get_num_steps_taken()
    derivs = integrator.get_num_derivative_evaluations()
    smallest = integrator.get_smallest_adapted_step_size_taken()
    print(
        f"{name}: {duration:g} s at 150 Hz ({log.n_samples} samples), "
        f"accuracy {accuracy:g}"
    )
    print(
        f"  build {build * 1e3:.0f} ms; RunStation best of {repeats}: wall "
        f"{wall:.2f} s, CPU {cpu:.2f} s ({duration / wall:.2f}x real time)"
    )
    print(
        f"  integrator: {steps} steps, {derivs} derivative evaluations, "
        f"smallest step {smallest:.2e} s"
    )
    print(
        "  oracle max |tau - Y chi| / max |tau| per joint: "
        + " ".join(f"{r:.1e}" for r in rel)
    )
    print("  tracking error max [deg]: " + " ".join(f"{e:.3f}" for e in err))
    if cli:
        with tempfile.TemporaryDirectory() as tmp:
            robot = true.save(Path(tmp) / "true.yaml")
            tr = traj.save(Path(tmp) / "traj.yaml")
            cmd = [
                sys.executable, "-m", "rmdrake.cli", "simulate", "--robot",
                str(robot), "--trajectory", str(tr), "--out",
                str(Path(tmp) / "log.csv"), "--nominal", name,
            ]  # fmt: skip
            w0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            print(f"  rmdrake simulate end to end: {time.perf_counter() - w0:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["rv3sb", "demo_rh"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--accuracy", type=float, default=1e-4)
    parser.add_argument("--cli", action="store_true")
    args = parser.parse_args()
    print(
        f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs; "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}"
    )
    for name in args.robots:
        bench_robot(name, args.repeats, args.accuracy, args.cli)


if __name__ == "__main__":
    main()
