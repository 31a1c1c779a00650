"""Writes the API reference pages (reference/api/*.md) before Sphinx reads them.

One page per public package: an autosummary table of every name in the
package's ``__all__`` (the lazy PEP 562 re-exports of
:func:`rmdrake.exports.lazy_exports`). Each object gets one generated page,
under the module that defines it, from the first package that exports it;
later packages link to that page. So the reference cannot drift from the
exports: a new name appears, a removed one disappears.
"""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

PACKAGES = [
    ("rmdrake", "The top level: core numerics, no diagram wiring."),
    ("rmdrake.systems", "Drake systems, each with ``AddToBuilder``."),
    ("rmdrake.studies", "The paper's studies and the scenario files."),
    ("rmdrake.calibration", "Kinematic calibration: plates, points, sockets, poses."),
    ("rmdrake.dynamics", "Dynamic identification."),
    ("rmdrake.excitation", "Excitation design."),
    ("rmdrake.compensation", "Calibrated compensation of targets and programs."),
    ("rmdrake.kinematics", "Batched kinematics."),
    ("rmdrake.model", "Robot models."),
    ("rmdrake.model.urdf", "URDF import."),
    ("rmdrake.io", "Files in and out."),
    ("rmdrake.pipelines", "The pipelines behind the command line."),
    ("rmdrake.studies.elastic_arm", "The heavy arm's elastic study."),
]


def canonical(package, name: str) -> str:
    """The dotted path of the object ``package.name`` where it is defined."""
    obj = getattr(package, name)
    if inspect.ismodule(obj):
        return obj.__name__
    module = getattr(obj, "__module__", None)
    qualname = getattr(obj, "__qualname__", None)
    if (
        isinstance(module, str)
        and isinstance(qualname, str)
        and module.startswith("rmdrake")
        and getattr(sys.modules.get(module), qualname.split(".")[0], None) is not None
    ):
        return f"{module}.{qualname}"
    # Data (a constant): the rmdrake module that holds this very object.
    for modname, mod in sorted(sys.modules.items()):
        if modname.startswith(package.__name__ + ".") and mod is not None:
            if getattr(mod, name, None) is obj and not hasattr(
                importlib.import_module(modname), "__getattr__"
            ):
                return f"{modname}.{name}"
    return f"{package.__name__}.{name}"


def _exported_modules(package) -> None:
    """Imports every name so sys.modules holds the defining modules."""
    for name in package.__all__:
        getattr(package, name)


def write_pages(out: Path) -> list[str]:
    out.mkdir(parents=True, exist_ok=True)
    seen: set[str] = set()
    pages = []
    for dotted, summary in PACKAGES:
        package = importlib.import_module(dotted)
        _exported_modules(package)
        new, old = [], []
        for name in package.__all__:
            path = canonical(package, name)
            (old if path in seen else new).append(path)
            seen.add(path)
        lines = [
            f"# `{dotted}`",
            "",
            summary,
            "",
            "```{eval-rst}",
        ]
        if new:
            lines += [
                ".. autosummary::",
                "   :toctree: generated",
                "   :nosignatures:",
                "",
                *(f"   {p}" for p in new),
                "",
            ]
        if old:
            lines += [
                "Also exported here (documented above or on an earlier page):",
                "",
                ".. autosummary::",
                "   :nosignatures:",
                "",
                *(f"   {p}" for p in old),
                "",
            ]
        lines += ["```", ""]
        page = out / f"{dotted}.md"
        text = "\n".join(lines)
        if not page.exists() or page.read_text() != text:
            page.write_text(text)
        pages.append(dotted)
    # Every module, from its docstring (the names it exports are above).
    import pkgutil

    import rmdrake

    modules = sorted(
        m.name
        for m in pkgutil.walk_packages(rmdrake.__path__, "rmdrake.")
        if m.name not in seen
    )
    lines = [
        "# Modules",
        "",
        "Every module of the package, with its docstring: what it holds and why",
        "(the names each package exports have their own pages).",
        "",
    ]
    for m in modules:
        lines += [
            f"## `{m}`",
            "",
            "```{eval-rst}",
            f".. automodule:: {m}",
            "   :no-index:",
            "```",
            "",
        ]
    page = out / "modules.md"
    text = "\n".join(lines)
    if not page.exists() or page.read_text() != text:
        page.write_text(text)
    pages.append("modules")
    index = [
        "# API",
        "",
        "Every name exported from each public package.",
        "",
        "```{toctree}",
        ":maxdepth: 1",
        "",
        *pages,
        "```",
        "",
    ]
    text = "\n".join(index)
    if not (out / "index.md").exists() or (out / "index.md").read_text() != text:
        (out / "index.md").write_text(text)
    return pages


def setup(app):
    def generate(app, config):
        write_pages(Path(app.srcdir) / "reference" / "api")

    # Before Sphinx lists the source files, so the pages are read on a clean
    # checkout (builder-inited comes too late for that).
    app.connect("config-inited", generate)
    return {"parallel_read_safe": True}
