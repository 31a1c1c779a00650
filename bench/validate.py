"""``rmdrake validate`` speed on a long log: end to end under 2 s for 20 000 samples.

Writes (in a temporary folder) a 20 000-sample CSV log of the RV-3SB on a random
feasible Fourier trajectory, efforts from the regressor plus Gaussian noise of
1 % of each joint's effort RMS, with qd and qdd; the true robot and one with
every link 20 % too heavy as robot YAMLs. Then times, best of ``--repeats``:

* ``validate``: :func:`rmdrake.pipelines.validate.validate_file` end to end, i.e.
  load both robot YAMLs, read the CSV, prepare the samples as ``identify`` does,
  predict both robots' efforts, compute and print the figures (the target: < 2 s);
* ``plot``: the Fig. 7 PNG of the same run, timed separately (matplotlib);
* ``process``: the whole ``rmdrake validate`` command in a fresh Python process
  (interpreter start and imports included), once, for information.

Wall and CPU (``time.process_time``) times are printed with the load average,
then the figures of the last run. ``--quick`` (for CI): a 2 000-sample log,
best of 2 (the plot and the fresh process once each). Run:

    OPENBLAS_NUM_THREADS=1 python bench/validate.py [--samples 20000 --repeats 5]
    OPENBLAS_NUM_THREADS=1 python bench/validate.py --quick
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

from rmdrake.dynamics import standard_parameters  # noqa: E402
from rmdrake.dynamics.joint_log import JointLog, write_joint_log  # noqa: E402
from rmdrake.dynamics.regressor import torques  # noqa: E402
from rmdrake.excitation.design import random_fourier_trajectory  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.pipelines.validate import validate_file  # noqa: E402

TARGET = 2.0  # s, end to end without the plot


def write_case(folder: Path, samples: int) -> tuple[Path, list[Path]]:
    """The log and the two robot YAMLs (true, 20 % too heavy) in ``folder``."""
    model = load_robot("rv3sb")
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    t, q, qd, qdd = traj.sample(samples / traj.period)
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    std = 0.01 * np.sqrt(np.mean(tau**2, axis=0))
    tau = tau + np.random.default_rng(0).normal(0.0, std, tau.shape)
    log = write_joint_log(
        folder / "log.csv", JointLog(t=t, q=q, tau=tau, qd=qd, qdd=qdd)
    )
    dyn = np.array(model.dynamics)
    dyn[:, :10] *= 1.2
    robots = [model.save(folder / "true.yaml")]
    robots.append(model.with_dynamics(dyn).save(folder / "heavy.yaml"))
    return log, robots


def timed(fn, repeats: int) -> tuple[float, float]:
    """Best wall and CPU time of ``repeats`` calls, s."""
    wall = cpu = np.inf
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, help="log length (20000; quick 2000)")
    parser.add_argument("--repeats", type=int, help="timed runs (5; quick 2)")
    parser.add_argument("--quick", action="store_true", help="CI size")
    args = parser.parse_args()
    samples = args.samples or (2000 if args.quick else 20000)
    repeats = args.repeats or (2 if args.quick else 5)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        log, robots = write_case(folder, samples)
        lines: list[str] = []

        def run() -> None:
            lines.clear()
            validate_file(robots, log, echo=lines.append)

        def plot() -> None:
            validate_file(robots, log, plot=folder / "fig7.png", echo=lambda _: None)

        wall, cpu = timed(run, repeats)
        wall_p, cpu_p = timed(plot, max(1, repeats // 2))
        command = [sys.executable, "-m", "rmdrake.cli", "validate", "--log", str(log)]
        for r in robots:
            command += ["--robot", str(r)]
        w0 = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        wall_proc = time.perf_counter() - w0
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"rv3sb, {samples} samples, 2 robots; load average {load}")
    verdict = "ok" if wall < TARGET else "OVER"
    print(
        f"validate (load + prepare + predict + report): {wall:.3f} s wall, "
        f"{cpu:.3f} s CPU, best of {repeats}: {verdict} (< {TARGET:g} s)"
    )
    print(f"with the plot: {wall_p:.3f} s wall, {cpu_p:.3f} s CPU")
    print(f"whole command in a fresh process (imports included): {wall_proc:.2f} s")
    print()
    for line in lines:
        print(line)


if __name__ == "__main__":
    main()
