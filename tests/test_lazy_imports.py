"""The package imports what a caller uses, when it is used: ``import rmdrake``
and ``rmdrake --help`` load no Drake, scipy, cvxpy, dask or matplotlib, and every
name a package re-exports (lazily, PEP 562) resolves to the object its module
defines."""

from __future__ import annotations

import importlib
import json
import pkgutil
import subprocess
import sys
import types

import pytest

import rmdrake

HEAVY = ("pydrake", "scipy", "cvxpy", "dask", "distributed", "matplotlib")

PROBE = """
import json, sys
{code}
heavy = sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))
print(json.dumps(heavy))
"""


def _heavy_after(code: str) -> list[str]:
    """The heavy top-level packages a fresh interpreter holds after ``code``."""
    out = subprocess.run(
        [sys.executable, "-c", PROBE.format(code=code, heavy=HEAVY)],
        capture_output=True, text=True, check=True, timeout=120,
    ).stdout  # fmt: skip
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "code",
    [
        "import rmdrake, rmdrake.errors, rmdrake.systems, rmdrake.studies",
        "from rmdrake.cli.entry import main\ntry:\n    main(['--help'])\n"
        "except SystemExit:\n    pass",
        "from rmdrake.cli.commands import build_parser\nfor c in ('calibrate', "
        "'identify', 'plan', 'fleet', 'run', 'excite', 'simulate-sockets'):\n"
        "    try:\n        build_parser().parse_args([c, '--help'])\n"
        "    except SystemExit:\n        pass",
    ],
    ids=["import", "--help", "COMMAND --help"],
)
def test_no_heavy_import_before_use(code):
    assert _heavy_after(code) == []


def test_a_name_loads_its_module_on_use():
    assert _heavy_after("import rmdrake\nrmdrake.MakePlant") == ["pydrake"]


def _packages() -> list[str]:
    found = [rmdrake.__name__]
    for info in pkgutil.walk_packages(rmdrake.__path__, prefix="rmdrake."):
        if info.ispkg:
            found.append(info.name)
    return found


@pytest.mark.parametrize("package", _packages())
def test_every_reexported_name_resolves(package):
    """Each name of ``__all__`` is its defining module's object (a typo in an
    export map, or a name moved to another module, fails here)."""
    module = importlib.import_module(package)
    for name in getattr(module, "__all__", ()):
        value = getattr(module, name)
        assert not isinstance(value, types.ModuleType), f"{package}.{name}"
        assert name in dir(module)
    with pytest.raises(AttributeError, match="no attribute"):
        module.surely_not_exported  # noqa: B018


def test_one_version(capsys):
    """The installed metadata, ``rmdrake.__version__`` and ``rmdrake --version``
    say the same version."""
    from importlib.metadata import version

    from rmdrake.cli.commands import main

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.split() == ["rmdrake", rmdrake.__version__]
    assert version("rmdrake") == rmdrake.__version__


def test_a_dask_worker_imports_what_its_task_needs():
    """A worker that runs ``load_robot`` (numpy and YAML) holds no Drake, scipy,
    cvxpy or matplotlib afterwards: unpickling a task imports its module, not
    the whole package."""
    from distributed import Client, LocalCluster

    from rmdrake.model.loading import load_robot

    def heavy_loaded() -> list[str]:
        import sys

        tops = {m.split(".")[0] for m in sys.modules}
        return sorted(tops & {"pydrake", "scipy", "cvxpy", "matplotlib"})

    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as client,
    ):
        assert client.submit(load_robot, "rv3sb").result().n_joints == 6
        assert list(client.run(heavy_loaded).values()) == [[]]
