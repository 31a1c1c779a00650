"""Identification on a real robot: the Franka Emika Panda log of Gaz et al. (2019).

    python examples/real_panda.py [--data ../shared/data/panda_gaz2019] [--smoke]

The log (7 joints, about 1 kHz with irregular stamps, measured q, qd and joint
torques, no accelerations) is resampled to 1 kHz, low-passed at 10 Hz (zero
phase, torques alike) and differentiated for qdd. The first 70 % identify the
62 base parameters (13 standard parameters per link) with OLS, WLS and the
physically consistent fit (no dynamics prior: it regularises toward zero in the
directions the data cannot see); the last 30 % are predicted. Printed: per-joint
RMS torque error on the held-out part, and each method's worst ratio to OLS.
The data is read in place; it is never copied into the repository.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identify
from rmdrake.io import read_joint_log
from rmdrake.robot import load_robot

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared/data/panda_gaz2019"


def main(argv: list[str] | None = None) -> dict[str, np.ndarray]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data",
        type=Path,
        default=DEFAULT_DATA,
        help="folder with panda.yaml and trajectory1.csv",
    )
    parser.add_argument(
        "--smoke",
        action="store_true",
        help="resample at 200 Hz instead of 1 kHz (fast, for tests)",
    )
    args = parser.parse_args(argv)
    robot = args.data / "panda.yaml"
    log_path = args.data / "trajectory1.csv"
    if not robot.exists() or not log_path.exists():
        raise SystemExit(
            f"real_panda: expected panda.yaml and trajectory1.csv in {args.data}"
        )
    model = load_robot(robot)
    log = read_joint_log(log_path, n_joints=model.n_joints)
    rate = 200.0 if args.smoke else 1000.0
    samples = prepare_samples(
        log.t, log.q, log.tau, log.qd, log.qdd, rate=rate, cutoff=10.0
    )
    train, test = samples.split(0.7)
    print(
        f"Panda log: {log.t.size} samples over {log.t[-1] - log.t[0]:.1f} s; "
        f"{samples.n_samples} after preparation"
    )
    for note in samples.notes:
        print(f"  {note}")
    errors: dict[str, np.ndarray] = {}
    header = " ".join(f"{'tau' + str(j + 1):>7}" for j in range(model.n_joints))
    print(
        f"held-out RMS torque error [N m] (train {train.n_samples}, "
        f"test {test.n_samples} samples)"
    )
    print(f"{'method':>9} {'nb':>3} {header} {'time[s]':>8}")
    for method in ("ols", "wls", "physical"):
        t0 = time.perf_counter()
        result = identify(model, train, method=method)
        elapsed = time.perf_counter() - t0
        err = np.sqrt(np.mean((result.predict(model, test) - test.tau) ** 2, axis=0))
        errors[method] = err
        row = " ".join(f"{e:7.3f}" for e in err)
        print(f"{method:>9} {result.base.count:>3} {row} {elapsed:8.2f}")
    for method in ("wls", "physical"):
        ratio = float(np.max(errors[method] / errors["ols"]))
        print(f"{method}: worst per-joint ratio to OLS {ratio:.3f} (target <= 1.2)")
    return errors


if __name__ == "__main__":
    main()
