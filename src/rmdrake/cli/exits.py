"""The one exit path of the ``rmdrake`` command: each outcome of a command is
one exit code and at most one line on stderr (never a traceback, unless asked
for with ``--debug``).

=====  ==========================================================================
code   outcome and line
=====  ==========================================================================
0      done
1      an internal error (a bug, or a Drake failure not caught before):
       ``rmdrake: internal error: <Type>: <message> (rerun with --debug ...)``
2      bad input: a malformed file or value, a missing, unreadable or
       unwritable file, an output naming an input: ``rmdrake: error: ...``
3      an implausible result, refused
       (:class:`~rmdrake.errors.ImplausibleResultError`): ``rmdrake: refused: ...``
       (a headline, then one line per reason)
130    interrupted (Ctrl-C): ``rmdrake: interrupted; nothing written`` (run
       and demo: ``...; the files written in OUT are whole``); every file is
       written atomically, so none is left half-written
=====  ==========================================================================
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import traceback
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

from rmdrake.errors import ImplausibleResultError, describe_error, one_line
from rmdrake.progress import restart_silence

__all__ = [
    "EXIT_CODES",
    "DefaultsHelpFormatter",
    "OneLineParser",
    "exit_line",
    "run_handler",
]

EXIT_CODES = {"ok": 0, "internal": 1, "error": 2, "refused": 3, "interrupted": 130}

#: Expected failures: bad input or a file the user cannot read or write.
#: RuntimeError included: Drake reports bad input (a port in use) with it.
EXPECTED = (ValueError, OSError, RuntimeError, MemoryError)
EXPECTED += (zipfile.BadZipFile, yaml.YAMLError, argparse.ArgumentTypeError)


def exit_line(error: BaseException, folder: str | None = None) -> tuple[int, str]:
    """(exit code, the message for stderr) of an exception out of a command:
    one line, except a refusal with several reasons (or a headline): its
    headline, then one indented line per reason.

    Args:
      folder: the output folder of a command that writes several files (run,
        demo): an interrupt there keeps the whole files already written.
    """
    if isinstance(error, KeyboardInterrupt):
        done = f"the files written in {folder} are whole" if folder else ""
        return EXIT_CODES[
            "interrupted"
        ], f"rmdrake: interrupted; {done or 'nothing written'}"
    if isinstance(error, ImplausibleResultError):  # before RuntimeError, its base
        return EXIT_CODES["refused"], f"rmdrake: refused: {error}"  # lines
    if isinstance(error, EXPECTED):
        return EXIT_CODES["error"], one_line(f"rmdrake: error: {describe_error(error)}")
    kind = type(error).__name__  # SystemExit too: Drake's failed assertions
    return EXIT_CODES["internal"], one_line(
        f"rmdrake: internal error: {kind}: {error} "
        "(rerun with --debug for the traceback)"
    )


def _end_progress_bars() -> None:
    """Closes the progress bars a failure left open (its traceback holds them),
    so that the final line starts a line of its own."""
    tqdm = sys.modules.get("tqdm")  # none open if no command imported it
    for bar in list(getattr(getattr(tqdm, "tqdm", None), "_instances", ())):
        bar.close()


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """``--help`` with each option's default, ``(default: 150.0)``, where it
    says something: not for a default of None, False, True (a flag), an empty
    list or ``argparse.SUPPRESS``, nor when the help text already states its
    default (``%(default)s`` or ``default:`` in it). As
    ``argparse.ArgumentDefaultsHelpFormatter``, positionals are left alone."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""  # argparse asks only for a non-empty help
        default = action.default
        said = "%(default)" in text or "default:" in text or "(default" in text
        quiet = default is None or default is argparse.SUPPRESS
        quiet = quiet or isinstance(default, bool) or default in ([], ())
        positional = not action.option_strings and action.nargs not in ("?", "*")
        if said or quiet or positional:
            return action.help
        return f"{text} (default: %(default)s)"


class OneLineParser(argparse.ArgumentParser):
    """argparse with one-line errors: ``rmdrake: error: ...`` and exit code 2
    (a bad option, or a value its type refused); ``--help`` shows the
    defaults (:class:`DefaultsHelpFormatter`, also the subcommands': argparse
    makes each subparser of this class, with these keyword defaults)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", DefaultsHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:
        print(one_line(f"rmdrake: error: {message}"), file=sys.stderr)
        raise SystemExit(EXIT_CODES["error"])


def run_handler(
    handler: Callable[[argparse.Namespace], object],
    args: argparse.Namespace,
    *,
    debug: bool = False,
    folder: str | Path | None = None,
) -> int:
    """Runs a command's handler; returns its exit code, printing one line on
    failure (preceded by the traceback when ``debug``).

    A Ctrl-C is never lost: Python raises it wherever the main thread is,
    and where that is a finalizer or a library's callback the exception is
    dropped ("Exception ignored in ..."); the handler then runs to its end.
    Each SIGINT is therefore also counted, and a handler that returns after
    one ends as interrupted (130), not done."""
    interrupts = _InterruptCount()
    restart_silence()  # a lazy bar speaks after an interval of this command's silence
    try:
        try:
            handler(args)
        finally:
            interrupts.restore()
        if interrupts.count:
            raise KeyboardInterrupt
    except BaseException as error:  # noqa: BLE001 - the one place that maps all
        if isinstance(error, SystemExit) and not isinstance(error.code, str):
            raise  # a deliberate exit with a code, not a failure
        code, line = exit_line(error, None if folder is None else str(folder))
        _end_progress_bars()
        if debug:
            traceback.print_exception(error)
        print(line, file=sys.stderr)
        return code
    return EXIT_CODES["ok"]


class _InterruptCount:
    """The SIGINTs a command received; ``restore`` puts the earlier handler
    back."""

    def __init__(self) -> None:
        self.count = 0
        self._old: Any = None
        if threading.current_thread() is not threading.main_thread():
            return  # only the main thread may set a handler; none counted
        old = signal.getsignal(signal.SIGINT)
        if old is not signal.default_int_handler:
            return  # SIGINT ignored or handled by the caller: leave it be
        self._old = old

        def counted(signum: int, frame: Any) -> None:
            self.count += 1
            old(signum, frame)

        signal.signal(signal.SIGINT, counted)

    def restore(self) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
            self._old = None
