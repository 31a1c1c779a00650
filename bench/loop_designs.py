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

from rmdrake.calibration.plates.checks import MeasurementWarning
from rmdrake.model.loading import load_robot
from rmdrake.studies.closed_loop import calibrate_loop, identify_loop, join_loop
from rmdrake.studies.scenarios import SHIPPED_SCENARIOS, load_scenario
from rmdrake.studies.tracking import (
    summarise_tracking,
    track_program,
    tracking_cells,
)


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
    config.tracking.speeds = config.tracking.speeds[-1:]  # the target's speed
    designs = args.designs or [0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeasurementWarning)
        calibration = calibrate_loop(nominal, config, 0, progress=False)
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
        runs = [track_program(models, loop, c) for c in tracking_cells(loop.tracking)]
        result = summarise_tracking(
            0,
            loop.tracking,
            {r.cell[:2]: r for r in runs},
            {r.cell: r.errors for r in runs},
        )
        ratios = [
            f"{path} {result.full_over_floor(p):.2f}"
            for p, path in enumerate(loop.tracking.paths)
        ]
        errors = ", ".join(
            f"{m} {100 * e:.2f} %" for m, e in identification.torque_error.items()
        )
        print(
            f"  design_seed {seed}: cond(A) {identification.excitation_cond:.1f}, "
            f"torque error {errors}; full / floor: {', '.join(ratios)}"
        )


if __name__ == "__main__":
    main()
