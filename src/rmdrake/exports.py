"""Lazy re-exports for the package ``__init__`` files (PEP 562).

``from rmdrake import load_robot`` imports :mod:`rmdrake.model.loading` when the
name is first asked for, not when ``rmdrake`` is imported, so ``rmdrake --help``,
a Dask worker and ``import rmdrake.errors`` load no Drake, scipy, cvxpy, dask
or matplotlib they do not use. Example, in a package's ``__init__.py``::

    __getattr__, __dir__, __all__ = lazy_exports(
        __name__, {"rmdrake.model.loading": ("load_robot", "shipped_robots")}
    )
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, Sequence[str]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of ``package``, which
    re-exports each name of ``exports[module]`` from that module (or, where the
    module has no such attribute, the submodule ``module.name``), importing it on
    first use and caching it in the package's namespace."""
    where = {name: module for module, names in exports.items() for name in names}
    if len(where) != sum(len(names) for names in exports.values()):
        raise ValueError(f"{package}: a name is exported from two modules")
    namespace = importlib.import_module(package).__dict__

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        source = importlib.import_module(module)
        try:
            value = getattr(source, name)
        except AttributeError:
            value = importlib.import_module(f"{module}.{name}")
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *where})

    return __getattr__, __dir__, sorted(where)
