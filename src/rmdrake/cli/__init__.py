"""The ``rmdrake`` command: parsing and printing only; each command calls its
pipeline (:mod:`rmdrake.pipelines`) or study (:mod:`rmdrake.studies`)."""

from __future__ import annotations

from rmdrake.cli.entry import main

__all__ = ["main"]
