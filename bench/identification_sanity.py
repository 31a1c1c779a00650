"""The evidence a wrong robot, joint order, sign, unit or time base leaves in a
real torque log: the figures the identification's sanity rule
(:mod:`rmdrake.dynamics.sanity`) is tuned on.

For every real log in ``../shared/data`` (the Panda of Gaz et al. 2019; the KUKA
LWR4+ runs 1-3 of FloBaRoID) and for wrong variants made from each (the two
joints with the largest torque swapped, the largest negated, the torques in
N mm, the torque 0.3 s late, the other arm's model), prepared as ``identify``
prepares them and fitted by ordinary least squares on the base parameters, it
prints per joint:

* ``load``: the joint's torque RMS over the largest joint's (loaded: >= 0.1);
* ``held``: RMS of the held-out residual (the fit of the first 70 % predicting
  the rest) over the joint's own torque RMS, %;
* ``flip``: the whole-log residual with the joint's torque negated over the
  logged one;

and per case: ``lag``, the shift of the torque against the motion whose fit
leaves the least energy, and that energy over the unshifted fit's; ``swap``,
the smallest ratio over pairs of loaded joints of their residual with their
torques exchanged over the logged one; ``outside``, the share of samples
beyond the model's joint limits; ``effort``, the largest 99th-percentile
|torque| over the effort limit; ``unit``, the loaded joints' torque RMS over
the prior's prediction; and the rule's verdict (the first reason's head).

Then, on the LWR4 end to end (not with ``--quick``): each method identifies
runs 1 and 2 (``identify``, the model written) and predicts run 3
(``validate``); printed per joint, its RMS error over that of a plain
least-squares fit of runs 1 and 2 on the same preparation (the raw base
parameters).

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

from rmdrake.dynamics.data import prepare_samples  # noqa: E402
from rmdrake.dynamics.identification import identify  # noqa: E402
from rmdrake.dynamics.joint_log import JointLog, read_joint_log  # noqa: E402
from rmdrake.dynamics.log_evidence import positions_outside  # noqa: E402
from rmdrake.dynamics.regressor import torques  # noqa: E402
from rmdrake.dynamics.sanity import (  # noqa: E402
    IdentificationBounds,
    check_identification,
    check_log,
    torque_unit_factor,
)
from rmdrake.model.dynamic_parameters import standard_parameters  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.model.robot import RobotModel  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LWR4 = DATA / "lwr4_flobaroid"
PANDA = DATA / "panda_gaz2019"
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


def report(name: str, model: RobotModel, log: JointLog, **options) -> None:
    # prepare_logs' preparation of a log, without the file
    s = prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd, **options)
    b = IdentificationBounds()
    result = identify(model, s, method="ols")
    sanity = check_identification(result, model=model, samples=s)
    refused = check_log(s, model, model.limits.effort, prior=model) or list(
        sanity.reasons
    )
    rms = np.sqrt(np.mean(s.tau**2, axis=0))
    ev = sanity.evidence
    swap = min((r for _, _, r in ev.swaps), default=np.inf)
    lim = model.limits
    outside, _ = positions_outside(s.q, lim.lower, lim.upper, b.limit_margin)
    effort = np.percentile(np.abs(s.tau), 99, axis=0) / np.asarray(lim.effort)
    unit = np.nan
    if model.dynamics is not None:
        prior = torques(model, s.q, s.qd, s.qdd, standard_parameters(model))
        unit, _ = torque_unit_factor(s.tau, prior, b.loaded_share)
    verdict = refused[0].split(":")[0] if refused else "passes"
    print(
        f"{name:<34} lag {ev.lag:+.2f} s ({ev.lag_ratio:.2f}x)  swap {swap:5.2f}  "
        f"outside {100 * outside:4.1f} %  effort {effort.max():.3g}x  "
        f"unit {unit:.3g}x  rule: {verdict}"
    )
    for label, values, fmt in (
        ("load", rms / rms.max(), "{:6.2f}"),
        ("held %", 100 * sanity.heldout_rms / rms, "{:6.1f}"),
        ("flip", sanity.flip_ratio, "{:6.2f}"),
    ):
        print(f"    {label:<7}" + "".join(fmt.format(v) for v in values))


def lwr4_end_to_end() -> None:
    """Every method on runs 1, 2 predicting run 3, against plain LS."""
    import tempfile

    from rmdrake.dynamics.data import stack_samples
    from rmdrake.dynamics.estimators import IDENTIFICATION_METHODS
    from rmdrake.dynamics.joint_log import write_joint_log
    from rmdrake.dynamics.log_samples import prepare_logs
    from rmdrake.pipelines.identify import identify_file
    from rmdrake.pipelines.validate import validate_file

    model = load_robot(str(LWR4 / "kuka_lwr4_nogeom.urdf"))
    with tempfile.TemporaryDirectory() as tmp:
        runs = [
            write_joint_log(Path(tmp, f"run{r}.csv"), lwr4_log(r)) for r in (1, 2, 3)
        ]
        _, parts = prepare_logs(runs[:2], 7)
        _, (s3,) = prepare_logs(runs[2:], 7)
        ols = identify(model, stack_samples(parts), method="ols")
        Y = ols.base.regressor(model, s3.q, s3.qd, s3.qdd)
        plain = np.sqrt(np.mean((Y @ ols.params - s3.tau) ** 2, axis=0))
        print("\nLWR4 runs 1+2 -> run 3: validate RMS per joint over plain LS's")
        print(f"{'plain LS [N m]':<16}" + "".join(f"{v:7.3f}" for v in plain))
        for method in IDENTIFICATION_METHODS:
            out = identify_file(
                model, runs[:2], Path(tmp, f"{method}.yaml"), method=method,
                echo=lambda _: None,
            )  # fmt: skip
            errors = validate_file([out], runs[2], echo=lambda _: None)
            rms = np.sqrt(np.mean((errors.predicted[0] - s3.tau) ** 2, axis=0))
            print(f"{method:<16}" + "".join(f"{v:7.2f}" for v in rms / plain))


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
    lwr4_end_to_end()


if __name__ == "__main__":
    main()
