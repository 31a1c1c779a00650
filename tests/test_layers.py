"""The architecture's rules, read from the source (function-level and
type-checking imports included):

- imports point down the layers cli -> studies -> pipelines -> systems -> core,
  never up;
- the import graph of ``rmdrake`` has no cycle;
- no module imports a private (``_name``) name from another module;
- a module imports a name from the module that defines it, not through a
  package's ``__init__`` (the ``__init__`` files re-export for users only), so
  the graph below is the one Python runs.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "src"
RANK = {"core": 0, "systems": 1, "pipelines": 2, "studies": 3, "cli": 4}
STAGE = {"model": 1, "kinematics": 2, "dynamics": 3, "calibration": 4}
STAGE |= {"excitation": 4, "compensation": 4, "report": 4}
"""Inside core, the pipeline's stages: the robot model, then kinematics, then
dynamics (with elastostatics), then the stages that use them. Everything else in
core (io/ and the top-level modules: arrays, errors, limits, optimize,
progress) is stage 0."""


def _module_name(path: Path) -> str:
    """Dotted module name of a source file under src/."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _sources() -> dict[str, Path]:
    files = sorted((ROOT / "rmdrake").rglob("*.py"))
    assert len(files) > 30, "source tree not found"
    return {_module_name(p): p for p in files}


MODULES = _sources()
PACKAGES = {m for m, p in MODULES.items() if p.name == "__init__.py"}


def _layer(module: str) -> str:
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in RANK:
        return parts[1]
    return "core"


def _imports(path: Path) -> list[tuple[str, str | None, int]]:
    """(module, imported name or None, line) of every rmdrake import."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            out += [(node.module, a.name, node.lineno) for a in node.names]
    return [i for i in out if i[0] == "rmdrake" or i[0].startswith("rmdrake.")]


def _target(module: str, name: str | None, modules=MODULES) -> str:
    """The module an import loads: ``from a import b`` loads ``a.b`` when that
    is a module, else ``a``."""
    if name is not None and f"{module}.{name}" in modules:
        return f"{module}.{name}"
    return module


def _graph(modules=MODULES) -> dict[str, set[str]]:
    return {
        m: {_target(mod, name, modules) for mod, name, _ in _imports(p)} - {m}
        for m, p in modules.items()
    }


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_layers_of_known_modules():
    assert _layer("rmdrake.cli.commands") == "cli"
    assert _layer("rmdrake.studies.runner") == "studies"
    assert _layer("rmdrake.pipelines.calibrate") == "pipelines"
    assert _layer("rmdrake.systems.station") == "systems"
    assert _layer("rmdrake.kinematics.forward") == "core"
    assert _layer("rmdrake.model.robot") == "core"
    assert _layer("rmdrake") == "core"


def test_no_import_points_up():
    upward = [
        f"{here} imports {target}"
        for here, path in MODULES.items()
        for target, _, _ in _imports(path)
        if RANK[_layer(target)] > RANK[_layer(here)]
    ]
    assert not upward, "imports pointing up the layers:\n" + "\n".join(upward)


def _stage(module: str) -> int:
    parts = module.split(".")
    return STAGE.get(parts[1], 0) if len(parts) > 1 else 0


def test_core_stages_point_down():
    """The robot model knows no kinematics or dynamics; kinematics no dynamics;
    no stage uses a later one or a sibling (calibration, excitation,
    compensation and report stand side by side)."""
    upward = [
        f"{here} imports {target}"
        for here, path in MODULES.items()
        if _layer(here) == "core" and here != "rmdrake"
        for target, _, _ in _imports(path)
        if _layer(target) == "core"
        and target.split(".")[1:2] != here.split(".")[1:2]
        and _stage(target) >= max(_stage(here), 1)
    ]
    assert not upward, "core imports against the stages:\n" + "\n".join(upward)


def test_no_import_cycle():
    cycles = _cycles(_graph())
    assert not cycles, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_no_private_name_imported():
    private = [
        f"{path.relative_to(ROOT)}:{line}: {name} from {module}"
        for path in MODULES.values()
        for module, name, line in _imports(path)
        if name is not None and name.startswith("_") and not name.endswith("__")
    ]  # a dunder (__version__) is public
    assert not private, "private names imported:\n" + "\n".join(private)


def test_names_come_from_their_module_not_a_package():
    through = [
        f"{path.relative_to(ROOT)}:{line}: {name} through {module}"
        for here, path in MODULES.items()
        if here not in PACKAGES
        for module, name, line in _imports(path)
        if module in PACKAGES and _target(module, name) == module
    ]
    assert not through, "names imported through a package:\n" + "\n".join(through)


def test_the_checks_see_what_they_must(tmp_path):
    """The checkers themselves: an upward import, a cycle and a private name
    in a made-up tree are found."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from rmdrake.studies import runner, _x\n")
    found = _imports(bad)
    assert ("rmdrake.studies", "runner", 2) in found
    assert any(name == "_x" for _, name, _ in found)
    assert RANK[_layer("rmdrake.studies")] > RANK[_layer("rmdrake.kinematics")]
    ring = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(ring) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
