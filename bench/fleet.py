"""The fleet rule's false alarms and detection, on numbers (no plant).

Healthy fleets of 4, 12 and 21 arms x 52 base parameters: each parameter
centre 1 (relative units), a build spread of 3 % between arms and each arm's
identification noise on top, its std as reported. The noise's share of each
parameter's scatter is the one measured on 12 Drake-simulated RV-3SB arms
(README recipe: one 20 s excitation, 0.5 % torque noise): std / (std of the
estimates over the arms) from 0.06 (MX3R, fc4: the build spread dominates) to
1.8 (XY6: the noise does), median 0.9. Printed per fleet size and rule: the
share of fleets where some healthy arm is flagged (the family-wise false-alarm
rate, with its 95 % upper bound), and with one worn arm (its joint 3 viscous
and Coulomb friction +50 %: about 16 build sigmas) the share where it is
flagged. Then the history rule (:mod:`rmdrake.dynamics.history`) on one arm's
fits: constant arms (false alarms) and an arm whose fv3 grows 10 % a year.
``--quick`` (for CI): 200 fleets instead of 4000. Run:

    OPENBLAS_NUM_THREADS=1 python bench/fleet.py [--quick] [--fleets N]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from rmdrake.dynamics.fleet import (  # noqa: E402
    compare_fleet,
    robust_centre,
    sigma_equivalent,
    spread_dof,
)
from rmdrake.dynamics.history import compare_history  # noqa: E402

# std / (std of the estimates over 11 healthy arms) per base parameter of the
# RV-3SB, measured on the README's 12-arm fleet (20 s excitation, 0.5 % noise).
NAMES = (
    "ZZ1R fv1 fc1 XX2R XY2 XZ2R YZ2 ZZ2R MX2R MY2 fv2 fc2 XX3R XY3R XZ3 YZ3 ZZ3R "
    "MX3R MY3R Ia3 fv3 fc3 XX4R XY4 XZ4 YZ4 ZZ4R MX4 MY4R Ia4 fv4 fc4 XX5R XY5 XZ5 "
    "YZ5 ZZ5R MX5 MY5R Ia5 fv5 fc5 XX6R XY6 XZ6 YZ6 ZZ6 MX6 MY6 Ia6 fv6 fc6"
).split()
SHARE = np.array(
    [0.66, 0.29, 0.15, 0.89, 0.85, 0.92, 1.06, 0.91, 0.08, 0.73, 0.26, 0.21, 0.96,
     0.98, 0.95, 0.92, 0.65, 0.07, 0.06, 0.92, 0.40, 0.11, 0.90, 1.35, 1.32, 0.86,
     1.14, 0.92, 1.67, 0.90, 0.42, 0.08, 1.12, 1.20, 0.99, 1.21, 1.11, 0.86, 0.34,
     1.06, 0.46, 0.15, 0.71, 1.80, 1.21, 1.08, 1.04, 1.01, 0.97, 0.79, 0.24, 0.13]
)  # fmt: skip
BUILD = 0.03  # relative build spread, one sigma
NOISE = BUILD * SHARE / np.sqrt(1 - np.minimum(SHARE, 0.95) ** 2)  # id std
WORN = ("fv3", "fc3")


def fleets(m: int, count: int, seed: int, worn: int | None = None, build=BUILD):
    """``count`` fleets of ``m`` arms side by side: values and stds (m,
    count x 52), each parameter's build spread ``build`` (relative), the worn
    arm's fv3 and fc3 (if any) x 1.5."""
    rng = np.random.default_rng(seed)
    p = len(NAMES)
    true = 1.0 + build * rng.standard_normal((m, count, p))
    if worn is not None:
        true[worn][:, [NAMES.index(n) for n in WORN]] *= 1.5
    values = true + NOISE * rng.standard_normal((m, count, p))
    std = np.broadcast_to(NOISE, values.shape)
    return values.reshape(m, -1), np.ascontiguousarray(std).reshape(m, -1)


def flagged(values, std, count: int, **rule) -> tuple[np.ndarray, float]:
    """(m, count) True where an arm has a flag, fleet by fleet, and the
    threshold. The fleets are compared together (one column per parameter of
    each fleet), at the threshold of one fleet of m x 52 tests."""
    m, p = values.shape[0], len(NAMES)
    arms = [str(i) for i in range(m)]
    if rule.get("before"):  # 0.1.0's rule: Welch-Satterthwaite dof, 5 sigma
        centre, spread = robust_centre(values)
        combined = np.sqrt(std**2 + spread**2)
        dof = spread_dof(m) * (combined / spread) ** 4
        z = sigma_equivalent((values - centre) / combined, dof)
        return (np.abs(z) > 5.0).reshape(m, count, p).any(axis=2), 5.0
    build = rule.pop("build", None)
    one = {} if build is None else {"build_spread": np.full(p, build)}
    threshold = compare_fleet(arms, NAMES, values[:, :p], std[:, :p], **one).threshold
    if build is not None:
        one = {"build_spread": np.full(p * count, build)}
    c = compare_fleet(arms, NAMES * count, values, std, **{"threshold": threshold,
                                                           **rule, **one})  # fmt: skip
    hit = (np.abs(c.z) > c.threshold).reshape(m, count, p).any(axis=2)
    return hit, c.threshold


