"""The paper's kinematic-calibration study (Wang et al. 2016, §4, Fig. 3).

Reads the ``calibration`` section of a shipped scenario (default ``paper``:
RV-3SB with errors on the 17 parameters of Table 1, 1.6 mm mean tool error,
5 plates x 12 range-finder readings, 2 um noise, 20 seeds), calibrates with
the paper's method (DE on tetrahedron volumes), LM on point-to-plane distances
and DE+LM, prints the table, writes a Fig. 3-style PNG and a Meshcat HTML.

    python examples/kinematic_calibration.py --out out/kinematic_calibration
    python examples/kinematic_calibration.py --scenario paper_smoke   # seconds
    python examples/kinematic_calibration.py --seeds 5 --methods lm,de+lm
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from collections.abc import Sequence

from rmdrake.threads import one_thread_per_pool

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the study; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/kinematic_calibration")
    parser.add_argument("--scenario", default="paper", help="shipped scenario name")
    parser.add_argument("--seeds", type=int, help="override the scenario's seeds")
    parser.add_argument("--methods", help="override: comma-separated de, lm, de+lm")
    args = parser.parse_args(argv)

    from rmdrake.model.loading import load_robot
    from rmdrake.studies import load_scenario, run_calibration_study

    scenario = load_scenario(name=args.scenario)
    config = scenario.calibration
    if args.seeds is not None:
        config = dataclasses.replace(config, seeds=args.seeds)
    if args.methods is not None:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        config = dataclasses.replace(config, methods=methods, repeat_methods=methods)
    run_calibration_study(load_robot(scenario.robot), config, args.out)
    return 0


if __name__ == "__main__":
    one_thread_per_pool()  # small matrices: one BLAS thread is fastest
    raise SystemExit(main())
