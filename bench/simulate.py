"""Station speed against Drake alone: simulated seconds per wall second.

For each robot (default rv3sb and demo_rh): a "true" robot (each link's
inertial parameters scaled by one factor in [0.85, 1.15], Ia, fv, fc by
[0.8, 1.2], seeded) under the default controller on the shipped nominal model,
in two motions: one period of a seeded eq. 17-feasible Fourier excitation (5
harmonics, 0.1 Hz, half the limits; 10 s) and a point-to-point program that
holds still most of the time (4 moves of 1.5 s, each held 1 s; 10 s: what the
calibration readings and the static-accuracy studies simulate). Each motion
runs on the continuous station (``time_step`` 0, RK3 at ``--accuracy``) and on
the discrete one (``DEFAULT_TIME_STEP``, about 1 kHz), and on a Drake-only
twin of each: the same plant and integrator settings driven by Drake's own
systems (a ``TrajectorySource`` of a cubic Hermite polynomial of the motion at
1 ms knots, and rmdrake's ``NominalController``, whose friction feedforward is
a SymbolicVectorSystem: on the continuous plant Drake's
``InverseDynamicsController``; on the discrete one Drake's ``InverseDynamics``
and the sampled PID; the plant's friction the station's, JointFriction (a
SymbolicVectorSystem) or the discrete plant's own). No Python system is
evaluated in a twin's step; the station differs by its desired-motion source
(Drake's Sine for the excitation), its encoders (Python, at the log rate) and
its sensors.

Printed per robot, motion and mode: best wall time of ``RunStation`` over
``--repeats`` runs as simulated s per wall s, the twin's, their ratio (the
issue's target: the discrete station at >= 30 % of its twin), the torque-oracle
residual max |tau_log - Y @ chi_true| / max |tau| (smooth sign in the
regressor: round-off on the continuous station; on the discrete one the SAP
Coulomb law's linear transition against the regressor's tanh, over |qd| < a few
v_eps), and the largest tracking error. Then per robot the static-accuracy
study's drives read at rest (20 targets, 2 s holds) with their holds
integrated by RK3 and by Radau3 (``StationConfig.hold_integration_scheme``),
their moves at the simulator's accuracy, and with Radau3 holds and the moves
at ``StationConfig.move_accuracy`` 1e-3.
``--quick``: rv3sb only, a tenth of each motion (2 targets), one repeat. Run:

    OPENBLAS_NUM_THREADS=1 python bench/simulate.py [--robots rv3sb demo_rh]
        [--repeats 3] [--accuracy 1e-4] [--quick]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder  # noqa: E402
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource  # noqa: E402
from pydrake.trajectories import PiecewisePolynomial  # noqa: E402

from rmdrake import load_robot, random_fourier_trajectory  # noqa: E402
from rmdrake.dynamics import SerialChain, regressor, standard_parameters  # noqa: E402
from rmdrake.dynamics.friction import DEFAULT_V_EPS  # noqa: E402
from rmdrake.model.plant import MakePlant  # noqa: E402
from rmdrake.model.robot import DYNAMIC_KEYS  # noqa: E402
from rmdrake.studies.closed_loop import TargetDrive, drive_to_targets  # noqa: E402
from rmdrake.systems import MakeStation, RunStation, measurement_config  # noqa: E402
from rmdrake.systems.controllers import NominalController  # noqa: E402
from rmdrake.systems.friction import (  # noqa: E402
    AddDiscretePlantFriction,
    JointFriction,
)
from rmdrake.systems.joint_state import joint_state_selector  # noqa: E402
from rmdrake.systems.station_config import (  # noqa: E402
    DEFAULT_TIME_STEP,
    StationConfig,
)
from rmdrake.systems.station_sources import (  # noqa: E402
    setpoint_move_times,
    setpoint_trajectory,
)


def perturbed(model, seed: int):
    rng = np.random.default_rng(seed)
    d = np.array(model.dynamics)
    d[:, :10] *= rng.uniform(0.85, 1.15, (model.n_joints, 1))
    d[:, 10:] *= rng.uniform(0.8, 1.2, (model.n_joints, 3))
    return model.with_dynamics(d)


def mid_range_targets(model, count: int, *, seed: int) -> np.ndarray:
    """(count, n) joint targets drawn uniformly in the middle 40 % of each
    joint's range, rad or m (seeded)."""
    rng = np.random.default_rng(seed)
    lo, hi = model.limits.lower, model.limits.upper
    return lo + (hi - lo) * (0.3 + 0.4 * rng.random((count, model.n_joints)))


