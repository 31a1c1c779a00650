"""URDF import speed: :func:`rmdrake.model.urdf.importer.robot_from_urdf` on the TIAGo
URDF
(57 links, torso + 7R arm = 8 joints, head, wheels, casters and gripper lumped or
ignored) and on a 7-joint generated URDF (random axes and origins, one fixed
joint inside the chain), and the export of the imported TIAGo. Target: under
2 s each. ``--quick`` (for CI) times 2 calls of each instead of 5. Run:

    OPENBLAS_NUM_THREADS=1 python bench/urdf.py [--tiago PATH] [--repeats 5] [--quick]

Times are the best and the median of ``--repeats`` calls (Drake's module import
excluded, the file parse included).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmdrake.model.urdf.importer import robot_from_urdf, robot_to_urdf  # noqa: E402

TIAGO = Path("/work/shared/data/tiago_figaroh/tiago.urdf")


def seven_joint_urdf(seed: int = 0) -> str:
    """A 7R arm with random axes, origins and rpy and a fixed joint mid-chain."""
    rng = np.random.default_rng(seed)
    f = lambda v: " ".join(repr(float(x)) for x in v)  # noqa: E731
    names = ["base", *(f"l{j}" for j in range(1, 8)), "flange", "tool"]
    out = ['<robot name="seven">']
    for name in names:
        out.append(
            f'<link name="{name}"><inertial><mass value="1.5"/><origin xyz="0.05 0 0"'
            ' rpy="0 0 0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0"'
            ' izz="0.02"/></inertial></link>'
        )
    for j in range(1, 8):
        out.append(
            f'<joint name="j{j}" type="revolute"><parent link="{names[j - 1]}"/>'
            f'<child link="{names[j]}"/><origin xyz="{f(rng.uniform(-0.3, 0.3, 3))}"'
            f' rpy="{f(rng.uniform(-3, 3, 3))}"/><axis xyz="{f(rng.normal(size=3))}"/>'
            '<limit lower="-2" upper="2" velocity="2" effort="50"/></joint>'
        )
    for a, b in (("l7", "flange"), ("flange", "tool")):
        out.append(
            f'<joint name="{b}_joint" type="fixed"><parent link="{a}"/><child '
            f'link="{b}"/><origin xyz="0 0 0.1" rpy="0.1 0.2 0.3"/></joint>'
        )
    return "\n".join([*out, "</robot>"])


def _time(fn, repeats: int) -> tuple[float, float]:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiago", type=Path, default=TIAGO)
    ap.add_argument("--repeats", type=int, help="default 5 (2 with --quick)")
    ap.add_argument("--quick", action="store_true", help="fewer repeats, for CI")
    args = ap.parse_args()
    repeats = args.repeats or (2 if args.quick else 5)
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        seven = Path(tmp) / "seven.urdf"
        seven.write_text(seven_joint_urdf())
        cases = [("7-joint test URDF", seven, "base", "tool")]
        if args.tiago.is_file():
            cases.insert(0, ("TIAGo (8 joints)", args.tiago, "base_footprint",
                             "wrist_ft_tool_link"))  # fmt: skip
        else:
            print(f"{args.tiago} not found: TIAGo skipped")
        for label, path, base, tip in cases:
            best, med = _time(
                lambda p=path, b=base, t=tip: robot_from_urdf(p, base=b, tip=t),
                repeats,
            )
            print(f"import {label:20s} best {best * 1e3:8.1f} ms  median "
                  f"{med * 1e3:8.1f} ms  (target < 2000 ms)")  # fmt: skip
            model = robot_from_urdf(path, base=base, tip=tip)
            best, med = _time(lambda m=model: robot_to_urdf(m), repeats)
            print(f"export {label:20s} best {best * 1e3:8.1f} ms  median "
                  f"{med * 1e3:8.1f} ms")  # fmt: skip


if __name__ == "__main__":
    main()
