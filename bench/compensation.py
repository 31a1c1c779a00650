"""Joint-target correction speed: batched throughput, one warm-started target,
a whole path, the controllers, ``rmdrake correct`` and closed-loop tracking. Run:

    OPENBLAS_NUM_THREADS=1 python bench/compensation.py [--quick]

The robot is the RV-3SB; the calibrated model is the nominal plus random
deltas (sigma 1 mm, 1 mrad) on the paper's 17 parameters (3.7 mm mean tool
error, printed). Batch: 1000 random poses of the middle 80 % of the joint
ranges, the nominal tool poses as targets, the nominal joints as seeds (program
filtering). Warm start: a 1000-point straight joint-space segment (0.3 mm tool
steps); target k is solved alone, seeded with the corrected joints of target
k-1, their linear extrapolation 2 q_{k-1} - q_{k-2} (what correct_path does),
or the nominal joints of k plus the correction of k-1 (a filtering controller).
Times are the best of ``--repeats`` (batch) or best and median over the path.
``rmdrake correct`` runs on 1000 poses of the middle 80 % away from
singularities (tool Jacobian sigma_min >= 0.05, as the compensation study's
targets: near one, the correction of a few mm can exceed what the command
accepts); a failing command stops the bench.

``--quick`` (for CI): 200 batch targets, a 200-point segment (same steps), 200
poses for ``rmdrake correct``, best of 2, and tracking by the nominal and full
controllers at 40 rad/s only.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.compensation.correction import correct_path, correct_targets  # noqa: E402
from rmdrake.kinematics.forward import tool_poses  # noqa: E402
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot  # noqa: E402


def best_time(fn, repeats: int) -> tuple[float, object]:
    """Best wall time of ``repeats`` calls (s) and the last result."""
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def histogram(iterations: np.ndarray) -> str:
    counts = np.bincount(iterations)
    return " ".join(f"{i}:{c}" for i, c in enumerate(counts) if c)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="rv3sb")
    parser.add_argument("--repeats", type=int, help="default 10 (2 with --quick)")
    parser.add_argument("--quick", action="store_true", help="CI size")
    args = parser.parse_args()
    repeats = args.repeats or (2 if args.quick else 10)
    M = 200 if args.quick else 1000  # batch targets, path points, CLI targets
    nominal = load_robot(args.robot)
    rng = np.random.default_rng(0)
    names = error_parameter_names(nominal, "paper")
    calibrated = apply_deltas(nominal, names, 1e-3 * rng.standard_normal(len(names)))
    lo, hi = nominal.limits.lower, nominal.limits.upper
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (M, nominal.n_joints))
    X = tool_poses(nominal.table, q, sigma=nominal.sigma)
    e0 = np.linalg.norm(
        tool_poses(calibrated.table, q, sigma=calibrated.sigma)[:, :3, 3] - X[:, :3, 3],
        axis=1,
    )
    print(
        f"robot {nominal.name}; initial tool error {np.mean(e0) * 1e3:.2f} mm mean, "
        f"{e0.max() * 1e3:.2f} mm max"
    )
    print(f"batch of {M} targets, best of {repeats}")
    for label, R in (("positions", None), ("full poses", X[:, :3, :3])):
        t, c = best_time(
            lambda R=R: correct_targets(
                calibrated, X[:, :3, 3], q_seed=q, orientation=R
            ),
            repeats,
        )
        print(
            f"  {label:<11} {t * 1e3:7.2f} ms  {M / t:9.0f} targets/s  "
            f"unreachable {c.unreachable.size}  iterations {histogram(c.iterations)}"
        )

    qa = np.array([0.3, 0.2, 1.2, 0.4, 0.9, 0.1])
    qb = np.array([-0.5, 0.6, 0.8, -0.3, 1.2, 0.8])
    # M points of the 1000-point segment from qa to qb (the same steps)
    q_nom = qa + np.linspace(0.0, (M - 1) / 999, M)[:, None] * (qb - qa)
    Xp = tool_poses(nominal.table, q_nom, sigma=nominal.sigma)
    step = np.linalg.norm(np.diff(Xp[:, :3, 3], axis=0), axis=1).mean()
    print(f"one warm-started target along a path ({step * 1e3:.2f} mm steps)")
    for label, pose in (("positions", False), ("full poses", True)):
        for seed_name in ("previous solution", "extrapolated", "nominal + last dq"):
            q_corr, times, its = q_nom.copy(), [], []
            for k in range(2, q_nom.shape[0]):
                seed = {
                    "previous solution": q_corr[k - 1],
                    "extrapolated": 2.0 * q_corr[k - 1] - q_corr[k - 2],
                    "nominal + last dq": q_nom[k] + q_corr[k - 1] - q_nom[k - 1],
                }[seed_name]
                R = Xp[k : k + 1, :3, :3] if pose else None
                t0 = time.perf_counter()
                c = correct_targets(
                    calibrated, Xp[k : k + 1, :3, 3], q_seed=seed[None], orientation=R
                )
                times.append(time.perf_counter() - t0)
                q_corr[k], its = c.q[0], its + [c.iterations[0]]
            us = np.array(times) * 1e6
            print(
                f"  {label:<11} seed {seed_name:<22} best {us.min():6.0f} us, "
                f"median {np.median(us):6.0f} us, iterations {histogram(np.array(its))}"
            )
    print(f"whole path of {M} targets")
    for label, R in (("positions", None), ("full poses", Xp[:, :3, :3])):
        t, c = best_time(
            lambda R=R: correct_path(
                calibrated, Xp[:, :3, 3], q_start=q_nom[0], orientation=R
            ),
            max(1, repeats // 5),
        )
        print(
            f"  {label:<11} correct_path (sequential, extrapolated seeds) "
            f"{t * 1e3:7.1f} ms, iterations {histogram(c.iterations)}"
        )
        # The alternative: sweeps of the batched solver, target k seeded with
        # the solution of k-1 from the previous sweep, until a sweep changes
        # nothing (1e-9 rad). A redundant (position-only) target set moves its
        # null-space drift on by one target per sweep.
        t0, seeds, previous = time.perf_counter(), np.repeat(q_nom[:1], M, 0), None
        for sweep in range(1, 21):  # noqa: B007 (the count is reported)
            c = correct_targets(calibrated, Xp[:, :3, 3], q_seed=seeds, orientation=R)
            if previous is not None and np.abs(c.q - previous).max() < 1e-9:
                break
            previous, seeds = c.q, np.vstack([q_nom[:1], c.q[:-1]])
        done = "" if sweep < 20 else " (not settled)"
        print(
            f"  {label:<11} batched sweeps {sweep} sweeps{done} "
            f"{(time.perf_counter() - t0) * 1e3:7.1f} ms"
        )

    controller_speed(nominal, repeats)
    cli_throughput(nominal, calibrated, M)
    variants = (
        ("nominal", "full")
        if args.quick
        else ("nominal", "kinematic", "full", "oracle")
    )
    tracking_speed(nominal, variants, (40.0,) if args.quick else (40.0, 10.0))


def cli_throughput(nominal, calibrated, count: int) -> None:
    """``rmdrake correct`` on ``count`` tool poses (position and RPY), end to
    end: reading the CSV, the nominal multi-start IK seeds, the correction on
    the calibrated model, writing the joint program (poses near a joint limit
    that the calibrated robot cannot reach, if any, are named and left out).

    The poses are random in the middle 80 % of the joint ranges with the tool
    Jacobian's smallest singular value >= 0.05 (m/rad; the compensation
    study's targets), seed 0.

    Raises:
      RuntimeError: the command failed (its message is printed above).
    """
    import tempfile

    from rmdrake.cli.commands import main as rmdrake_main
    from rmdrake.compensation.correction import rpy_from_rotation
    from rmdrake.compensation.programs import ToolTargets, write_tool_targets
    from rmdrake.studies.compensation import held_out_configurations

    q = held_out_configurations(nominal, count, margin=0.1, min_singular=0.05, seed=0)
    X = tool_poses(nominal.table, q, sigma=nominal.sigma)
    with tempfile.TemporaryDirectory() as tmp:
        targets = Path(tmp) / "targets.csv"
        write_tool_targets(
            targets, ToolTargets(X[:, :3, 3], rpy_from_rotation(X[:, :3, :3]), None)
        )
        robot = Path(tmp) / "calibrated.yaml"
        calibrated.save(robot)
        argv = ["correct", "--robot", str(robot), "--targets", str(targets)]
        argv += ["--out", str(Path(tmp) / "q.csv"), "--nominal", nominal.name]
        argv += ["--allow-unreachable"]  # poses near the limits may be
        t0 = time.perf_counter()
        code = rmdrake_main(argv)
        wall = time.perf_counter() - t0
    if code != 0:
        raise RuntimeError(f"rmdrake correct failed (exit {code})")
    print(
        f"rmdrake correct, {count} tool poses end to end: "
        f"{wall:.2f} s, {count / wall:.0f} targets/s"
    )


def tracking_speed(
    nominal, variants: tuple[str, ...], bandwidths: tuple[float, ...]
) -> None:
    """Closed-loop station simulation speed of the tracking study: the true
    robot (1.6 mm kinematic errors, dynamics 10-30 % off) along the study's
    0.2 m circle about the tool at ``cube_q`` (plane normal (1, 0, 1) in B) at
    0.9 of the joint limits, per controller variant and feedback bandwidth
    (rad/s)."""
    from rmdrake.studies.calibration import draw_true_robot
    from rmdrake.studies.closed_loop import ClosedLoopModels
    from rmdrake.studies.identification import perturb_dynamics
    from rmdrake.studies.scenarios import (
        CalibrationStudyConfig,
        CompensationStudyConfig,
        stream,
    )
    from rmdrake.studies.tracking import plan_step, setup_step, track_path

    draw = draw_true_robot(nominal, CalibrationStudyConfig(), 0)
    true = perturb_dynamics(draw.true, stream(0, 1))
    models = ClosedLoopModels(nominal, true, true, {"ols": true, "physical": true})
    study = CompensationStudyConfig()
    setup = setup_step(nominal, study)
    program = plan_step(nominal, setup, study.tracking, "circle", 0.9)
    print(f"closed-loop tracking, circle {program.duration:.2f} s simulated:")
    runs = [(v, True) for v in variants] + [("kinematic", False)]
    for variant, ahead in runs:
        for w in bandwidths:
            run = track_path(
                study.station, program, models, variant, bandwidth=w,
                correction_ahead=ahead,
            )  # fmt: skip
            label = variant if ahead else f"{variant} online"
            print(
                f"  {label:<16} {w:4.0f} rad/s: {run.wall_time:5.2f} s wall, "
                f"{program.duration / run.wall_time:5.2f} simulated s/s"
            )


def controller_speed(nominal, repeats: int) -> None:
    """One evaluation of the compensation controller's torque (6 joints: inverse
    dynamics of the identified plant, friction feedforward, feedback) and the
    closed-loop simulation speed of examples/compensation_in_your_diagram.py."""
    from rmdrake.systems import CalibratedCompensationController

    ctrl = CalibratedCompensationController(nominal=nominal, identified=nominal)
    context = ctrl.CreateDefaultContext()
    rng = np.random.default_rng(0)
    ports = [ctrl.GetInputPort(p) for p in ("estimated_state", "desired_state")]
    accel = ctrl.GetInputPort("desired_acceleration")
    actuation = ctrl.GetOutputPort("actuation")

    def evaluate() -> None:
        for port in ports:
            port.FixValue(context, rng.uniform(-1, 1, 12))
        accel.FixValue(context, rng.uniform(-1, 1, 6))
        actuation.Eval(context)

    t, _ = best_time(lambda: [evaluate() for _ in range(100)], repeats)
    print(f"controller torque (6 joints, inputs changed each call): {t * 1e4:.1f} us")
    from rmdrake.systems.correction import JointTargetCorrection

    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(1).standard_normal(len(names))
    fix_calibrated = apply_deltas(nominal, names, deltas)
    fix = JointTargetCorrection(nominal=nominal, calibrated=fix_calibrated)
    fctx = fix.CreateDefaultContext()
    q = np.array([0.2, 0.3, 0.8, 0.4, 0.9, -0.3])
    fix.GetInputPort("desired_state").FixValue(fctx, np.r_[q, np.zeros(6)])
    fix.GetInputPort("desired_acceleration").FixValue(fctx, np.zeros(6))
    values = fix.AllocateDiscreteVariables()

    def update() -> None:  # one exact solve, warm-started from the last one
        fix.CalcForcedDiscreteVariableUpdate(fctx, values)
        fctx.SetDiscreteState(values)
        q[:] += 1e-3  # the program moves on by 1 mrad per joint
        fix.GetInputPort("desired_state").FixValue(fctx, np.r_[q, np.zeros(6)])

    t, _ = best_time(lambda: [update() for _ in range(20)], repeats)
    print(f"online correction, one exact update (warm-started): {t * 1e6 / 20:.0f} us")
    out = fix.GetOutputPort("corrected_state")

    def output() -> None:
        fix.GetInputPort("desired_state").FixValue(fctx, np.r_[q, np.zeros(6)])
        out.Eval(fctx)

    t, _ = best_time(lambda: [output() for _ in range(100)], repeats)
    print(f"online correction, one output between updates: {t * 1e4:.1f} us")
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.systems.correction import PresolvedTargetCorrection

    program = PiecewisePolynomial.FirstOrderHold(
        [0.0, 10.0], np.stack([q, q + 0.5], axis=1)
    )  # 10 s: 1001 updates of 10 ms
    t, _ = best_time(
        lambda: PresolvedTargetCorrection(
            nominal=nominal, calibrated=fix_calibrated, program=program
        ),
        repeats,
    )
    print(f"correction solved ahead, 1001 updates (10 s of program): {t:.3f} s")
    spec = importlib.util.spec_from_file_location(
        "example", Path(__file__).resolve().parents[1] / "examples"
        / "compensation_in_your_diagram.py",
    )  # fmt: skip
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    t0 = time.perf_counter()
    example.main([])
    wall = time.perf_counter() - t0
    print(
        f"closed loop, 3 runs x 4.5 s simulated (incl. calibration and the "
        f"program filtering): {wall:.2f} s wall, {13.5 / wall:.2f} simulated s/s"
    )


if __name__ == "__main__":
    main()
