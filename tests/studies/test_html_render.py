"""What users see: each kind of saved Meshcat page renders in a real browser.

Every page rmdrake writes (the robot of ``rmdrake show``, the calibration scene,
the excitation poses, the tracking scene) is loaded offline (``file://``) in
headless Debian chromium driven by Playwright, with Meshcat's own three.js and
software WebGL (SwiftShader). The test waits for Meshcat's scene tree to hold
``drake`` (the robot), then checks the screenshot is a drawing and not a blank
page: many colours and contrast, and hiding each group of the scene (the robot,
the plates and points, the paths) changes a visible share of the pixels. Any
console error or uncaught page exception fails the test.

CI (``.ci/run``) installs chromium; without it this test fails and says how to
install it (it is never skipped).
"""

from __future__ import annotations

import io
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rmdrake.kinematics.forward import tool_points
from rmdrake.model.loading import load_robot

CHROMIUM = "/usr/bin/chromium"
INSTALL = (
    "install it with `sudo apt-get install --no-install-recommends chromium` "
    "(Debian/Ubuntu) and Playwright with `pip install -e '.[test]'`; "
    "do not run `playwright install`"
)
VIEWPORT = {"width": 800, "height": 600}
SET_VISIBLE = """([g, v]) => {
    window.viewer.scene_tree.find(g.split("/")).set_property("visible", v);
    window.viewer.set_dirty();
}"""


@pytest.fixture(scope="module")
def browser():
    """Headless chromium (Debian's), or a failure that says how to get it."""
    if not Path(CHROMIUM).exists():
        pytest.fail(f"the rendering test needs chromium at {CHROMIUM}: {INSTALL}")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail(f"the rendering test needs the playwright package: {INSTALL}")
    with sync_playwright() as p:
        # --use-gl=swiftshader renders blank; this flag keeps WebGL in software.
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            args=["--enable-unsafe-swiftshader", "--no-sandbox"],
        )
        yield b
        b.close()


def _image(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


def _render(browser, html: Path, groups: tuple[str, ...]) -> dict:
    """Loads ``html`` offline; returns the screenshot, the share of pixels each
    top-level scene group draws (changed when it is hidden) and the errors."""
    page = browser.new_page(viewport=VIEWPORT)
    errors: list[str] = []

    def on_console(message) -> None:
        if message.type == "error":
            errors.append(f"console.error: {message.text}")

    page.on("console", on_console)
    page.on("pageerror", lambda e: errors.append(f"pageerror: {e}"))
    try:
        page.goto(html.resolve().as_uri(), wait_until="load", timeout=60_000)
        page.wait_for_function(
            "g => window.viewer && window.viewer.scene_tree"
            " && g in window.viewer.scene_tree.children",
            arg=groups[0].split("/")[0],
            timeout=60_000,
        )
        top = page.evaluate("() => Object.keys(window.viewer.scene_tree.children)")
        page.wait_for_timeout(800)  # a few animation frames
        shot = _image(page.screenshot())
        drawn = {}
        for g in groups:
            page.evaluate(SET_VISIBLE, [g, False])
            page.wait_for_timeout(500)
            hidden = _image(page.screenshot())
            changed = np.abs(shot - hidden).sum(axis=2) > 30
            drawn[g] = float(changed.mean())
            page.evaluate(SET_VISIBLE, [g, True])
    finally:
        page.close()
    return {"shot": shot, "top": top, "drawn": drawn, "errors": errors}


def _robot_page(tmp_path: Path) -> Path:
    out = tmp_path / "rv3sb.html"
    cmd = [sys.executable, "-m", "rmdrake.cli", "show", "--robot", "rv3sb"]
    if shutil.which("rmdrake"):
        cmd = ["rmdrake", "show", "--robot", "rv3sb"]
    run = subprocess.run(
        [*cmd, "--html", str(out)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    return out


def _calibration_page(tmp_path: Path) -> Path:
    from rmdrake.systems.visualization import save_calibration_html

    model = load_robot("rv3sb")
    rng = np.random.default_rng(3)
    q = 0.3 * rng.uniform(-1.0, 1.0, (6, model.n_joints))
    points = tool_points(model.table, q)
    plates = []
    for normal in np.eye(3)[:2]:  # two plates through the points' centre
        X = np.eye(4)
        X[:3, :3] = np.roll(np.eye(3), 2 - int(np.argmax(normal)), axis=1)
        X[:3, 3] = points.mean(axis=0)
        plates.append((X, (0.2, 0.2)))
    sets = {"points": (points, (0.9, 0.1, 0.1, 1.0))}
    path = tmp_path / "calibration.html"
    return save_calibration_html(model, q, plates, sets, path)


def _excitation_page(tmp_path: Path) -> Path:
    from rmdrake.systems.visualization import save_robot_poses_html

    model = load_robot("demo_rh")
    lo, hi = model.limits.lower, model.limits.upper
    mid = 0.5 * (lo + hi)
    poses = mid + 0.3 * (hi - lo) * np.random.default_rng(1).uniform(-1, 1, (4, 1))
    return save_robot_poses_html(model, poses, tmp_path / "excitation.html")


def _elastic_page(tmp_path: Path) -> Path:
    """The elastic-arm study's page: an elastic robot drawn by its link side."""
    from rmdrake.dynamics.compliance import link_angles
    from rmdrake.systems.visualization import save_robot_states_html

    model = load_robot("demo_rh_elastic")
    q = np.array([0.0, 0.5, 0.3, 0.0, 0.6, 0.0])
    sag = link_angles(model, q) - q
    states = {"nominal": (q, 0.3), "deflected": (q + 20.0 * sag, 1.0)}
    return save_robot_states_html(model, states, tmp_path / "compliance.html")


def _tracking_page(tmp_path: Path) -> Path:
    from rmdrake.systems.visualization import save_path_html

    model = load_robot("rv3sb")
    t = np.linspace(0.0, 1.0, 12)
    q = np.outer(np.sin(np.pi * t), 0.4 * np.ones(model.n_joints))
    p = tool_points(model.table, q)
    lines = {
        "commanded": (p, (0.1, 0.4, 0.9, 1.0)),
        "reached": (p + [0.0, 0.0, 0.02], (0.9, 0.2, 0.1, 1.0)),
    }
    return save_path_html(model, t, q, lines, tmp_path / "tracking.html")


PAGES = {
    "robot": (_robot_page, ("drake",)),
    "calibration": (_calibration_page, ("drake", "calibration")),
    "excitation": (_excitation_page, ("drake",)),
    "tracking": (_tracking_page, ("drake", "paths")),
    "elastic": (_elastic_page, ("drake/nominal (grey)", "drake/deflected (red)")),
}


@pytest.mark.parametrize("kind", list(PAGES))
def test_saved_page_renders_the_scene(browser, tmp_path, kind):
    make, groups = PAGES[kind]
    html = make(tmp_path)
    r = _render(browser, html, groups)
    assert not r["errors"], f"{kind}: browser errors: {r['errors']}"
    assert {g.split("/")[0] for g in groups} <= set(r["top"]), r["top"]
    shot = r["shot"]
    assert shot.shape[:2] == (VIEWPORT["height"], VIEWPORT["width"])
    colours = len(np.unique(shot.reshape(-1, 3), axis=0))
    # a blank page (white, black, or the background alone) has neither
    assert shot.std() > 10.0 and colours > 200, (kind, shot.std(), colours)
    # each group is drawn: hiding it changes a visible share of the pixels
    for g, share in r["drawn"].items():
        assert share > 2e-4, f"{kind}: /{g} draws {share:.2%} of the pixels"
