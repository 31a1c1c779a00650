"""The docstring examples run, and every public entry point has one.

Runs the ``>>>`` examples of every module of the model, kinematics, dynamics,
excitation, io, report, systems, pipelines, calibration, studies and
compensation packages and of the top-level modules, against the rmdrake that is
imported (the installed wheel under ``RMDRAKE_TEST_INSTALLED=1``: modules are
found through ``rmdrake.__path__``, never through ``src/``). The public names
are those the packages' ``__all__`` re-export (and the top-level
``rmdrake.__all__`` names defined in these packages); each class or function
among them must show an example in its own docstring.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import os
import pkgutil
import tempfile

import pytest

import rmdrake

PACKAGES = (
    "rmdrake.model",
    "rmdrake.kinematics",
    "rmdrake.dynamics",
    "rmdrake.excitation",
    "rmdrake.io",
    "rmdrake.report",
    "rmdrake.systems",
    "rmdrake.pipelines",
    "rmdrake.calibration",
    "rmdrake.studies",
    "rmdrake.compensation",
)
"""The packages whose docstrings this test covers (with their subpackages)."""

TOP_LEVEL = (
    "rmdrake",
    "rmdrake.arrays",
    "rmdrake.drake_log",
    "rmdrake.errors",
    "rmdrake.execution",
    "rmdrake.exports",
    "rmdrake.limits",
    "rmdrake.optimize",
    "rmdrake.progress",
    "rmdrake.threads",
    "rmdrake.version",
)
"""The top-level modules covered."""

EXEMPT: dict[str, str] = {}
"""Public names without an example, each with the reason it cannot run here."""


def _covered(module: str) -> bool:
    return module in TOP_LEVEL or any(
        module == p or module.startswith(p + ".") for p in PACKAGES
    )


def _modules() -> list[str]:
    names = [*TOP_LEVEL]
    for info in pkgutil.walk_packages(rmdrake.__path__, "rmdrake."):
        if info.name not in names and _covered(info.name):
            names.append(info.name)
    return sorted(names)


def _public() -> dict[str, object]:
    """{package.name: object} of the public classes and functions covered."""
    found: dict[str, object] = {}
    for package in ("rmdrake", *PACKAGES):
        module = importlib.import_module(package)
        for name in getattr(module, "__all__", ()):
            value = getattr(module, name)
            if not (inspect.isclass(value) or inspect.isroutine(value)):
                continue  # a constant: its docstring is not kept at run time
            if _covered(value.__module__) and value.__module__ != "rmdrake":
                found[f"{package}.{name}"] = value
    return found


@pytest.fixture(scope="module")
def in_tmp_dir():
    """Examples that write files write them in a fresh temporary directory."""
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        try:
            yield tmp
        finally:
            os.chdir(here)


@pytest.mark.parametrize("module", _modules())
def test_examples_run(module, in_tmp_dir):
    mod = importlib.import_module(module)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    for test in finder.find(mod, module):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{module}: {result.failed} example(s) failed"


def test_public_names_have_examples():
    missing = sorted(
        name
        for name, value in _public().items()
        if name.rsplit(".", 1)[1] not in EXEMPT and ">>>" not in (value.__doc__ or "")
    )
    assert not missing, f"public names without an example: {missing}"


def test_exemptions_are_public():
    names = {name.rsplit(".", 1)[1] for name in _public()}
    assert set(EXEMPT) <= names
