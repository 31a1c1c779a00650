"""The README's commands cannot drift from the CLI: every ``rmdrake``
invocation in its ``bash`` blocks parses with the real parser (options,
choices, types that do not touch files), and the quick ones run as written.

A command line is ``$R <command> ...`` (``R=.venv/bin/rmdrake``) or
``.venv/bin/rmdrake <command> ...``, with ``\\`` continuations and ``#``
comments; ``$D`` is the shared data folder."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from rmdrake.cli.commands import build_parser, main

README = Path(__file__).resolve().parents[1] / "README.md"
PREFIX = re.compile(r"^(?:\$R|\.venv/bin/rmdrake)\s+")


def readme_commands() -> list[list[str]]:
    """The argv (after ``rmdrake``) of every invocation in the bash blocks."""
    blocks = re.findall(r"```bash\n(.*?)```", README.read_text(), flags=re.S)
    commands = []
    for block in blocks:
        joined = block.replace("\\\n", " ")
        for line in joined.splitlines():
            line = line.strip()
            if PREFIX.match(line):
                words = shlex.split(PREFIX.sub("", line), comments=True)
                commands.append(words)
    return commands


def test_the_readme_has_commands():
    names = {argv[0] for argv in readme_commands()}
    assert {"show", "calibrate", "simulate", "identify", "run"} <= names


@pytest.mark.parametrize("argv", readme_commands(), ids=lambda a: " ".join(a)[:60])
def test_every_readme_command_parses(argv):
    """Parsing only: a removed option, a renamed command or a bad choice fails
    here (path types check nothing at parse time; the paths are checked when
    a command runs)."""
    parser = build_parser()
    try:
        args = parser.parse_args([w.replace("$D", "data") for w in argv])
    except SystemExit as e:
        pytest.fail(f"rmdrake {' '.join(argv)}: argparse exit {e.code}")
    assert args.command == argv[0]


QUICK = {"show", "import-urdf", "export-urdf", "simulate-plates", "simulate-points",
         "perturb", "compare"}  # fmt: skip
DATA = README.parent.parent / "shared" / "data" / "tiago_figaroh"


@pytest.mark.skipif(not DATA.is_dir(), reason=f"no shared data at {DATA}")
def test_the_quick_readme_commands_run_in_order(tmp_path, monkeypatch, capsys):
    """The quick commands (a few seconds each), in the README's order, in one
    folder (so each finds the files the ones before wrote; ``$D`` the shared
    TIAGo data): each exits 0."""
    monkeypatch.chdir(tmp_path)
    ran = []
    for argv in readme_commands():
        if argv[0] in QUICK:
            argv = [w.replace("$D", str(DATA)) for w in argv]
            assert main(argv) == 0, " ".join(argv)
            ran.append(argv[0])
    assert {"show", "import-urdf", "simulate-plates"} <= set(ran)
