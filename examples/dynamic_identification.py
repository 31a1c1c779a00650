"""The paper's dynamic study with Drake as the robot (§3.2, §4; Fig. 4, 6, 7).

    python examples/dynamic_identification.py --out out/dynamics [--smoke]

Designs the RV-3SB's Fourier excitation by DE (eq. 16-17), runs it on a true
robot (nominal dynamics perturbed 10-30 %, friction, rotor inertia) in the Drake
station, identifies the base parameters with OLS, WLS, physically consistent
least squares and the paper's DE, and validates them on a different trajectory.
See :mod:`rmdrake.systems.identification_study` for every choice.
"""

from __future__ import annotations

import argparse

from rmdrake.systems.identification_study import METHODS, run_identification_study


def main(argv: list[str] | None = None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/dynamics")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--design-time",
        type=float,
        default=240.0,
        help="wall-time budget of the excitation DE, s",
    )
    parser.add_argument(
        "--noise",
        type=float,
        default=0.01,
        help="torque noise, fraction of each joint's peak",
    )
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument(
        "--smoke", action="store_true", help="token DE budgets, for tests"
    )
    parser.add_argument("--no-html", action="store_true")
    args = parser.parse_args(argv)
    return run_identification_study(
        args.out,
        seed=args.seed,
        noise=args.noise,
        design_time=args.design_time,
        smoke=args.smoke,
        methods=tuple(args.methods.split(",")),
        html=not args.no_html,
    )


if __name__ == "__main__":
    main()
