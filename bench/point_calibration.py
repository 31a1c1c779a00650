"""Point calibration (laser tracker) speed and accuracy, and the TIAGo figures.

Synthetic: RV-3SB, 50 poses x 3 markers, 20 um noise per coordinate, true
errors of 0.3 mm / 0.3 mrad on the point-identifiable ``full`` set. Prints the
fit time (median and best of ``--repeats``, data simulated beforehand), the
held-out marker error on 30 new poses (3-D RMS, against 2 x the noise), and the
spread of each parameter over ``--seeds`` noise seeds against its mean
reported std. Then, if the data folder exists, the TIAGo table of
examples/real_tiago.py. ``--quick`` (for CI): 3 fits on 3 noise seeds, and the
TIAGo table with 2 folds, its ``auto`` row without the nested cross-validation
(the selection's own CV only). Run:

    OPENBLAS_NUM_THREADS=1 python bench/point_calibration.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.calibration.points.data import PointMeasurements, read_point_measurements  # noqa: E402
from rmdrake.calibration.points.identifiability import (  # noqa: E402
    analyse_point_identifiability,
)
from rmdrake.calibration.points.lm import PointLM  # noqa: E402
from rmdrake.calibration.points.selection import cross_validate  # noqa: E402
from rmdrake.calibration.points.simulate import simulate_points  # noqa: E402
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot  # noqa: E402

NOISE = 2e-5
TIAGO = Path(__file__).resolve().parents[2] / "shared" / "data" / "tiago_figaroh"


def synthetic(repeats: int, seeds: int) -> None:
    nominal = load_robot("rv3sb")
    probe = simulate_points(nominal, poses=50, markers=3, noise=0, seed=7).data
    full = error_parameter_names(nominal, "full")
    names = analyse_point_identifiability(nominal, probe, full).identifiable
    deltas = 3e-4 * np.random.default_rng(3).standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    clean = simulate_points(true, poses=50, markers=3, noise=0, seed=7)
    d = clean.data
    held = simulate_points(true, poses=30, markers=3, noise=0, seed=7)
    held_q = simulate_points(true, poses=30, markers=3, noise=0, seed=8).data.q
    from rmdrake.calibration.points.problem import predict_points

    p_held = predict_points(
        true.table, held_q, held.markers[held.data.marker - 1], clean.R_IB, clean.p_IB
    )
    held_data = PointMeasurements(held.data.pose, held.data.marker, held_q, p_held)
    rng = np.random.default_rng(11)
    values, stds, held_rms, times = [], [], [], []
    for s in range(max(seeds, repeats)):
        data = PointMeasurements(
            d.pose,
            d.marker,
            d.q,
            clean.p_I + NOISE * rng.standard_normal((d.n_rows, 3)),
        )
        t0 = time.perf_counter()
        est = PointLM(nominal, params="full").fit(data)
        times.append(time.perf_counter() - t0)
        if s < seeds:
            values.append(est.deltas_)
            stds.append(est.std_)
            e = np.linalg.norm(held_data.p_I - est.predict(held_data), axis=1)
            held_rms.append(np.sqrt(np.mean(e**2)))
    unknowns = len(est.names_) + 6 + 3 * 3
    print(
        f"RV-3SB, 50 poses x 3 markers, noise {NOISE * 1e6:g} um: {len(est.names_)} "
        f"error parameters + 6 instrument + 9 marker = {unknowns} unknowns"
    )
    print(
        f"  fit time: median {np.median(times) * 1e3:.1f} ms, best "
        f"{np.min(times) * 1e3:.1f} ms over {len(times)} fits (target < 500 ms)"
    )
    print(
        f"  held-out marker error (30 new poses, 3-D RMS): mean over seeds "
        f"{np.mean(held_rms) * 1e6:.2f} um, worst {np.max(held_rms) * 1e6:.2f} um "
        f"(target <= 2 x noise = {2 * NOISE * 1e6:.0f} um)"
    )
    ratio = np.std(values, axis=0, ddof=1) / np.mean(stds, axis=0)
    inside = int(np.sum((ratio > 1 / 1.5) & (ratio < 1.5)))
    print(
        f"  spread over {seeds} seeds / mean reported std: median "
        f"{np.median(ratio):.3f}, range {ratio.min():.3f}..{ratio.max():.3f}, "
        f"{inside} of {ratio.size} within a factor 1.5"
    )


def tiago(folder: Path, folds: int, nested: bool = True) -> None:
    """The TIAGo table: per parameter set, the train RMS and the ``folds``-fold
    CV RMS over poses (for ``auto``, nested: the choice rerun in each training
    set; ``nested`` False skips that CV, the costliest part, and prints -)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(
            folder / "tiago.urdf", base="base_footprint", tip="wrist_ft_tool_link"
        )
    data = read_point_measurements(folder / "points_2021-11-30.csv", robot.n_joints)
    print(f"TIAGo (real motion capture), {folds}-fold CV over poses, seed 0, mm:")
    for params in ("base", "offsets", "full", "auto"):
        t0 = time.perf_counter()
        est = PointLM(robot, params=params, folds=folds).fit(data)
        cv_figures = "CV RMS -, max -"
        if nested or params != "auto":
            cv = cross_validate(
                lambda p=params: PointLM(robot, params=p, folds=folds),
                data,
                folds=folds,
            )
            cv_figures = f"CV RMS {cv.rms * 1e3:.3f}, max {cv.max * 1e3:.3f}"
        extra = ""
        if params == "auto":
            extra = (
                f" chose {est.selection_.label} ({', '.join(est.names_)}), "
                f"selection CV {est.selection_.cv_rms * 1e3:.3f}"
                + ("; CV above nested" if nested else "")
            )
        print(
            f"  {params:<8} k={len(est.names_):>2} train RMS "
            f"{est.residual_rms_ * 1e3:.3f}, {cv_figures} "
            f"({time.perf_counter() - t0:.1f} s){extra}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, help="timed fits (20; quick 3)")
    parser.add_argument("--seeds", type=int, help="noise seeds (20; quick 3)")
    parser.add_argument("--tiago", type=Path, default=TIAGO, help="data folder")
    parser.add_argument("--folds", type=int, help="TIAGo CV folds (5; quick 2)")
    parser.add_argument(
        "--quick", action="store_true", help="CI size: fewer fits, no nested CV"
    )
    args = parser.parse_args()
    small = 3 if args.quick else 20
    synthetic(args.repeats or small, args.seeds or small)
    if args.tiago.is_dir():
        tiago(args.tiago, args.folds or (2 if args.quick else 5), nested=not args.quick)
    else:
        print(f"{args.tiago} not found: TIAGo skipped")


if __name__ == "__main__":
    main()
