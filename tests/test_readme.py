"""The README's and the docs' commands cannot drift from the CLI: every
``rmdrake`` invocation in the ``bash`` blocks of README.md and of the Markdown
pages under docs/ parses with the real parser (options, choices, types that do
not touch files), and the README's quick recipe runs as written. (The
tutorials' commands run when the docs are built: a failing one fails it.)

A command line is ``$R <command> ...`` (``R=.venv/bin/rmdrake``) or
``.venv/bin/rmdrake <command> ...``, with ``\\`` continuations, ``#``
comments and a ``>`` redirection that ends its words; ``$D`` is the shared
data folder, ``$i`` a shell loop's arm number (``07``), and in the one-arm
history recipe ``$d`` a log's date, ``$m`` its month number and ``$f`` the
friction factor (:data:`LOOP_VARIABLES`)."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import pytest

from rmdrake.cli.commands import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = [README] + sorted(
    p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts
)
"""README.md and every Markdown page of the docs."""
PREFIX = re.compile(r"^(?:\$R|\.venv/bin/rmdrake)\s+")
LOOP_VARIABLES = {"$i": "07", "$d": "2026-04-15", "$m": "3", "$f": "1.09"}
"""A value of each shell loop variable the README's bash blocks use."""


def _substituted(word: str) -> str:
    for name, value in LOOP_VARIABLES.items():
        word = word.replace(name, value)
    return word


def readme_commands(pages: list[Path] = PAGES) -> list[list[str]]:
    """The argv (after ``rmdrake``) of every invocation in the bash blocks."""
    blocks = [
        block
        for page in pages
        for block in re.findall(r"```bash\n(.*?)```", page.read_text(), flags=re.S)
    ]
    commands = []
    for block in blocks:
        joined = block.replace("\\\n", " ")
        for line in joined.splitlines():
            line = line.strip()
            if PREFIX.match(line):
                words = shlex.split(PREFIX.sub("", line), comments=True)
                if ">" in words:
                    words = words[: words.index(">")]
                commands.append([_substituted(w) for w in words])
    return commands


def test_the_readme_has_commands():
    names = {argv[0] for argv in readme_commands([README])}
    assert {"show", "perturb", "calibrate", "compare", "correct"} <= names


def test_the_docs_have_commands():
    """The pages moved out of the README keep their commands (and so this
    test's reach): each main command appears in some page."""
    names = {argv[0] for argv in readme_commands()}
    main_commands = {"show", "calibrate", "simulate", "identify", "run", "plan"}
    assert main_commands | {"fleet", "excite", "validate"} <= names


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


def recipe_block() -> str:
    """The README's first-hour recipe: the bash block that perturbs rv3sb."""
    blocks = re.findall(r"```bash\n(.*?)```", README.read_text(), flags=re.S)
    return next(b for b in blocks if "perturb --robot rv3sb --out true.yaml" in b)


def test_the_first_hour_recipe_runs_as_written(tmp_path, monkeypatch, capsys):
    """Every line of the recipe block, in order, in one folder (``printf`` by
    the shell): each exits 0, and the calibration finds the perturbed robot's
    error (the second compare's mean tool error is over 10x below the
    first's)."""
    monkeypatch.chdir(tmp_path)
    means = []
    for line in recipe_block().replace("\\\n", " ").splitlines():
        line = line.strip()
        if line.startswith("printf "):
            subprocess.run(["bash", "-c", line], check=True)
        elif PREFIX.match(line):
            argv = shlex.split(PREFIX.sub("", line), comments=True)
            assert main(argv) == 0, " ".join(argv)
            out = capsys.readouterr().out
            if argv[0] == "compare":
                means.append(float(re.search(r"mean ([\d.]+) mm", out).group(1)))
    assert len(means) == 2 and means[1] < means[0] / 10
    assert (tmp_path / "q.csv").is_file()
