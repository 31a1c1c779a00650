"""The evidence a wrong robot, joint order, sign, unit or time base leaves in a
real torque log: the figures that the identification's sanity rule is tuned on.

For every real log in ``../shared/data`` (the Panda of Gaz et al. 2019; the KUKA
LWR4+ runs 1-3 of FloBaRoID) and for wrong variants made from each (the two
joints with the largest torque swapped, the largest negated, the torques in
N mm, the torque 0.3 s late, the other arm's model), prepared as ``identify``
prepares them and fitted by ordinary least squares on the base parameters, it
prints per joint:

* ``load``: the joint's torque RMS over the largest joint's;
* ``held``: RMS of the held-out residual (the fit of the first 70 % predicting
  the rest) over the joint's own torque RMS, %;
* ``flip``: the whole-log residual with the joint's torque negated over the
  logged one;

and per case: ``U``, the held-out residual over the torque in energy over all
joints, sqrt(sum e_j^2 / sum rms_j^2), %; ``lag``, the time shift of the torque
against the motion (-0.5 .. 0.5 s) whose fit leaves the least energy, and the
ratio of that energy to the unshifted fit's; ``outside``, the share of samples
whose joint positions leave the model's limits; ``effort``, the largest
99th-percentile |torque| over the joint's effort limit; and whether today's
checks (:func:`~rmdrake.dynamics.sanity.check_torque_log` and
:func:`~rmdrake.dynamics.sanity.check_identification`) refuse the OLS fit.

Run:

    python bench/identification_sanity.py           # every log
    python bench/identification_sanity.py --quick   # LWR4 run 1 only
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.dynamics.base import BaseParameters  # noqa: E402
from rmdrake.dynamics.data import JointSamples, prepare_samples  # noqa: E402
from rmdrake.dynamics.identification import identify  # noqa: E402
from rmdrake.dynamics.joint_log import JointLog, read_joint_log  # noqa: E402
from rmdrake.dynamics.sanity import (  # noqa: E402
    check_identification,
    check_torque_log,
)
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.model.robot import RobotModel  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LWR4 = DATA / "lwr4_flobaroid"
PANDA = DATA / "panda_gaz2019"
LAGS = np.arange(-0.5, 0.5001, 0.02)  # s
LATE = 0.3  # s, the late variant's shift


def lwr4_log(run: int) -> JointLog:
    d = np.load(LWR4 / f"measurements_{run}.npz")
    t = d["times"] - d["times"][0]
    return JointLog(t=t, q=d["positions"], tau=d["torques"], qd=d["velocities"])


def variants(log: JointLog) -> dict[str, JointLog]:
    """The log and its wrong variants (module docstring)."""
    rms = np.sqrt(np.mean(log.tau**2, axis=0))
    a, b = np.argsort(-rms)[:2]
    swapped, negated = log.tau.copy(), log.tau.copy()
    swapped[:, [a, b]] = swapped[:, [b, a]]
    negated[:, a] *= -1
    late = np.stack(
        [np.interp(log.t - LATE, log.t, c) for c in log.tau.T], axis=1
    )  # the torque of t - LATE logged at t
    keep = log.t >= log.t[0] + LATE
    return {
        "clean": log,
        f"swap {a + 1}-{b + 1}": dataclasses.replace(log, tau=swapped),
        f"negated {a + 1}": dataclasses.replace(log, tau=negated),
        "N mm": dataclasses.replace(log, tau=1e3 * log.tau),
        f"{LATE:g} s late": JointLog(
            t=log.t[keep],
            q=log.q[keep],
            tau=late[keep],
            qd=None if log.qd is None else log.qd[keep],
        ),
    }


def best_lag(
    model: RobotModel, base: BaseParameters, s: JointSamples
) -> tuple[float, float]:
    """(lag, ratio): the shift of the torque against the motion, s, whose
    least-squares fit of the ``base`` parameters leaves the least residual
    energy, and that energy over the unshifted fit's (on the rows every shift
    keeps)."""
    Y = base.regressor(model, s.q, s.qd, s.qdd)  # (N, n, nb)
    k_max = int(round(LAGS.max() * s.rate))
    N = s.n_samples
    rows = slice(k_max, N - k_max)
    A = Y[rows].reshape(-1, Y.shape[2])
    energy = []
    for lag in LAGS:
        k = int(round(lag * s.rate))
        b = s.tau[k_max + k : N - k_max + k].reshape(-1)  # torque k samples later
        x = np.linalg.lstsq(A, b, rcond=None)[0]
        energy.append(float(np.sum((A @ x - b) ** 2)))
    energy = np.array(energy)
    zero = energy[np.argmin(np.abs(LAGS))]
    i = int(np.argmin(energy))
    return float(LAGS[i]), float(energy[i] / zero)


def report(name: str, model: RobotModel, log: JointLog, **options) -> None:
    # prepare_logs' preparation of a log, without the file
    s = prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd, **options)
    result = identify(model, s, method="ols")
    sanity = check_identification(result)
    rms = np.sqrt(np.mean(s.tau**2, axis=0))
    held = sanity.heldout_rms
    U = np.sqrt(np.sum(held**2) / np.sum(rms**2))
    lag, ratio = best_lag(model, result.base, s)
    lim = model.limits
    outside = np.mean(np.any((s.q < lim.lower) | (s.q > lim.upper), axis=1))
    effort = np.percentile(np.abs(s.tau), 99, axis=0) / np.asarray(lim.effort)
    refused = sanity.reasons or check_torque_log(s.tau, lim.effort)
    print(
        f"{name:<34} U {100 * U:5.1f} %  lag {lag:+.2f} s ({ratio:.2f}x)  "
        f"outside {100 * outside:4.1f} %  effort {effort.max():.3g}x  "
        f"refused today (ols): {'yes' if refused else 'no'}"
    )
    for label, values, fmt in (
        ("load", rms / rms.max(), "{:6.2f}"),
        ("held %", 100 * held / rms, "{:6.1f}"),
        ("flip", sanity.flip_ratio, "{:6.2f}"),
    ):
        print(f"    {label:<7}" + "".join(fmt.format(v) for v in values))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="LWR4 run 1 only")
    args = parser.parse_args()
    if not LWR4.is_dir() or not PANDA.is_dir():
        print(f"the real logs are not here ({DATA}): nothing to measure")
        return
    lwr4 = load_robot(str(LWR4 / "kuka_lwr4_nogeom.urdf"))
    panda = load_robot(str(PANDA / "panda.yaml"))
    panda_options = {"rate": 200.0, "cutoff": 10.0}  # as examples/real_panda.py
    runs = (1,) if args.quick else (1, 2, 3)
    for run in runs:
        for name, log in variants(lwr4_log(run)).items():
            report(f"LWR4 run {run}, {name}", lwr4, log)
        report(f"LWR4 run {run}, the Panda's model", panda, lwr4_log(run))
    if args.quick:
        return
    log = read_joint_log(PANDA / "trajectory1.csv", 7)
    for name, variant in variants(log).items():
        report(f"Panda, {name}", panda, variant, **panda_options)
    report("Panda, the LWR4's model", lwr4, log, **panda_options)


if __name__ == "__main__":
    main()
