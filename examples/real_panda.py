"""Identification on a real robot: the Franka Emika Panda log of Gaz et al. (2019).

    python examples/real_panda.py [--data ../shared/data/panda_gaz2019] [--smoke]

The log (7 joints, about 1 kHz with irregular stamps, measured q, qd and joint
torques, no accelerations) is resampled to 1 kHz, low-passed at 10 Hz (zero
phase, torques alike) and differentiated for qdd. The first 70 % identify the
62 base parameters (13 standard parameters per link) with OLS, WLS and the
physically consistent fit; the last 30 % are predicted. Printed: per-joint
RMS torque error on the held-out part, and each method's worst ratio to OLS.

A joint-torque sensor measures after the gearbox, so it does not see the
rotors, and it has a bias per joint: the methods are run again with the terms
of such an arm (``--terms no-rotor,offset``: no Ia, a constant offset per
joint; :class:`rmdrake.robot.DynamicTerms`), printed as ``ols/sensor`` etc.
next to the default terms (Ia, fv, fc). Measured at 1 kHz: the offsets take
joint 1 from 0.220 to 0.147 N m, joint 3 from 0.168 to 0.143 and joint 6 from
0.101 to 0.076 (mean 0.143 -> 0.126 N m with OLS), while joint 5 loses
(0.060 -> 0.070: its rotor-inertia column helped there).

The log comes with no dynamics prior (panda.yaml has kinematics only), so the
physical fit is run twice: unbounded (it settles wherever the data leave the
masses free: 60-90 kg in all for an 18 kg arm) and with mass bounds, the
honest route without CAD inertials: every link within [0.2, 10] kg and the
total within the arm's published 18 kg +- 50 % ([9, 27] kg). Its link masses
are printed next to Gaz et al.'s published ones (4.97, 0.65, 3.23, 3.59, 1.23,
1.67, 0.74 kg). The data is read in place; it is never copied into the
repository.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identify
from rmdrake.io import read_joint_log
from rmdrake.robot import DynamicTerms, load_robot

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared/data/panda_gaz2019"
PUBLISHED_MASSES = np.array([4.97, 0.65, 3.23, 3.59, 1.23, 1.67, 0.74])  # kg
BOUNDS = dict(mass_bounds=(0.2, 10.0), total_mass=(9.0, 27.0))  # kg
SENSOR = DynamicTerms(rotor_inertia=False, offset=True)  # a torque-sensing arm


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
    print(f"{'method':>15} {'nb':>3} {header} {'time[s]':>8}")
    masses = {}
    for name, method, options in (
        ("ols", "ols", {}),
        ("wls", "wls", {}),
        ("physical", "physical", {}),
        ("bounded", "physical", BOUNDS),
        ("ols/sensor", "ols", dict(terms=SENSOR)),
        ("wls/sensor", "wls", dict(terms=SENSOR)),
        ("bounded/sensor", "physical", dict(BOUNDS, terms=SENSOR)),
    ):
        t0 = time.perf_counter()
        result = identify(model, train, method=method, **options)
        elapsed = time.perf_counter() - t0
        err = np.sqrt(np.mean((result.predict(model, test) - test.tau) ** 2, axis=0))
        errors[name] = err
        if method == "physical":
            masses[name] = result.chi[9 : 13 * model.n_joints : 13]
        row = " ".join(f"{e:7.3f}" for e in err)
        print(f"{name:>15} {result.base.count:>3} {row} {elapsed:8.2f}")
    print(f"terms: default {DynamicTerms()}; sensor {SENSOR}")
    for name in ("wls", "physical", "bounded", "ols/sensor", "wls/sensor"):
        ratio = float(np.max(errors[name] / errors["ols"]))
        print(f"{name}: worst per-joint ratio to OLS {ratio:.3f}")
    print("link masses [kg] (bounded: each in 0.2..10, total in 9..27)")
    print(f"{'published':>15} " + " ".join(f"{m:7.2f}" for m in PUBLISHED_MASSES))
    for name, m in masses.items():
        factor = np.max(np.maximum(m / PUBLISHED_MASSES, PUBLISHED_MASSES / m))
        row = " ".join(f"{v:7.2f}" for v in m)
        print(f"{name:>15} {row}  total {m.sum():6.2f}, worst factor {factor:.3g}")
    return errors


if __name__ == "__main__":
    main()
