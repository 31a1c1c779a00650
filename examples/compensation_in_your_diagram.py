"""Calibrated compensation in your own Drake diagram.

A user's diagram: the robot's plant (here the RV-3SB with the paper's 1.6 mm
geometric errors and 10-30 % dynamic errors, standing in for the real arm), a
TrajectorySource of the user's joint path planned on the nominal model, the
compensation controller added with ``AddToBuilder``, and a logger. The path is
filtered for the calibrated kinematics offline (``corrected_program``) or
online by the controller (``calibrated=``); the controller runs the inverse
dynamics of the identified robot. Prints the tool path error of each.

    python examples/compensation_in_your_diagram.py [--seed 0]
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

import numpy as np

from rmdrake.threads import one_thread_per_pool


def _robots(seed: int):
    """The 'real' arm, and what calibration and identification made of it."""
    from rmdrake import load_robot
    from rmdrake.calibration.plates.estimators import make_calibrator
    from rmdrake.calibration.plates.simulate import simulate_plates
    from rmdrake.dynamics import standard_parameters
    from rmdrake.model.dynamic_parameters import perturb_standard_parameters
    from rmdrake.studies import CalibrationStudyConfig, draw_true_robot

    nominal = load_robot("rv3sb")
    draw = draw_true_robot(nominal, CalibrationStudyConfig(n_validation=200), seed)
    rng = np.random.default_rng(seed)
    chi = perturb_standard_parameters(standard_parameters(nominal), rng)
    real = draw.true.with_dynamics(chi.reshape(nominal.n_joints, -1))
    plates = simulate_plates(real, noise=2e-6, seed=seed, planning_model=nominal)
    calibrated = make_calibrator("lm", nominal).fit(plates.data).model_
    return nominal, real, calibrated, real  # identified: taken as exact here


def main(argv: Sequence[str] | None = None) -> dict[str, float]:
    """Runs the diagram three times (nominal program, corrected offline,
    corrected online); returns the max tool path error of each in m."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    nominal, real, calibrated, identified = _robots(args.seed)

    # ---- the user's code: about 30 lines --------------------------------------
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import (
        Demultiplexer,
        LogVectorOutput,
        TrajectorySource,
    )
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.kinematics.forward import tool_points
    from rmdrake.model.plant import MakePlant
    from rmdrake.systems import (
        CalibratedCompensationController,
        JointFriction,
        corrected_program,
    )

    t = np.array([0.0, 1.5, 3.0, 4.5])  # s; a path through four joint waypoints
    waypoints = np.array([[0.0, 0.2, 1.2, 0.0, 0.8, 0.0], [0.6, 0.4, 1.0, 0.3, 1, 0.2],
        [0.9, 0.1, 1.4, -0.2, 0.7, -0.3], [0.3, 0.3, 1.1, 0.1, 0.9, 0.0]])  # fmt: skip
    path = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        t, waypoints.T, np.zeros(6), np.zeros(6)
    )
    errors, corrected = {}, corrected_program(nominal, calibrated, path)
    for label, program, online, start in (  # start: the arm at rest, on program
        ("nominal program", path, None, path.value(0)),
        ("corrected program", corrected, None, corrected.value(0)),
        ("online correction", path, calibrated, corrected.value(0)),
    ):
        builder = DiagramBuilder()
        plant, _ = MakePlant(real, builder=builder, visual=False)
        fv, fc = real.dynamics[:, 11], real.dynamics[:, 12]  # the arm's friction
        JointFriction.AddToBuilder(builder, plant, fv=fv, fc=fc)
        source = builder.AddSystem(TrajectorySource(program, 2))  # [q; qd; qdd]
        split = builder.AddSystem(Demultiplexer([12, 6]))
        builder.Connect(source.get_output_port(), split.get_input_port())
        controller = CalibratedCompensationController.AddToBuilder(
            builder,
            desired_state=split.get_output_port(0),
            desired_acceleration=split.get_output_port(1),
            estimated_state=plant.get_state_output_port(),
            nominal=nominal,
            identified=identified,
            calibrated=online,  # corrects the program inside the controller
        )
        builder.Connect(
            controller.GetOutputPort("actuation"), plant.get_actuation_input_port()
        )
        logger = LogVectorOutput(plant.get_state_output_port(), builder, 0.01)
        diagram = builder.Build()
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        plant.SetPositions(plant.GetMyMutableContextFromRoot(context), start)
        simulator.AdvanceTo(t[-1])
        log = logger.FindLog(context)
        q = log.data()[:6].T
        q_path = np.array([path.value(s).ravel() for s in log.sample_times()])
        target = tool_points(nominal.table, q_path, sigma=nominal.sigma)
        attained = tool_points(real.table, q, sigma=real.sigma)
        errors[label] = float(np.linalg.norm(attained - target, axis=1).max())
    # ---- end of the user's code ------------------------------------------------

    for label, e in errors.items():
        print(f"{label:>18}: max tool path error {e * 1e3:.4f} mm")
    return errors


if __name__ == "__main__":
    one_thread_per_pool()  # small matrices: one BLAS thread is fastest
    main()
