"""Atomic file writes: the one way rmdrake writes a file.

The data is written to a temporary file in the target folder, flushed,
fsync'ed and renamed over the target (``os.replace``), so a crash, a Ctrl-C or
a bad input never leaves a half-written or truncated file behind, and a reader
sees either the old file or the new one. Every failure is one ``ValueError``
line naming the path.
"""

from __future__ import annotations

import itertools
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

__all__ = [
    "CHUNK_LINES",
    "atomic_write_bytes",
    "atomic_write_files",
    "atomic_write_lines",
    "atomic_write_text",
    "encode_lines",
    "check_writable",
]


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Writes ``data`` to ``path`` atomically (temp file + fsync + rename).

    Rules: the parent folder is created if missing; a file replaced keeps its
    mode; a folder, a special file or a write-protected file (one the user
    cannot write, or whose mode grants no write permission at all, which even
    root respects here) is never replaced; on any failure the target is
    untouched and no temporary file is left. Returns the resolved path.

    Raises:
      ValueError: one line naming the path and the reason it cannot be written
        (see :func:`check_writable`; also a full disk, a race).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import atomic_write_bytes
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = atomic_write_bytes(Path(tmp, "out.bin"), b"rmdrake")
    ...     print(path.name, path.read_bytes())
    ...
    out.bin b'rmdrake'
    """
    path = Path(path)
    check_writable(path)
    tmp = _write_temp(path, data)
    try:
        os.replace(tmp, path)
    except BaseException as e:
        _failed(path, tmp, e)
    return path.resolve()


def atomic_write_files(files: dict[str | os.PathLike, bytes]) -> list[Path]:
    """Writes several files that belong together (a CSV and the file beside
    it) so that a failure replaces none of them: every target is checked
    (:func:`check_writable`), every temporary file written and fsync'ed, and
    only then is each renamed over its target, so a full disk or a bad path
    leaves all the old files as they were. Returns the resolved paths, in
    order.

    Raises:
      ValueError: as :func:`atomic_write_bytes`, naming the path.
    """
    paths = [Path(p) for p in files]
    for path in paths:
        check_writable(path)
    temps: list[str] = []
    try:
        for path, data in zip(paths, files.values(), strict=True):
            temps.append(_write_temp(path, data))
    except BaseException:
        for tmp in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    for i, (path, tmp) in enumerate(zip(paths, temps, strict=True)):
        try:
            os.replace(tmp, path)
        except BaseException as e:
            for rest in temps[i + 1 :]:
                if os.path.exists(rest):
                    os.unlink(rest)
            _failed(path, tmp, e)
    return [p.resolve() for p in paths]


def _write_temp(path: Path, data: bytes) -> str:
    """A temporary file beside ``path`` holding ``data``, flushed and
    fsync'ed, with the mode ``path`` has (or a new file's); its name."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(
            prefix=f".{path.name}.", suffix=".tmp", dir=path.parent
        )
        os.chmod(tmp, path.stat().st_mode & 0o7777 if path.exists() else _new_mode())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    except BaseException as e:
        _failed(path, tmp, e)
    return tmp


def _failed(path: Path, tmp: str | None, e: BaseException) -> None:
    """Removes the temporary file ``tmp`` of a failed write of ``path`` and
    raises: ``e`` itself unless an OSError, else one ValueError line."""
    if tmp is not None and os.path.exists(tmp):
        os.unlink(tmp)
    if not isinstance(e, OSError):
        raise e
    why = e.strerror or type(e).__name__
    if isinstance(e, FileExistsError | NotADirectoryError):
        why = "a folder on its path is a file"
    where = f" ({e.filename})" if e.filename not in (None, tmp) else ""
    raise ValueError(f"{path}: cannot write: {why}{where}") from None


def check_writable(path: str | os.PathLike) -> None:
    """Refuses, before any work, a ``path`` that :func:`atomic_write_bytes`
    would not write: an existing folder, special file or write-protected file;
    a path through a file; a missing parent under a folder the user cannot
    write; a name ending in ``/`` (a folder, whether it exists or not); a
    symbolic link that loops or points nowhere (the write would replace the
    link, not write where it seems to point).

    Raises:
      ValueError: ``PATH: is write-protected; nothing written`` and the like.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake.io import check_writable
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     check_writable(Path(tmp, "result.yaml"))  # fine: nothing raised
    ...     try:
    ...         check_writable(tmp)  # an existing folder
    ...     except ValueError as error:
    ...         print(type(error).__name__)
    ...
    ValueError
    """
    text = os.fspath(path)
    path = Path(path)
    why = None
    if text.endswith(("/", os.sep)):
        why = "names a folder (ends in /), expected a file name"
    elif path.is_symlink() and not path.exists():
        why = "is a symbolic link that loops or points nowhere, expected a file name"
    elif path.is_dir():
        why = "is a folder, expected a file name"
    elif path.exists() and not path.is_file():
        why = "is not a regular file"
    elif path.exists() and (
        not os.access(path, os.W_OK) or not path.stat().st_mode & 0o222
    ):
        why = "is write-protected"
    else:
        parent = next(p for p in path.absolute().parents if p.exists())
        if not parent.is_dir():
            why = f"cannot write: a folder on its path is a file ({parent})"
        elif not os.access(parent, os.W_OK | os.X_OK):
            why = f"cannot write: folder {parent} is not writable"
    if why:
        raise ValueError(f"{path}: {why}; nothing written")


def _new_mode() -> int:
    """The usual mode of a new file, 0o666 less the umask (mkstemp makes 0o600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Writes UTF-8 ``text`` to ``path`` atomically; see :func:`atomic_write_bytes`.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import atomic_write_text
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = atomic_write_text(Path(tmp, "note.txt"), "calibrated")
    ...     print(path.read_text())
    ...
    calibrated
    """
    return atomic_write_bytes(path, text.encode("utf-8"))


CHUNK_LINES = 65_536
"""Lines of a text file (a measurement CSV) encoded at a time by
:func:`atomic_write_lines`."""


def atomic_write_lines(path: str | os.PathLike, lines: Iterable[str]) -> Path:
    """Writes ``lines`` (without their newlines), each ended by a newline,
    atomically as UTF-8 (:func:`atomic_write_bytes`).

    The lines are encoded :data:`CHUNK_LINES` at a time, so memory is the
    file's bytes twice (the chunks, then the joined file) rather than a list
    of every line's string object, its joined text and its bytes; the bytes
    are those of ``"\n".join(lines) + "\n"``."""
    return atomic_write_bytes(path, encode_lines(lines))


def encode_lines(lines: Iterable[str]) -> bytes:
    """The UTF-8 bytes of ``lines`` (without their newlines), each ended by a
    newline, encoded :data:`CHUNK_LINES` at a time (:func:`atomic_write_lines`;
    for :func:`atomic_write_files`)."""
    it = iter(lines)
    parts = []
    while chunk := list(itertools.islice(it, CHUNK_LINES)):
        parts.append(("\n".join(chunk) + "\n").encode("utf-8"))
    return b"".join(parts)
