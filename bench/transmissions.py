"""Transmissions (issue 41): the coupled-wrist oracle figures.

    OPENBLAS_NUM_THREADS=1 python bench/transmissions.py [--quick] [--noise 0.05]

The shipped illustrative ``rv3sb_geared`` (RV-3SB with gear ratios 100, 100,
100, 80, 80, 50 and a coupled wrist: motor 6 turns at q5 + q6) is

1. checked in Drake: its discrete plant (the coupled motor as a chain of
   coupler-constrained joints carrying its rotor) has, restricted to the arm's
   joints, the inverse dynamics of the regressor with the coupled motor's
   Iam (relative difference, 8 random states);
2. simulated noise-free on the discrete station stepping at 1, 2, 4 and 8 kHz
   (Drake's coupler constraints converge as the step shrinks), then
3. at simulate's COUPLED_RATE (4 kHz) along a random Fourier trajectory
   (seed 3, 150 Hz), noise-free and with Gaussian torque noise of ``--noise``
   N m on every joint (seed 1); each log is written on the motor side
   (t, qm, taum, qdm, qddm), read back through the transmission, taken at the
   step's start (q - h qd, qd - h qdd: the discrete plant's rigid-body
   identity, ``rmdrake.systems.station``) and kept where every Coulomb term
   (the joints' and the coupled motor's) is saturated at both ends of the
   step;
   identified by ordinary least squares on the first 70 % of those samples,
   with the coupled motor (55 base parameters) and without it (the serial
   model, 52), and each model's prediction error on the last 30 % (held out)
   printed per joint, RMS in N m, next to the noise.

One period (10 s, 1500 samples) per run, half of one with ``--quick``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def plant_oracle(model) -> float:
    """Relative max difference of the plant's and the regressor's efforts."""
    import re

    from pydrake.multibody.tree import JointIndex, MultibodyForces

    from rmdrake.dynamics import regressor
    from rmdrake.model.dynamic_parameters import extended_parameters
    from rmdrake.model.plant import MakePlant

    plant, _ = MakePlant(model, time_step=1e-3, visual=False)
    C = model.transmission.coupling
    G = np.zeros((plant.num_positions(), model.n_joints))
    for i in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(i))
        if m := re.fullmatch(r"joint(\d+)", joint.name()):
            G[joint.position_start(), int(m[1]) - 1] = 1.0
        elif m := re.fullmatch(r"motor(\d+)_joint(\d+)", joint.name()):
            G[joint.position_start(), int(m[2]) - 1] = C[int(m[1]) - 1, int(m[2]) - 1]
    ctx = plant.CreateDefaultContext()
    q, qd, qdd = np.random.default_rng(4).uniform(-2, 2, (3, 8, 6))
    ref = []
    for a, v, acc in zip(q, qd, qdd, strict=True):
        plant.SetPositions(ctx, G @ a)
        plant.SetVelocities(ctx, G @ v)
        f = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, f)
        ref.append(G.T @ plant.CalcInverseDynamics(ctx, G @ acc, f))
    chi = extended_parameters(model)
    n = model.n_joints
    chi[11 : 13 * n : 13] = chi[12 : 13 * n : 13] = 0.0
    chi[13 * n : 15 * n] = 0.0
    chi[-2:] = 0.0
    tau = regressor(model, q, qd, qdd, np.arange(chi.size)) @ chi
    return float(np.abs(tau - np.array(ref)).max() / np.abs(np.array(ref)).max())


def station_samples(model, periods: float, noise: float, folder: str, rate: float):
    """The motor-side log of one run on a station stepping at ``rate`` Hz or
    more, read back, at the step's start, on the saturated samples:
    (JointSamples, samples kept, share kept, wall s)."""
    from rmdrake.dynamics.data import JointSamples
    from rmdrake.dynamics.joint_log import read_joint_log, write_joint_log
    from rmdrake.excitation.random import random_fourier_trajectory
    from rmdrake.systems.station import MakeStation, RunStation
    from rmdrake.systems.station_config import (
        DEFAULT_LOG_PERIOD,
        SensorConfig,
        StationConfig,
        discrete_time_step,
    )

    traj = random_fourier_trajectory(model, seed=3)
    config = StationConfig(time_step=discrete_time_step(DEFAULT_LOG_PERIOD, rate))
    config.sensors = SensorConfig(torque_noise=noise, seed=1)
    t0 = time.perf_counter()
    station = MakeStation(
        config, true_model=model, trajectory=traj, nominal_model=model
    )
    log = RunStation(station, periods=periods)
    wall = time.perf_counter() - t0
    path = write_joint_log(
        os.path.join(folder, f"motor_{noise:g}.csv"), log, model.transmission
    )
    back = read_joint_log(path, model.n_joints, transmission=model.transmission)
    h = config.time_step
    q0, v0 = back.q - h * back.qd, back.qd - h * back.qdd
    c = model.transmission.coupling[list(model.coupled_motors)].T  # (n, k)
    speeds = [np.hstack([v, v @ c]) for v in (back.qd, v0)]
    keep = np.all((np.abs(speeds[0]) > 0.01) & (speeds[0] * speeds[1] > 0), axis=1)
    keep &= np.all(np.abs(speeds[1]) > 0.01, axis=1)
    rate = 1.0 / config.log_period
    samples = JointSamples(
        back.t[keep], q0[keep], v0[keep], back.qdd[keep], back.tau[keep], rate
    )
    return samples, int(keep.sum()), float(keep.mean()), wall


def heldout_rms(model, samples) -> tuple[np.ndarray, int]:
    """OLS on the first 70 %, RMS prediction error per joint on the rest."""
    from rmdrake.dynamics.data import JointSamples
    from rmdrake.dynamics.identification import identify

    k = int(0.7 * samples.n_samples)

    def part(s: slice) -> JointSamples:
        return JointSamples(
            samples.t[s], samples.q[s], samples.qd[s], samples.qdd[s],
            samples.tau[s], samples.rate,
        )  # fmt: skip

    fit, held = part(slice(0, k)), part(slice(k, None))
    result = identify(model, fit, method="ols")
    err = result.predict(model, held) - held.tau
    return np.sqrt(np.mean(err**2, axis=0)), result.base.count


def main() -> None:
    from rmdrake.model.loading import load_robot

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="half a period per run")
    p.add_argument("--noise", type=float, default=0.05, help="torque std, N m")
    args = p.parse_args()
    periods = 0.5 if args.quick else 1.0
    model = load_robot("rv3sb_geared")
    serial = dataclasses.replace(model, transmission=None, motor_terms=None)
    print(f"1. Drake plant vs regressor (coupled wrist): {plant_oracle(model):.2e}")
    from rmdrake.systems.station_config import CONTROL_RATE, COUPLED_RATE

    with tempfile.TemporaryDirectory() as folder:
        print("\n2. noise-free, held-out RMS over effort RMS per joint, by step rate:")
        for k in (1, 2, 4, 8):
            rate = k * CONTROL_RATE
            samples, kept, _, wall = station_samples(model, periods, 0.0, folder, rate)
            scale = np.sqrt(np.mean(samples.tau**2, axis=0))
            rms, nb = heldout_rms(model, samples)
            mark = " (simulate's COUPLED_RATE)" if rate == COUPLED_RATE else ""
            print(f"   {rate:6g} Hz, {wall:4.1f} s wall: " + _row(rms / scale) + mark)
        for noise in (0.0, args.noise):
            samples, kept, share, wall = station_samples(
                model, periods, noise, folder, COUPLED_RATE
            )
            scale = np.sqrt(np.mean(samples.tau**2, axis=0))
            print(
                f"\n3. station run at {COUPLED_RATE:g} Hz, torque noise {noise:g} N m: "
                f"{kept} saturated samples ({100 * share:.0f} %), {wall:.1f} s wall"
            )
            print("   effort RMS [N m]:         " + _row(scale))
            for label, m in (("coupled", model), ("serial", serial)):
                rms, nb = heldout_rms(m, samples)
                print(f"   held-out RMS {label:7s} ({nb}) [N m]: " + _row(rms))
                if noise > 0:
                    print("     / noise:                 " + _row(rms / noise))


def _row(v: np.ndarray) -> str:
    return "  ".join(f"{x:9.3g}" for x in v)


if __name__ == "__main__":
    main()
