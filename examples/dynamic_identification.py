"""The paper's dynamic study with Drake as the robot (§3.2, §4; Fig. 4, 6, 7).

Reads the ``identification`` section of a shipped scenario (default ``paper``),
designs the robot's Fourier excitation by DE (eq. 16-17), runs it on a true
robot (nominal dynamics perturbed 10-30 %, friction, rotor inertia) in the Drake
station, identifies the base parameters with OLS, WLS, physically consistent
least squares and the paper's DE, and validates them on a different trajectory.

    python examples/dynamic_identification.py --out out/dynamics
    python examples/dynamic_identification.py --scenario paper_smoke
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence

from rmdrake.threads import one_thread_per_pool


def main(argv: Sequence[str] | None = None):
    """Runs the study; returns its :class:`IdentificationStudy`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/dynamics")
    parser.add_argument("--scenario", default="paper", help="shipped scenario name")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    args = parser.parse_args(argv)

    from rmdrake.model.loading import load_robot
    from rmdrake.studies import load_scenario, run_identification_study

    scenario = load_scenario(name=args.scenario)
    config = scenario.identification
    if args.seed is not None:
        config = dataclasses.replace(config, seed=args.seed)
    return run_identification_study(load_robot(scenario.robot), config, args.out)


if __name__ == "__main__":
    one_thread_per_pool()  # small matrices: one BLAS thread is fastest
    main()
