"""The ``rmdrake`` command: parsing and printing only; each command calls its
pipeline (:mod:`rmdrake.pipelines`) or study (:mod:`rmdrake.studies`)."""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.cli.entry": ("main",),
    },
)
