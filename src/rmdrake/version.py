"""rmdrake's version, in one place: the package metadata (``pyproject.toml``'s
dynamic version), ``rmdrake.__version__`` and ``rmdrake --version`` read it."""

__version__ = "0.2.0"
