"""The installed package is the whole package: every module and data file under
``src/rmdrake`` is in the installed distribution (the wheel's RECORD), and the
console script is declared. A package or data file left out of the build fails
here, before any user's import does."""

from __future__ import annotations

from importlib.metadata import distribution
from pathlib import Path

import pytest

import rmdrake

SRC = Path(__file__).resolve().parents[1] / "src"


def _source_files() -> set[str]:
    return {
        p.relative_to(SRC).as_posix()
        for p in (SRC / "rmdrake").rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
    }


@pytest.mark.skipif(
    Path(rmdrake.__file__).resolve().is_relative_to(SRC),
    reason="rmdrake is installed editable (make dev): no wheel to check",
)
def test_the_installed_distribution_holds_every_source_file():
    dist = distribution("rmdrake")
    installed = {f.as_posix() for f in dist.files or ()}
    sources = _source_files()
    assert len(sources) > 150, "source tree not found"
    assert not sources - installed, "left out of the wheel"
    assert "rmdrake/model/shipped/rv3sb.yaml" in installed
    assert "rmdrake/systems/station.py" in installed


def test_the_console_script_is_declared():
    (script,) = [e for e in distribution("rmdrake").entry_points if e.name == "rmdrake"]
    assert script.group == "console_scripts"
    assert script.load()(["--version"]) == 0
