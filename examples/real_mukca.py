"""Real socket calibration of a Franka Panda (MUKCa data, 8 plate placements).

Imports MUKCa's Panda URDF (base ``panda_link0``, tip ``ball_link``: the ball's
centre is the tool point; the file is kinematic-only, every mass 0), reads the
recordings in place (one folder per placement, ``hole_0.csv`` and
``hole_1.csv``: the ball seated in each of the plate's two sockets, 50 mm
apart) and prints MUKCa's metrics: consistency (mean distance of the predicted
ball positions from their socket's mean, mm) and distortion (distance between
the two socket means minus 50 mm).

1. per parameter set: the nominal kinematics (``base``), the joint offsets,
   the identifiable ``full`` set and rmdrake's automatic choice: consistency
   on the training data (all placements) and on held-out placements (leave
   one placement out: each placement in turn is calibrated without and
   scored; ``auto`` reruns its choice inside each training set);
2. per placement, with the automatic choice: nominal, calibrated on all
   placements (training), calibrated on the other seven (held out), and
   calibrated on that placement alone, scored on the other seven;
3. MUKCa's own figures beside ours; with ``--out``, a bar figure per
   placement and a Meshcat scene (``mukca.html``: the arm visiting the
   recorded configurations, the fitted sockets, the predicted ball positions
   of the nominal and of the calibrated model).

Run from the repository root (about a minute):

    python examples/real_mukca.py [--data ../shared/data/mukca_panda] [--out out/mukca]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

from rmdrake.calibration.sockets.data import read_mukca_sockets
from rmdrake.calibration.sockets.lm import SocketLM, cross_validate_placements
from rmdrake.calibration.sockets.problem import socket_metrics
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.loading import load_robot
from rmdrake.report.plots import plot_socket_placements
from rmdrake.systems.visualization import save_calibration_html
from rmdrake.threads import one_thread_per_pool

ROOT = Path(__file__).resolve().parents[1]

MUKCA = {"training": (8.28e-3, 0.168e-3), "held out": (7.79e-3, 0.347e-3)}
"""MUKCa's README on another Panda ("panda_1"): mean absolute consistency
error before and after, m."""


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Prints the tables, writes the figure; returns {set: {"k", "train",
    "held_out", "held_out_rms", "distortion_mean", "distortion_abs"}} in m (the
    held-out figures leave one placement out)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data",
        type=Path,
        default=ROOT / ".." / "shared" / "data" / "mukca_panda",
        help="folder with panda.urdf and panda_2_clean/",
    )
    parser.add_argument("--out", type=Path, help="folder for the figure")
    args = parser.parse_args(argv)
    with warnings.catch_warnings():  # kinematic-only: the URDF has no masses
        warnings.simplefilter("ignore")
        robot = load_robot(
            args.data / "panda.urdf", base="panda_link0", tip="ball_link"
        )
    data, names = read_mukca_sockets(args.data / "panda_2_clean", n_joints=7)
    print(
        f"{robot.name}: {robot.n_joints} joints, {data.n_rows} configurations in "
        f"{data.socket_ids.size} sockets on {data.n_placements} placements "
        "(2 sockets 50 mm apart each); consistency = mean distance of the "
        "predicted ball from its socket's mean, mm"
    )
    print(
        f"{'parameters':<32} {'k':>3} {'training':>9} {'held out':>9} "
        f"{'(RMS)':>7} {'distortion mean':>16} {'mean |.|':>9}"
    )
    rows: dict[str, dict[str, float]] = {}
    fitted = {}
    nominal = socket_metrics(robot.table, data, sigma=robot.sigma)
    for label, params in (
        ("nominal kinematics", "base"),
        ("+ joint offsets", "offsets"),
        ("+ full identifiable set", "full"),
        ("automatic choice (nested CV)", "auto"),
    ):
        est = fitted[params] = SocketLM(robot, params=params).fit(data)
        cv = cross_validate_placements(lambda p=params: SocketLM(robot, params=p), data)
        rows[params] = {
            "k": len(est.names_),
            "train": est.metrics_.mean_abs,
            "held_out": cv.mean_abs,
            "held_out_rms": cv.rms,
            "distortion_mean": float(np.mean(cv.distortion)),
            "distortion_abs": float(np.mean(np.abs(cv.distortion))),
        }
        r = rows[params]
        print(
            f"{label:<32} {r['k']:>3} {r['train'] * 1e3:9.3f} "
            f"{r['held_out'] * 1e3:9.3f} {r['held_out_rms'] * 1e3:7.3f} "
            f"{r['distortion_mean'] * 1e3:+16.3f} {r['distortion_abs'] * 1e3:9.3f}",
            flush=True,
        )
    auto = est
    print(
        f"automatic choice on all placements: {auto.selection_.label} "
        f"({len(auto.names_)} parameters); not fitted: "
        + ", ".join(fitted["full"].identifiability_.dropped)
    )

    # Per placement, with the automatic choice.
    P, place = data.n_placements, data.placement
    train = np.array([auto.metrics_.errors[place == p].mean() for p in range(P)])
    before = np.array([nominal.errors[place == p].mean() for p in range(P)])
    held = np.array([cv.errors[place == p].mean() for p in range(P)])
    alone = np.zeros(P)
    print(
        f"\n{'placement':<14} {'rows':>4} {'nominal':>8} {'training':>9} "
        f"{'held out':>9} {'distortion':>11}   trained on it alone, on the others"
    )
    for p in range(P):
        one = SocketLM(robot, params="full").fit(data.of_placements([p]))
        others = data.of_placements([i for i in range(P) if i != p])
        alone[p] = socket_metrics(one.model_.table, others, sigma=robot.sigma).mean_abs
        print(
            f"{names[p]:<14} {int((place == p).sum()):>4} {before[p] * 1e3:8.3f} "
            f"{train[p] * 1e3:9.3f} {held[p] * 1e3:9.3f} "
            f"{cv.distortion[p] * 1e3:+11.3f}   {alone[p] * 1e3:8.3f} "
            f"({len(one.names_)} parameters)"
        )
    rows["one placement"] = {"held_out": float(np.mean(alone))}
    print(
        f"\nMUKCa's README (another Panda): training {MUKCA['training'][0] * 1e3:.2f} "
        f"-> {MUKCA['training'][1] * 1e3:.3f} mm, held out "
        f"{MUKCA['held out'][0] * 1e3:.2f} -> {MUKCA['held out'][1] * 1e3:.3f} mm; "
        f"here: training {nominal.mean_abs * 1e3:.2f} -> "
        f"{rows['auto']['train'] * 1e3:.3f} mm, held out "
        f"{np.mean(cv.before) * 1e3:.2f} -> {rows['auto']['held_out'] * 1e3:.3f} mm, "
        f"one placement alone {np.mean(alone) * 1e3:.3f} mm on the others"
    )
    if args.out is not None:
        path = plot_socket_placements(
            names,
            before,
            train,
            held,
            args.out / "mukca_placements.png",
            title="MUKCa Panda: mean consistency error per placement",
        )
        print(f"wrote {path}")
        sets = {
            "sockets (fitted)": (auto.sockets_, (0.1, 0.3, 0.9, 0.6)),
            "ball, nominal": (tool_points(robot.table, data.q), (0.9, 0.1, 0.1, 1.0)),
            "ball, calibrated": (
                tool_points(auto.model_.table, data.q),
                (0.1, 0.7, 0.2, 1.0),
            ),
        }
        path = save_calibration_html(
            robot, data.q[::4], [], sets, args.out / "mukca.html"
        )
        print(
            f"wrote {path} (sockets in blue, ball predicted by nominal red, "
            "calibrated green)"
        )
    return rows


if __name__ == "__main__":
    one_thread_per_pool()  # small matrices: one BLAS thread is fastest
    main()
