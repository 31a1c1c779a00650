"""Sphinx configuration: MyST pages, executed MyST-NB tutorials, the API
reference generated from the packages' ``__all__`` (``_ext/apigen.py``) and
the CLI page from the real argparse parser. Built by ``make docs`` with -W
against the installed package (not ``src/``)."""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import rmdrake

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
# The tutorials' kernels draw inline (the Makefile's Agg would hide their
# figures); rmdrake's own plots save files with any backend.
os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# The tutorials read ../shared/data beside the checkout when it is present.
os.environ.setdefault("RMDRAKE_DATA", str(HERE.parents[1] / "shared" / "data"))

project = "rmdrake"
author = "rmdrake authors"
copyright = "2026, rmdrake authors"
release = rmdrake.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
    "myst_nb",
    "apigen",
    "pydrake_system",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb"}
exclude_patterns = ["_build", "jupyter_execute", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# The reference: every exported name, Google-style docstrings.
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "description"
# Defaults as written in the source (not an install path of this machine).
autodoc_preserve_defaults = True
autodoc_typehints_format = "short"
autodoc_member_order = "bysource"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# Attributes as fields of their class, not a second description of each.
napoleon_use_ivar = True
nitpicky = False
suppress_warnings = [
    # Classes re-exported from several packages (and pydrake's own base
    # classes) are documented once, under the module defining them.
    "autosummary.import_cycle",
]

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

# Tutorials: executed at every build, a failing cell fails the build.
nb_execution_mode = os.environ.get("RMDRAKE_DOCS_EXECUTE", "force")
nb_execution_timeout = 600
# Each tutorial runs in a temporary folder (they write their files there).
nb_execution_in_temp = True
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

html_theme = "furo"
html_title = f"rmdrake {release}"
html_static_path = ["_static"]


# The docstrings are plain text with a little reST: scikit-learn style fitted
# attributes (``names_``, ``model_``) and absolute values (``|q_b - q_a|``),
# which reST reads as link targets and substitutions. Escape those two outside
# literals, doctests and literal blocks, so the text renders as written (every
# other reST problem is fixed in the docstring itself).
_INLINE_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")
_TRAILING_UNDERSCORE = re.compile(r"(?<![\\\w])([A-Za-z][\w.]*?[A-Za-z0-9])_(?=\W|$)")


def _escape_text(text: str) -> str:
    parts = _INLINE_LITERAL.split(text)
    for i in range(0, len(parts), 2):
        parts[i] = _TRAILING_UNDERSCORE.sub(r"\1\\_", parts[i].replace("|", r"\|"))
    return "".join(parts)


def _plain_docstring(app, what, name, obj, options, lines):
    doctest = literal = False
    literal_indent = 0
    for i, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if doctest:
            doctest = bool(stripped)
            continue
        if literal:
            if stripped and indent <= literal_indent:
                literal = False
            else:
                continue
        if stripped.startswith(">>>"):
            doctest = True
            continue
        lines[i] = _escape_text(line)
        if stripped.endswith("::"):
            literal, literal_indent = True, indent


def setup(app):
    app.connect("autodoc-process-docstring", _plain_docstring)
