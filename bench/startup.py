"""Start-up of the ``rmdrake`` command: what a user waits for before any work.

Each figure is the CPU time (user + system, from the kernel's accounting of the
child) of a fresh Python process, the median of ``--repeats`` runs, measured in
one run against two references:

* ``bare``: ``python -c pass``, the interpreter alone;
* ``pydrake.plant``: ``python -c "import pydrake.multibody.plant"``.

Rows:

* ``rmdrake --help`` and ``rmdrake COMMAND --help`` for every command (target:
  under 0.3 s of CPU; they import no Drake, scipy, cvxpy, dask or matplotlib);
* each command's start-up: a process importing the modules its handler imports
  when it runs (read from the handler's source, so the list cannot drift), set
  against a process importing only the ``pydrake`` modules that start-up loads
  (target: at most 1.3x; a command that loads no Drake is set against
  ``pydrake.plant``).

Run:

    python bench/startup.py [--repeats 5]
    python bench/startup.py --quick     # 3 runs, four commands
"""

from __future__ import annotations

import argparse
import ast
import inspect
import json
import os
import statistics
import subprocess
import sys
import textwrap
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HELP_TARGET = 0.3  # s of CPU
RATIO_TARGET = 1.3  # a command's start-up over its pydrake modules
QUICK_COMMANDS = ("show", "calibrate", "identify", "plan")
ALIASES = {"demo": "run"}  # demo's handler is run's, on a shipped scenario


def cpu_seconds(argv: list[str]) -> float:
    """CPU time (user + system) of one run of ``argv``, s."""
    before = os.times()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)
    after = os.times()
    return (after.children_user - before.children_user) + (
        after.children_system - before.children_system
    )


def median_cpu(argv: list[str], repeats: int) -> float:
    return statistics.median(cpu_seconds(argv) for _ in range(repeats))


def python(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def handler_modules() -> dict[str, list[str]]:
    """Per command, the rmdrake modules its handler imports when it runs (the
    ``from rmdrake... import`` statements in the handler's body)."""
    from rmdrake.cli.commands import build_parser

    sub = next(
        a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)
    )
    out = {}
    for name, parser in sub.choices.items():
        handler = parser.get_default("handler")
        tree = ast.parse(textwrap.dedent(inspect.getsource(handler)))
        modules = [
            n.module
            for n in ast.walk(tree)
            if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("rmdrake")
        ]
        out[name] = modules
    for name, same in ALIASES.items():  # handlers that call another's
        out[name] = out[same]
    return out


def pydrake_modules(modules: list[str]) -> list[str]:
    """The ``pydrake`` modules a fresh process holds after importing
    ``modules``."""
    code = (
        f"import importlib, json, sys\nfor m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith('pydrake'))))"
    )
    out = subprocess.run(python(code), check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="3 runs, 4 commands")
    args = parser.parse_args()
    repeats = 3 if args.quick else args.repeats
    script = str(Path(sys.executable).with_name("rmdrake"))

    bare = median_cpu(python("pass"), repeats)
    plant = median_cpu(python("import pydrake.multibody.plant"), repeats)
    print(
        f"CPU s, median of {repeats} fresh processes; load "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    print(f"{'bare interpreter':<34} {bare:6.3f}")
    print(f"{'import pydrake.multibody.plant':<34} {plant:6.3f}")

    commands = handler_modules()
    names = QUICK_COMMANDS if args.quick else tuple(commands)
    print(f"\n{'--help':<34} {'CPU s':>6} {'/bare':>6} {'/plant':>7}  target")
    worst = 0.0
    for name in ("", *names):
        argv = [script, *([name] if name else []), "--help"]
        t = median_cpu(argv, repeats)
        worst = max(worst, t)
        label = f"rmdrake {name + ' ' if name else ''}--help"
        print(
            f"{label:<34} {t:6.3f} {t / bare:6.1f} {t / plant:7.2f}  "
            f"< {HELP_TARGET} s {'ok' if t < HELP_TARGET else 'MISSED'}"
        )

    print(
        f"\n{'start-up (handler imports)':<34} {'CPU s':>6} {'pydrake':>7} "
        f"{'ratio':>6}  target <= {RATIO_TARGET}"
    )
    ratios = []
    for name in names:
        modules = sorted(set(commands[name]))
        t = median_cpu(python("".join(f"import {m}\n" for m in modules)), repeats)
        drake = pydrake_modules(modules)
        if drake:
            ref = median_cpu(python("".join(f"import {m}\n" for m in drake)), repeats)
        else:
            ref = plant
        ratio = t / ref
        ratios.append(ratio)
        print(
            f"rmdrake {name:<26} {t:6.3f} {ref:7.3f} {ratio:6.2f}  "
            f"{'ok' if ratio <= RATIO_TARGET else 'MISSED'}"
            f"{'' if drake else '  (no Drake: against pydrake.plant)'}"
        )
    print(
        f"\nworst --help {worst:.3f} s (target {HELP_TARGET}); start-up ratio "
        f"median {statistics.median(ratios):.2f}, worst {max(ratios):.2f} "
        f"(target {RATIO_TARGET})"
    )


if __name__ == "__main__":
    main()
