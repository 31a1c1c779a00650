"""Drake's log messages that rmdrake knows to be harmless where it triggers
them, dropped there and nowhere else.

Drake logs through Python's ``logging`` (logger ``drake``). Some of its lines
are true in general but moot in one rmdrake call: the URL of a Meshcat that
only renders a saved page, the joint friction its plant ignores on a URDF
rmdrake wrote (rmdrake models friction itself), an illustration role replaced
before any visualizer reads it. :func:`drake_messages_dropped` drops records
containing given text while one block runs; every other record passes, and
the filter is gone when the block ends.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["drake_messages_dropped"]


class _Drop(logging.Filter):
    """Drops the records whose message contains one of ``fragments``."""

    def __init__(self, fragments: tuple[str, ...]) -> None:
        super().__init__()
        self.fragments = fragments

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        return not any(f in message for f in self.fragments)


@contextmanager
def drake_messages_dropped(*fragments: str) -> Iterator[None]:
    """While the block runs, Drake's log records whose message contains any of
    ``fragments`` are dropped (none given: nothing is)."""
    if not fragments:
        yield
        return
    logger, drop = logging.getLogger("drake"), _Drop(fragments)
    logger.addFilter(drop)
    try:
        yield
    finally:
        logger.removeFilter(drop)
