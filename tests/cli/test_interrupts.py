"""A Ctrl-C is never lost: one that a finalizer or a library's callback
swallowed still ends the command as interrupted (exit 130, one line)."""

from __future__ import annotations

import argparse
import os
import signal

from rmdrake.cli.exits import run_handler


def _swallowing(args: argparse.Namespace) -> None:
    """A handler in which the interrupt lands where it is dropped."""
    try:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # the handler runs between bytecodes
            pass
    except KeyboardInterrupt:
        pass  # what an "Exception ignored in ..." finalizer amounts to


def test_a_swallowed_interrupt_still_ends_as_interrupted(capsys):
    assert run_handler(_swallowing, argparse.Namespace()) == 130
    assert capsys.readouterr().err == "rmdrake: interrupted; nothing written\n"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_command_with_no_interrupt_is_done(capsys):
    assert run_handler(lambda args: None, argparse.Namespace()) == 0
    assert capsys.readouterr().err == ""
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_an_interrupt_raised_through_keeps_the_folder_line(capsys):
    def interrupted(args: argparse.Namespace) -> None:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):
            pass

    assert run_handler(interrupted, argparse.Namespace(), folder="out") == 130
    assert capsys.readouterr().err == (
        "rmdrake: interrupted; the files written in out are whole\n"
    )
