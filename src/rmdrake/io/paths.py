"""What a path names, before it is opened: reading a FIFO or ``/dev/zero``
would wait or run forever, so every reader of a named input asks first.

>>> not_a_regular_file("/dev/null")
'is a device, not a regular file'
>>> not_a_regular_file("/")
'Is a directory'
"""

from __future__ import annotations

import os
import stat

__all__ = ["not_a_regular_file"]


def not_a_regular_file(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot be read as a file (``is a FIFO, not a regular
    file``, ``is a device, ...``, ``Is a directory``, a link that loops or
    points nowhere: the system's words), or None for a regular file."""
    try:
        mode = os.stat(path).st_mode
    except OSError as e:
        return e.strerror or type(e).__name__
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "Is a directory"
    kind = (
        "a FIFO"
        if stat.S_ISFIFO(mode)
        else "a device"
        if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
        else "a special file"
    )
    return f"is {kind}, not a regular file"