def upper95(k: int, n: int) -> float:
    """The one-sided 95 % Clopper-Pearson upper bound of k in n."""
    return 1.0 if k == n else float(stats.beta.ppf(0.95, k + 1, n - k))


def fleet_table(count: int, seed: int) -> None:
    """Prints the false alarms and detections of each rule, per fleet size."""
    rules = {  # name: (rule, true build spread)
        "before: 5 sigma, W-S dof": ({"before": True}, BUILD),
        "fixed 5 sigma": ({"threshold": 5.0}, BUILD),
        "family-wise 1 %": ({}, BUILD),
        "family-wise 1 %, build 3 % given": ({"build": BUILD}, BUILD),
        "  the same, true build 4.5 %": ({"build": BUILD}, 1.5 * BUILD),
        "  the same, true build 2 %": ({"build": BUILD}, BUILD / 1.5),
    }
    print(f"fleets of m arms x {len(NAMES)} parameters, {count} fleets each, "
          f"seed {seed}; worn: fv3, fc3 +50 % on one arm")  # fmt: skip
    print(f"{'rule':34s} {'m':>3s} {'sigma':>6s} {'false alarms':>13s} "
          f"{'(95 % up)':>9s} {'worn found':>10s}")  # fmt: skip
    for name, (rule, build) in rules.items():
        for m in (4, 12, 21):
            t0 = time.perf_counter()
            values, std = fleets(m, count, seed + m, build=build)
            hit, threshold = flagged(values, std, count, **rule)
            k = int(hit.any(axis=0).sum())
            worn = min(7, m - 1)
            values, std = fleets(m, count, seed + 100 + m, worn=worn, build=build)
            found = flagged(values, std, count, **rule)[0][worn].mean()
            print(
                f"{name:34s} {m:3d} {threshold:6.2f} {100 * k / count:11.2f} % "
                f"{100 * upper95(k, count):7.2f} % {100 * found:9.1f} %"
                f"  ({time.perf_counter() - t0:.1f} s)"
            )


def history_table(count: int, seed: int) -> None:
    """Prints the history rule's false alarms on constant arms and its
    detection of fv3 growing 10 % a year, for 6 and 12 monthly fits."""
    p = len(NAMES)
    print(f"\none arm's monthly fits x {p} parameters, {count} arms each, "
          f"seed {seed}; drift: fv3 +10 %/year")  # fmt: skip
    print(f"{'fits':>4s} {'sigma':>6s} {'false alarms':>13s} {'(95 % up)':>9s} "
          f"{'drift found':>11s} {'trend/truth':>11s}")  # fmt: skip
    k = NAMES.index("fv3")
    for n in (6, 12):
        days = np.arange(n) * 365.25 / 12
        rng = np.random.default_rng(seed + n)
        noise = NOISE * rng.standard_normal((2, n, count, p))
        values = 1.0 + noise  # constant arms, then drifting ones
        values[1, :, :, k] += 0.10 * days[:, None] / 365.25
        std = np.broadcast_to(NOISE, (n, count, p)).reshape(n, -1)
        hits = []
        for v in values:
            h = compare_history(
                NAMES * count,
                days,
                v.reshape(n, -1),
                std,
                threshold=compare_history(NAMES, days, v[:, 0], std[:, :p]).threshold,
            )
            hit = (np.abs(h.z) > h.threshold).reshape(count, p)
            hits.append((hit, h.trend.reshape(count, p)[:, k]))
        (quiet, _), (drift, trend) = hits
        bad = int(quiet.any(axis=1).sum())
        print(
            f"{n:4d} {h.threshold:6.2f} {100 * bad / count:11.2f} % "
            f"{100 * upper95(bad, count):7.2f} % {100 * drift[:, k].mean():9.1f} % "
            f"{np.median(trend) / 0.10:11.3f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="CI size")
    parser.add_argument("--fleets", type=int, help="default 4000 (200 --quick)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    count = args.fleets or (200 if args.quick else 4000)
    fleet_table(count, args.seed)
    history_table(count, args.seed)


if __name__ == "__main__":
    main()
