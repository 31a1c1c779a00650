"""examples/kinematic_calibration.py on paper_smoke: the paper's study end to end in
seconds (table, Fig. 3 PNG, Meshcat HTML)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "kinematic_calibration.py"


def test_example_smoke(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("kinematic_calibration", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--scenario", "paper_smoke", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for label in ("paper: DE on volumes", "LM on plane distances", "DE + LM"):
        assert label in printed
    assert "paper (experiment)" in printed and "95th pct" in printed
    png = tmp_path / "kinematic_calibration_fig3.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (tmp_path / "kinematic_calibration.html").read_text()
    assert "<html" in html.lower() and len(html) > 10_000
