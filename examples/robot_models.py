"""The shipped robot models: summary, numpy kinematics vs Drake, Meshcat HTML.

    python examples/robot_models.py --out out/examples [--smoke] [--robot R ...]

Loads each shipped robot (or each ``--robot``, a shipped name or a robot YAML,
revolute and prismatic joints alike), checks the vectorised MDH forward
kinematics against the Drake MultibodyPlant built from the same table on
random joint vectors within the limits (rad, or m for a prismatic joint), and
saves a Meshcat HTML of the robot at a few poses.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot, shipped_robots
from rmdrake.model.plant import TOOL_FRAME, MakePlant, joint_name
from rmdrake.systems.visualization import save_robot_poses_html
from rmdrake.threads import one_thread_per_pool


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/examples")
    parser.add_argument("--smoke", action="store_true", help="few poses, for tests")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--robot",
        action="append",
        help="a shipped name or a robot YAML (repeat it; default: every shipped one)",
    )
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    n_poses = 5 if args.smoke else 200
    worst = {}
    for robot in args.robot or shipped_robots():
        model = load_robot(robot)
        name = model.name
        plant, _ = MakePlant(model, visual=False)
        context = plant.CreateDefaultContext()
        tool = plant.GetFrameByName(TOOL_FRAME)
        lo, hi = model.limits.lower, model.limits.upper
        q = rng.uniform(lo, hi, (n_poses, model.n_joints))
        X_numpy = tool_poses(model.table, q, sigma=model.sigma)
        # Each joint's position by its index: an elastic joint is two plant
        # joints (motor side joint<j>, link side joint<j>_link, deflection 0).
        index = [
            plant.GetJointByName(joint_name(j)).position_start()
            for j in range(1, model.n_joints + 1)
        ]
        q_plant = np.zeros(plant.num_positions())
        err = 0.0
        for k in range(n_poses):
            q_plant[index] = q[k]
            plant.SetPositions(context, q_plant)
            X = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
            err = max(err, float(np.abs(X.GetAsMatrix4() - X_numpy[k]).max()))
        worst[name] = err
        reach = np.linalg.norm(X_numpy[:, :3, 3], axis=1).max()
        html = save_robot_poses_html(model, q[:4], Path(args.out) / f"{name}.html")
        print(
            f"{name:>8}: {n_poses} poses, max |X_numpy - X_drake| = {err:.2e}, "
            f"max reach {reach:.3f} m, scene {html}"
        )
    return worst


if __name__ == "__main__":
    one_thread_per_pool()  # small matrices: one BLAS thread is fastest
    main()
