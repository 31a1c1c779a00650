"""Every example runs in its --smoke mode (as the README promises)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load_example(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_robot_models_example(tmp_path):
    worst = load_example("robot_models").main(["--smoke", "--out", str(tmp_path)])
    assert set(worst) >= {"rv3sb", "demo_rh"}
    assert max(worst.values()) < 1e-12
    assert (tmp_path / "rv3sb.html").stat().st_size > 10_000
