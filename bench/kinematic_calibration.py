"""Plane-constraint calibration speed and accuracy on the paper's scenario.

RV-3SB, 17 parameters (Table 1), 5 plates x 12 readings, 2 um noise, true errors
giving 1.6 mm mean tool error. Times the fit only (data simulated beforehand):
LM (best and median of ``--repeats``), DE+LM and the paper's DE alone (median of
``--de-repeats``), and prints the mean/max tool error after calibration on 1000
held-out poses. Targets (issue 3): LM <= 0.1 s, DE+LM <= 5 s. ``--quick``
(for CI): LM best of 3, DE+LM and DE once each, the DE alone stopped after 50
generations (its error figures are then not the paper's). Run:

    OPENBLAS_NUM_THREADS=1 python bench/kinematic_calibration.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.calibration import make_calibrator, tool_point_errors  # noqa: E402
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.studies import CalibrationStudyConfig, draw_true_robot  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="scenario seed")
    parser.add_argument("--repeats", type=int, help="LM repeats (20; quick 3)")
    parser.add_argument("--de-repeats", type=int, help="DE repeats (3; quick 1)")
    parser.add_argument(
        "--quick", action="store_true", help="CI size: fewer repeats, DE capped"
    )
    args = parser.parse_args()
    lm_repeats = args.repeats or (3 if args.quick else 20)
    de_repeats = args.de_repeats or (1 if args.quick else 3)
    # The DE alone runs to its own convergence (300 generations and more);
    # the quick run caps it (scipy's maxiter), the rest is the same call.
    de_alone = {"maxiter": 50} if args.quick else {}
    sc = draw_true_robot(load_robot("rv3sb"), CalibrationStudyConfig(), args.seed)
    data = sc.simulation.data
    print(
        f"paper scenario seed {args.seed}: {sc.nominal.name}, {len(sc.names)} "
        f"parameters, {data.n_readings} readings on {data.plate_ids.size} plates; "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, "
        f"{os.cpu_count()} CPUs, load average before "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}"
    )
    before = tool_point_errors(sc.nominal, sc.true, sc.q_validation)
    print(f"before: mean {before.mean * 1e3:.4f} mm, max {before.max * 1e3:.4f} mm")
    print(
        f"{'method':<22} {'best [s]':>9} {'median [s]':>11} {'target':>8} "
        f"{'mean err [mm]':>14} {'max err [mm]':>13}"
    )
    for method, repeats, target in (
        ("lm", lm_repeats, 0.1),
        ("de+lm", de_repeats, 5.0),
        ("de", de_repeats, None),
    ):
        times = []
        for r in range(repeats):
            options = {} if method == "lm" else {"seed": r}
            options.update(de_alone if method == "de" else {})
            est = make_calibrator(method, sc.nominal, **options)
            t0 = time.perf_counter()
            est.fit(data)
            times.append(time.perf_counter() - t0)
        err = tool_point_errors(est.model_, sc.true, sc.q_validation)
        de = "DE alone, capped" if de_alone else "paper's DE alone"
        label = {"de": de, "lm": "LM", "de+lm": "DE+LM"}[method]
        extra = ""
        if method != "lm":
            extra = (
                f"  ({est.de_result_.nit} generations, {est.de_result_.nfev} "
                f"vectorised cost calls)"
            )
        print(
            f"{label:<22} {min(times):9.4f} {np.median(times):11.4f} "
            f"{'<= ' + str(target) if target else '-':>8} {err.mean * 1e3:14.4f} "
            f"{err.max * 1e3:13.4f}{extra}"
        )
    print(f"load average after {', '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
