"""The paper's kinematic-calibration study (Wang et al. 2016, §4, Fig. 3).

RV-3SB with errors on the 17 parameters of Table 1 (1.6 mm mean tool error),
5 plates x 12 range-finder readings, 2 um noise; calibrated by the paper's
method (DE on tetrahedron volumes), by LM on point-to-plane distances and by
DE+LM; repeated over 20 seeds. Prints the table, writes a Fig. 3-style PNG and
a Meshcat HTML. The study itself is :func:`rmdrake.calibration.run_paper_study`.

    python examples/kinematic_calibration.py --out out/kinematic_calibration
    python examples/kinematic_calibration.py --smoke   # seconds, for tests
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _split(text: str) -> list[str]:
    return [m.strip() for m in text.split(",") if m.strip()]


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the study; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/kinematic_calibration")
    parser.add_argument("--seeds", type=int, default=20, help="scenario seeds")
    parser.add_argument(
        "--methods", default="de,lm,de+lm", help="comma-separated: de, lm, de+lm"
    )
    parser.add_argument(
        "--repeat-methods",
        default=None,
        help="methods run on the seeds after the first (default: all)",
    )
    parser.add_argument("--no-html", action="store_true", help="skip Meshcat HTML")
    parser.add_argument("--smoke", action="store_true", help="tiny and fast")
    args = parser.parse_args(argv)

    from rmdrake.calibration import run_paper_study

    run_paper_study(
        args.out,
        seeds=args.seeds,
        methods=_split(args.methods),
        repeat_methods=None
        if args.repeat_methods is None
        else _split(args.repeat_methods),
        smoke=args.smoke,
        html=not args.no_html,
        progress=not args.smoke,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
