"""The architecture's one rule, read from the source: imports point down the
layers cli -> studies -> systems -> core, never up (function-level imports
included)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RANK = {"core": 0, "systems": 1, "studies": 2, "cli": 3}


def _module_name(path: Path) -> str:
    """Dotted module name of a source file (systems/ is rmdrake.systems)."""
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[0] == "systems":
        parts = ["rmdrake", *parts]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _layer(module: str) -> str:
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in ("cli", "studies", "systems"):
        return parts[1]
    if len(parts) > 1 and parts[1].startswith("cli_"):  # the CLI's own modules
        return "cli"
    return "core"


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
    return {n for n in names if n == "rmdrake" or n.startswith("rmdrake.")}


def _sources() -> list[Path]:
    files = sorted((ROOT / "rmdrake").rglob("*.py")) + sorted(
        (ROOT / "systems").rglob("*.py")
    )
    assert len(files) > 30, "source tree not found"
    return files


def test_layers_of_known_modules():
    assert _layer("rmdrake.cli") == "cli"
    assert _layer("rmdrake.studies.runner") == "studies"
    assert _layer("rmdrake.systems.station") == "systems"
    assert _layer("rmdrake.kinematics") == "core"
    assert _layer("rmdrake.cli_robots") == "cli"
    assert _layer("rmdrake") == "core"


def test_no_import_points_up():
    upward = []
    for path in _sources():
        here = _module_name(path)
        for target in _imports(path):
            if RANK[_layer(target)] > RANK[_layer(here)]:
                upward.append(f"{here} imports {target}")
    assert not upward, "imports pointing up the layers:\n" + "\n".join(upward)


def test_the_check_sees_an_upward_import(tmp_path):
    """The checker itself: an upward import in a core module is found."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from rmdrake.studies import runner\n")
    assert "rmdrake.studies" in _imports(bad)
    assert RANK[_layer("rmdrake.studies")] > RANK[_layer("rmdrake.kinematics")]


def test_modules_stay_small():
    """No module much over 450 lines; the CLI under 300 (parsing and printing)."""
    sizes = {p: len(p.read_text().splitlines()) for p in _sources()}
    big = [f"{p.relative_to(ROOT)}: {n}" for p, n in sizes.items() if n > 470]
    assert not big, "modules over about 450 lines:\n" + "\n".join(big)
    assert sizes[ROOT / "rmdrake" / "cli.py"] < 300
