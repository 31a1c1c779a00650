"""Every example runs in its --smoke mode (as the README promises)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

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


PANDA = Path(__file__).resolve().parents[2] / "shared/data/panda_gaz2019"


def test_real_panda_example():
    """Real data (read in place from ../shared, never copied): held-out torque
    error of every method within 1.2x of OLS and of the published range
    (0.06 .. 0.23 N m per joint, with a 10 % allowance at 200 Hz)."""
    import pytest

    if not (PANDA / "trajectory1.csv").exists():
        pytest.skip(f"the real Panda log is not beside the repository ({PANDA})")
    errors = load_example("real_panda").main(["--smoke", "--data", str(PANDA)])
    for method in ("wls", "physical"):
        assert np.max(errors[method] / errors["ols"]) <= 1.2
    assert errors["ols"].max() < 0.25 and errors["ols"].min() > 0.03