def motions(model, fraction: float) -> dict[str, tuple[object, float, callable]]:
    """name -> (trajectory for MakeStation, duration s, q_desired(t) (M, n))."""
    fourier = random_fourier_trajectory(model, seed=1, fill=0.5)
    q_list = mid_range_targets(model, 4, seed=0)
    holds = setpoint_trajectory(q_list, move_time=1.5, settle_time=1.0)
    return {
        "excitation": (fourier, fraction * fourier.period, fourier.q),
        "holding": (
            holds,
            fraction * holds.end_time(),
            lambda t: np.column_stack([holds.value(x)[:, 0] for x in t]).T,
        ),
    }


def hermite(q_of_t, duration: float, n: int) -> PiecewisePolynomial:
    """A cubic Hermite polynomial through q and its rate at 1 ms knots."""
    t = np.arange(0.0, duration + 0.02, 1e-3)
    q = q_of_t(t)
    qd = np.gradient(q, t, axis=0)
    return PiecewisePolynomial.CubicHermite(t, q.T, qd.T)


def twin_speed(true, nominal, q_of_t, duration: float, config: StationConfig) -> float:
    """Simulated s per wall s of the Drake-only twin (module docstring)."""
    n = true.n_joints
    path = hermite(q_of_t, duration, n)
    builder = DiagramBuilder()
    discrete = config.time_step > 0
    plant, _ = MakePlant(
        true,
        builder=builder,
        time_step=config.time_step,
        visual=False,
        coulomb_width=config.v_eps if discrete else None,
    )
    source = builder.AddSystem(TrajectorySource(path, 1, True))
    acceleration = builder.AddSystem(TrajectorySource(path.derivative(2)))
    actuation = plant.get_actuation_input_port()
    if discrete:
        S = joint_state_selector(plant, [f"joint{j}" for j in range(1, n + 1)])
        actuation, _ = AddDiscretePlantFriction(builder, plant, true, S)
    else:  # the station's friction: Drake's SymbolicVectorSystem
        d = np.asarray(true.dynamics)
        fv, fc = (d[:, DYNAMIC_KEYS.index(k)] for k in ("fv", "fc"))
        JointFriction.AddToBuilder(builder, plant, fv=fv, fc=fc, v_eps=config.v_eps)
    # Drake's systems only: InverseDynamicsController (continuous) or
    # InverseDynamics with the sampled PID (discrete), and the friction
    # feedforward's SymbolicVectorSystem.
    controller = NominalController.AddToBuilder(
        builder,
        desired_state=source.get_output_port(),
        desired_acceleration=acceleration.get_output_port(),
        estimated_state=plant.get_state_output_port(),
        nominal=nominal,
        bandwidth=config.controller.bandwidth,
        friction_feedforward=True,
        v_eps=config.v_eps,
        time_step=config.time_step,
    )
    builder.Connect(controller.GetOutputPort("actuation"), actuation)
    LogVectorOutput(plant.get_state_output_port(), builder, config.log_period)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    x0 = np.concatenate([path.value(0.0)[:, 0], path.derivative(1).value(0.0)[:, 0]])
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), x0)
    simulator = Simulator(diagram, context)
    if not discrete:
        ApplySimulatorConfig(config.simulator, simulator)
        context.SetTime(0.0)
    simulator.Initialize()
    wall = time.perf_counter()
    simulator.AdvanceTo(duration)
    return duration / (time.perf_counter() - wall)


