"""Regressor speed: samples per second for one batch on a shipped arm.

Side by side in one run, on the same arm and the same random (q, qd, qdd):

* rmdrake: :func:`rmdrake.dynamics.regressor`, one vectorised call for the batch
  (output (N, n, 13n), i.e. 13 columns per link including Ia, fv, fc);
* Pinocchio: ``computeJointTorqueRegressor`` called per sample in a Python loop,
  filling a preallocated (N, n, 10n) array (10 inertial columns per link); the
  model is built here from the MDH table (skipped if ``import pinocchio`` fails);
* Drake AutoDiff: ``CalcInverseDynamics`` on ``MultibodyPlant_[AutoDiffXd]`` with
  the 10 inertial parameters of every link and the rotor inertias as derivative
  variables (Jacobian d tau / d chi = Y), on a few samples, extrapolated.

Every figure is the best of ``--repeats`` rounds, each round running every route
once in turn so they all see the same load (the machine is shared); wall time and
CPU time (``time.process_time``, less sensitive to other processes) are both
printed, with the load average. ``--quick`` (for CI): a batch of 200 samples,
best of 3 rounds, 3 AutoDiff samples. Run:

    OPENBLAS_NUM_THREADS=1 python bench/regressor.py [--samples 1500 --repeats 20]
    OPENBLAS_NUM_THREADS=1 python bench/regressor.py --quick
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.dynamics import (  # noqa: E402
    SerialChain,
    base_parameters,
    regressor,
    standard_parameters,
)
from rmdrake.model.loading import load_robot  # noqa: E402
from rmdrake.model.plant import MakePlant, mdh_static_transform  # noqa: E402
from rmdrake.model.robot import RobotModel


def interleaved_best(routes: dict, rounds: int) -> dict:
    """Best wall and CPU (process) time per route, s, over ``rounds`` rounds that
    run every route once in turn, so that all routes see the same load."""
    best = {k: [np.inf, np.inf] for k in routes}
    for _ in range(rounds):
        for name, fn in routes.items():
            w0, c0 = time.perf_counter(), time.process_time()
            fn()
            w, c = time.perf_counter() - w0, time.process_time() - c0
            best[name] = [min(best[name][0], w), min(best[name][1], c)]
    return best


def pinocchio_model(model: RobotModel):
    """A Pinocchio model of the MDH chain (RZ joints, link frames = MDH frames)."""
    import pinocchio as pin

    pm = pin.Model()
    parent = 0
    chi = standard_parameters(model).reshape(-1, 13)
    for j, row in enumerate(model.mdh):
        X = mdh_static_transform(row)
        placement = pin.SE3(X.rotation().matrix(), X.translation())
        parent = pm.addJoint(parent, pin.JointModelRZ(), placement, f"joint{j + 1}")
        XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = chi[j, :10]
        # Pinocchio order: m, m c, then inertia about the joint origin
        # (Ixx, Ixy, Iyy, Ixz, Iyz, Izz).
        dyn = np.array([M, MX, MY, MZ, XX, XY, YY, XZ, YZ, ZZ])
        pm.appendBodyToJoint(
            parent, pin.Inertia.FromDynamicParameters(dyn), pin.SE3.Identity()
        )
    pm.gravity = pin.Motion(np.asarray(model.gravity), np.zeros(3))
    return pm


def pinocchio_column_map(n: int) -> np.ndarray:
    """rmdrake column of each Pinocchio regressor column (10 per link)."""
    order = [9, 6, 7, 8, 0, 1, 3, 2, 4, 5]  # m, MX, MY, MZ, XX, XY, YY, XZ, YZ, ZZ
    return np.array([13 * j + c for j in range(n) for c in order])


def autodiff_regressor(model: RobotModel):
    """A function (q, qd, qdd) -> Y (N, n, 11n: 10 inertial + Ia per link) by
    Drake AutoDiff, per sample (plant and parameter variables set up once)."""
    from pydrake.autodiffutils import AutoDiffXd
    from pydrake.multibody.tree import (
        MultibodyForces_,
        SpatialInertia_,
        UnitInertia_,
    )

    plant, _ = MakePlant(model, visual=False)
    ad = plant.ToAutoDiffXd()
    ctx = ad.CreateDefaultContext()
    n = model.n_joints
    chi = standard_parameters(model).reshape(n, 13)
    nv = 11 * n

    def var(value: float, i: int) -> AutoDiffXd:
        return AutoDiffXd(float(value), np.eye(nv)[i])

    for j in range(n):
        p = [var(chi[j, c], 11 * j + c) for c in range(10)]
        m = p[9]
        body = ad.GetBodyByName(f"link{j + 1}")
        M = SpatialInertia_[AutoDiffXd](
            m,
            np.array([p[6] / m, p[7] / m, p[8] / m]),
            UnitInertia_[AutoDiffXd](
                p[0] / m, p[3] / m, p[5] / m, p[1] / m, p[2] / m, p[4] / m
            ),
            True,
        )
        body.SetSpatialInertiaInBodyFrame(ctx, M)
        act = ad.GetJointActuatorByName(f"joint{j + 1}")
        act.SetRotorInertia(ctx, var(chi[j, 10], 11 * j + 10))

    def run(q, qd, qdd) -> np.ndarray:
        out = np.empty((len(q), n, nv))
        for i in range(len(q)):
            ad.SetPositions(ctx, [AutoDiffXd(v) for v in q[i]])
            ad.SetVelocities(ctx, [AutoDiffXd(v) for v in qd[i]])
            forces = MultibodyForces_[AutoDiffXd](ad)
            ad.CalcForceElementsContribution(ctx, forces)
            tau = ad.CalcInverseDynamics(ctx, [AutoDiffXd(v) for v in qdd[i]], forces)
            for j in range(n):
                out[i, j] = tau[j].derivatives()
        return out

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="rv3sb")
    parser.add_argument("--samples", type=int, help="batch size (1500; quick 200)")
    parser.add_argument("--repeats", type=int, help="rounds (20; quick 3)")
    parser.add_argument(
        "--autodiff-samples", type=int, help="AutoDiff samples (20; quick 3)"
    )
    parser.add_argument("--quick", action="store_true", help="CI size")
    args = parser.parse_args()
    repeats = args.repeats or (3 if args.quick else 20)
    model = load_robot(args.robot)
    n, N = model.n_joints, args.samples or (200 if args.quick else 1500)
    rng = np.random.default_rng(0)
    q = rng.uniform(model.limits.lower, model.limits.upper, (N, n))
    qd = rng.uniform(-model.limits.velocity, model.limits.velocity, (N, n))
    qdd = rng.uniform(-model.limits.acceleration, model.limits.acceleration, (N, n))
    chain = SerialChain.from_model(model)
    Y = regressor(chain, q, qd, qdd)
    print(
        f"robot {model.name}, n = {n}, batch N = {N}, best of {repeats} rounds; "
        f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} "
        f"on {os.cpu_count()} cores, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}"
    )
    base = base_parameters(chain)
    Y_out = np.empty_like(Y)
    routes = {
        "rmdrake regressor (N, n, 13n), one call": lambda: regressor(chain, q, qd, qdd),
        "rmdrake regressor, reused out= buffer": lambda: regressor(
            chain, q, qd, qdd, out=Y_out
        ),
        f"rmdrake base regressor (N, n, {base.count}), one call": lambda: (
            base.regressor(chain, q, qd, qdd)
        ),
    }
    try:
        import pinocchio as pin
    except ImportError:
        pin = None
        print("pinocchio not importable: its column is skipped")
    pin_label = "Pinocchio computeJointTorqueRegressor/sample"
    if pin is not None:
        pm = pinocchio_model(model)
        data = pm.createData()
        out = np.empty((N, n, 10 * n))

        def run_pin() -> None:
            for i in range(N):
                out[i] = pin.computeJointTorqueRegressor(pm, data, q[i], qd[i], qdd[i])

        run_pin()
        err = np.max(np.abs(out - Y[:, :, pinocchio_column_map(n)]))
        routes[pin_label] = run_pin
    best = interleaved_best(routes, repeats)

    K = args.autodiff_samples or (3 if args.quick else 20)
    ad_run = autodiff_regressor(model)
    Yad = ad_run(q[:K], qd[:K], qdd[:K])
    cols = np.array([13 * j + c for j in range(n) for c in range(11)])
    err_ad = np.max(np.abs(Yad - Y[:K][:, :, cols]))
    t_ad = interleaved_best({"ad": lambda: ad_run(q[:K], qd[:K], qdd[:K])}, 3)["ad"]
    best[f"Drake AutoDiff/sample ({K} timed, scaled)"] = [t * N / K for t in t_ad]

    ref = best.get(pin_label)
    print(
        f"{'route':<44} {'wall [ms]':>9} {'samples/s':>10} {'vs pin':>6}"
        f" {'CPU [ms]':>9} {'samples/s':>10} {'vs pin':>6}"
    )
    for label, (w, c) in best.items():
        rw = f"{ref[0] / w:6.2f}" if ref else "     -"
        rc = f"{ref[1] / c:6.2f}" if ref else "     -"
        rate_w, rate_c = N / w, N / c
        print(
            f"{label:<44} {w * 1e3:9.2f} {rate_w:10.4g} {rw}"
            f" {c * 1e3:9.2f} {rate_c:10.4g} {rc}"
        )
    if pin is not None:
        print(f"max |Y_rmdrake - Y_pinocchio| = {err:.2e} (same columns)")
    print(f"max |Y_rmdrake - Y_autodiff|  = {err_ad:.2e} (10 inertial + Ia columns)")
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
