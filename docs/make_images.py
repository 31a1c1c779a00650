"""Regenerates the committed pictures of the README and the docs.

    .venv/bin/python docs/make_images.py            # all of them, 1-2 minutes

- ``_static/demo_calibration.png`` (also ``_static/figures/``): the demo's
  calibration study at the paper's budgets, on 2 of its 20 seeds;
- the other figure pages' PNGs in ``_static/figures/``: from ``rmdrake run
  --scenario paper_smoke`` (the demo's path with token budgets) and a small
  ``rmdrake plan``;
- ``_static/meshcat_rv3sb.png``: ``rmdrake show --robot rv3sb --html`` opened in
  Debian's chromium through Playwright (``/usr/bin/chromium``), captured once
  Meshcat's scene tree holds ``drake``.

Each PNG is downscaled to at most 1000 px wide and saved optimised (Pillow).
The tutorials draw their own figures when the docs are built; these pictures
are the ones a page shows without running anything.
"""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from PIL import Image

from rmdrake import load_robot
from rmdrake.studies import load_scenario, run_calibration_study

STATIC = Path(__file__).resolve().parent / "_static"
RMDRAKE = str(Path(sys.executable).with_name("rmdrake"))


def save(source: Path, target: Path, width: int = 1000) -> None:
    image = Image.open(source)
    if image.width > width:
        image = image.resize((width, round(image.height * width / image.width)))
    image = image.convert("RGB").quantize(colors=256)
    target.parent.mkdir(parents=True, exist_ok=True)
    image.save(target, optimize=True)
    print(f"wrote {target} ({target.stat().st_size // 1024} kB)")


def rmdrake(*args: str, cwd: Path) -> None:
    subprocess.run([RMDRAKE, *args], cwd=cwd, check=True)


def screenshot(html: Path, png: Path) -> None:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path="/usr/bin/chromium",
            args=["--enable-unsafe-swiftshader", "--no-sandbox"],
        )
        page = browser.new_page(viewport={"width": 1000, "height": 700})
        page.goto(html.as_uri(), wait_until="load", timeout=60_000)
        page.wait_for_function(  # as tests/studies/test_html_render.py
            "() => window.viewer && window.viewer.scene_tree"
            " && 'drake' in window.viewer.scene_tree.children",
            timeout=60_000,
        )
        page.wait_for_timeout(1500)
        page.screenshot(path=str(png))
        browser.close()


def main() -> int:
    work = Path(tempfile.mkdtemp(prefix="rmdrake-images-"))
    try:
        rmdrake("run", "--scenario", "paper_smoke", "--out", "demo", cwd=work)
        demo = work / "demo"
        figures = STATIC / "figures"
        # The calibration figure at the paper's budgets (the smoke run's DE has
        # a token one): the demo's first step, on 2 of its 20 seeds.
        paper = load_scenario(name="paper").calibration
        result = run_calibration_study(
            load_robot("rv3sb"),
            dataclasses.replace(paper, seeds=2),
            work / "paper",
            progress=False,
        )
        save(Path(result.png), STATIC / "demo_calibration.png")
        save(Path(result.png), figures / "kinematic_calibration_fig3.png")
        for name in (
            "dynamics/fig4_joint_trajectories.png",
            "dynamics/fig6_cartesian_path.png",
            "dynamics/fig7_torques.png",
            "compensation/static_accuracy_fig3.png",
            "compensation/tracking_seed0.png",
        ):
            source = demo / name
            if source.is_file():
                save(source, figures / Path(name).name)
            else:
                print(f"missing {source}", file=sys.stderr)
        plan = (
            "plan --robot rv3sb --robots 20 --plates 5 --noise 2e-6 --length-std 2e-4"
            " --angle-std 1e-3 --params paper --readings 40,60,120 --target 5e-5"
            " --out plan --workers 0 --no-progress"
        )
        rmdrake(*plan.split(), cwd=work)
        save(work / "plan" / "plan.png", figures / "plan.png")
        rmdrake("show", "--robot", "rv3sb", "--html", "rv3sb.html", cwd=work)
        raw = work / "meshcat.png"
        screenshot(work / "rv3sb.html", raw)
        save(raw, STATIC / "meshcat_rv3sb.png")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