def bench_robot(name: str, repeats: int, accuracy: float, fraction: float) -> None:
    nominal = load_robot(name)
    true = perturbed(nominal, seed=2)
    chain = SerialChain.from_model(true)
    chi = standard_parameters(true)
    print(f"{name}:")
    for motion, (trajectory, duration, q_of_t) in motions(nominal, fraction).items():
        for label, step in (("continuous", 0.0), ("discrete", DEFAULT_TIME_STEP)):
            config = StationConfig(time_step=step)
            config.simulator.accuracy = accuracy
            station = MakeStation(
                config, true_model=true, trajectory=trajectory, nominal_model=nominal
            )
            wall = np.inf
            for _ in range(repeats):
                w0 = time.perf_counter()
                log = RunStation(station, duration=duration)
                wall = min(wall, time.perf_counter() - w0)
            speed = duration / wall
            twin = max(
                twin_speed(true, nominal, q_of_t, duration, config)
                for _ in range(repeats)
            )
            Y = regressor(chain, log.q, log.qd, log.qdd, coulomb_width=DEFAULT_V_EPS)
            rel = np.abs(Y @ chi - log.tau).max() / np.abs(log.tau).max()
            track = np.degrees(np.abs(log.q - q_of_t(log.t)).max())
            print(
                f"  {motion:10s} {label:10s} ({duration:g} s): station "
                f"{speed:7.2f} s/s, Drake-only twin {twin:7.2f} s/s, ratio "
                f"{speed / twin:6.1%}; oracle residual {rel:.1e}; tracking "
                f"{track:.3f} deg"
            )
    read_at_rest(true, nominal, repeats, fraction)


def read_at_rest(true, nominal, repeats: int, fraction: float) -> None:
    """The static-accuracy study's drives (``drive_to_targets``: moves of at
    least 1.5 s within half the joint limits, holds of 2 s, read at each
    hold's end) on the measurement runs' station, its holds integrated with
    RK3 and with Radau3 (``hold_integration_scheme``): simulated s per wall
    s, the largest difference of the encoder angles read, and the largest
    settle error |q - q_target|."""
    count = max(2, round(20 * fraction))
    q_list = mid_range_targets(nominal, count, seed=3)
    limits = nominal.limits  # moves within half the limits, as the studies plan
    move_time = np.maximum(
        setpoint_move_times(
            q_list,
            velocity=0.5 * limits.velocity,
            acceleration=0.5 * limits.acceleration,
            q_start=q_list[0],
        ),
        1.5,
    )
    duration = float(np.sum(move_time + 2.0))
    runs = {}
    for scheme, accuracy in (("", 0.0), ("radau3", 0.0), ("radau3", 1e-3)):
        config = measurement_config()
        config.hold_integration_scheme = scheme
        config.move_accuracy = accuracy
        wall = np.inf
        for _ in range(repeats):
            q, _, w = drive_to_targets(
                config,
                TargetDrive(q_list, move_time, settle_time=2.0, q_start=q_list[0]),
                true_model=true,
                nominal_model=nominal,
            )
            wall = min(wall, w)
        runs[scheme, accuracy] = (duration / wall, q)
    (rk3, q_rk3), (radau3, q_radau3), (fast, q_fast) = runs.values()
    print(
        f"  read at rest ({count} drives, {duration:g} s), moves at the "
        f"simulator's accuracy: holds by RK3 {rk3:7.2f} s/s, by Radau3 "
        f"{radau3:7.2f} s/s ({radau3 / rk3:.2f}x); encoder angles read differ by "
        f"{np.abs(q_radau3 - q_rk3).max():.1e} rad (settled to "
        f"{np.abs(q_rk3 - q_list).max():.1e} rad)\n"
        f"  moves at move_accuracy 1e-3 (the default), holds by Radau3: "
        f"{fast:7.2f} s/s ({fast / radau3:.2f}x); encoder angles read differ "
        f"by {np.abs(q_fast - q_radau3).max():.1e} rad"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=None)
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--accuracy", type=float, default=1e-4)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    robots = args.robots or (["rv3sb"] if args.quick else ["rv3sb", "demo_rh"])
    repeats = args.repeats or (1 if args.quick else 3)
    print(
        f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs; "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}"
    )
    for name in robots:
        bench_robot(name, repeats, args.accuracy, 0.1 if args.quick else 1.0)


if __name__ == "__main__":
    main()
