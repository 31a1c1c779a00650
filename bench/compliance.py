"""Elastic joints: the deflection model's speed and the elastic station's.

Printed: gravity torques of demo_rh_elastic (a precomputed GravityModel) per
call for 3 poses (the compensation controller's per-step cost) and per pose for
10 000 poses; link angles (the fixed point) for 10 000 poses; then one slow
setpoint move (1 s + 3 s, then a 3 s hold) simulated in the Drake station on
the rigid demo_rh, the elastic arm under the rigid computed-torque controller,
and the elastic arm under the compensation controller pre-deflecting online
(bandwidth a quarter of the lowest structural mode), as wall time per
simulated second and integrator steps. ``--quick`` (for CI): 1 000 poses
instead of 10 000, best of 2, and only the first simulated second of each move.
Run:

    OPENBLAS_NUM_THREADS=1 python bench/compliance.py [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator  # noqa: E402

from rmdrake.dynamics.compliance import (
    GravityModel,
    link_angles,
    lowest_structural_mode,
)
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.systems import MakeStation, StationConfig, setpoint_trajectory  # noqa: E402
from rmdrake.systems.station_config import (  # noqa: E402
    CompensationControllerConfig,
    InverseDynamicsControllerConfig,
)

Q0 = np.array([0.0, 0.3, 0.5, 0.0, 0.6, 0.0])
Q1 = np.array([0.1, 0.4, 0.4, 0.1, 0.5, 0.1])


def _best(f, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="CI size: fewer poses, 1 s simulated"
    )
    args = parser.parse_args()
    M, repeats = (1000, 2) if args.quick else (10_000, 5)
    duration = 1.0 if args.quick else 7.0  # s simulated (the whole move: 7 s)
    elastic = load_robot("demo_rh_elastic")
    rigid = dataclasses.replace(elastic, compliance=None)
    gravity = GravityModel(elastic)
    rng = np.random.default_rng(0)
    lo, hi = elastic.limits.lower, elastic.limits.upper
    few, many = rng.uniform(lo, hi, (3, 6)), rng.uniform(lo, hi, (M, 6))
    t3 = _best(lambda: [gravity(few, 4500.0) for _ in range(100)], repeats) / 100
    tn = _best(lambda: gravity(many, 4500.0), min(3, repeats))
    tl = _best(lambda: link_angles(gravity, many, 4500.0), min(3, repeats))
    print(f"gravity torques, 3 poses: {1e3 * t3:.3f} ms per call")
    print(f"gravity torques, {M:,} poses: {1e6 * tn / M:.2f} us per pose")
    print(f"link angles (fixed point), {M:,} poses: {1e6 * tl / M:.2f} us per pose")

    mode = lowest_structural_mode(elastic, Q0)
    bandwidth = mode / 4
    move = setpoint_trajectory(
        np.array([Q0, Q1]), move_time=[1.0, 3.0], settle_time=3.0
    )
    runs = [
        (
            "rigid demo_rh, computed torque",
            rigid,
            InverseDynamicsControllerConfig(),
            {},
        ),
        (
            "elastic, rigid computed torque",
            elastic,
            InverseDynamicsControllerConfig(),
            {},
        ),
        (
            "elastic, compensation pre-deflecting",
            elastic,
            CompensationControllerConfig(kinematic_correction=False),
            {"calibrated_model": elastic, "identified_model": rigid},
        ),
    ]
    print(f"lowest structural mode {mode:.1f} rad/s; bandwidth {bandwidth:.2f} rad/s")
    print(f"station, the first {duration:g} s of the move simulated:")
    for label, true, controller, models in runs:
        controller.bandwidth = bandwidth
        config = StationConfig(controller=controller, v_eps=0.05)
        station = MakeStation(
            config, true_model=true, trajectory=move, nominal_model=rigid, **models
        )
        context = station.CreateDefaultContext()
        simulator = Simulator(station.diagram, context)
        ApplySimulatorConfig(station.config.simulator, simulator)
        simulator.Initialize()
        t = time.perf_counter()
        simulator.AdvanceTo(duration)
        wall = time.perf_counter() - t
        steps = simulator.get_num_steps_taken()
        print(f"{label:38s} {wall / duration:.3f} s per simulated s, {steps} steps")


if __name__ == "__main__":
    main()
