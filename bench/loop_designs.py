"""How much the closed loop's path tracking depends on its excitation design.

The paper scenario's closed loop on its first true robot (seed 0): one
calibration, then for each excitation design (600 generations of DE on the
nominal RV-3SB, the scenario's budget) the loop's identification on that
design and the tracking grid at the fastest speed with both feedback
bandwidths. Printed per design: cond(A), the identified models' torque errors
against the true model, and each path's full / floor (the study's target:
<= 2; the floor is the larger of the oracle's RMS at the soft gains and the
full compensation's at the stiff ones). ``--designs``: the loop's
``design_seed`` values (the scenario's is 0). ``--quick``: 2 generations, 1
period, the circle only, one design. Run:

    OPENBLAS_NUM_THREADS=1 python bench/loop_designs.py [--designs 0 1 2]
"""

from __future__ import annotations

import argparse
import copy
import warnings

import numpy as np

from rmdrake.calibration.plates.checks import MeasurementWarning
from rmdrake.model.loading import load_robot
from rmdrake.studies.closed_loop import calibrate_loop, identify_loop, join_loop
from rmdrake.studies.scenarios import SHIPPED_SCENARIOS, load_scenario
from rmdrake.studies.tracking import TRACKING_VARIANTS, track_program


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, nargs="+", default=None)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    nominal = load_robot("rv3sb")
    config = load_scenario(SHIPPED_SCENARIOS, "paper").compensation
    if args.quick:
        config.identification.design_maxiter = 2
        config.identification.periods = 1.0
        config.tracking.paths = ["circle"]
    designs = args.designs or [0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeasurementWarning)
        calibration = calibrate_loop(nominal, config, 0, progress=False)
    full, oracle = TRACKING_VARIANTS.index("full"), TRACKING_VARIANTS.index("oracle")
    soft = int(np.argmin(config.tracking.bandwidths))
    print(
        f"closed loop of scenario 'paper', seed 0, {config.identification.periods:g} "
        f"periods, {config.identification.design_maxiter} generations; "
        "full / floor per path (target <= 2):"
    )
    for seed in designs:
        loop = copy.deepcopy(config)
        loop.identification.design_seed = seed
        identification = identify_loop(nominal, loop, 0, progress=False)
        models, _ = join_loop(nominal, calibration, identification)
        fastest = len(loop.tracking.speeds) - 1
        ratios = []
        for p, path in enumerate(loop.tracking.paths):
            rms = [
                track_program(models, loop, (p, fastest, b)).errors.tool_rms
                for b in range(len(loop.tracking.bandwidths))
            ]
            floor = max(rms[soft][oracle], rms[1 - soft][full])
            ratios.append(f"{path} {rms[soft][full] / floor:.2f}")
        errors = ", ".join(
            f"{m} {100 * e:.2f} %" for m, e in identification.torque_error.items()
        )
        print(
            f"  design_seed {seed}: cond(A) {identification.excitation_cond:.1f}, "
            f"torque error {errors}; full / floor: {', '.join(ratios)}"
        )


if __name__ == "__main__":
    main()
