"""The docs' API reference lists every exported name: docs/_ext/apigen.py,
which writes the reference pages when the docs are built, puts each name of
the ``__all__`` of ``rmdrake``, ``rmdrake.systems``, ``rmdrake.studies`` (and
the other public packages) into its package's page."""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path

import pytest

APIGEN = Path(__file__).resolve().parents[1] / "docs" / "_ext" / "apigen.py"


@pytest.fixture(scope="module")
def pages(tmp_path_factory) -> Path:
    spec = importlib.util.spec_from_file_location("apigen", APIGEN)
    apigen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(apigen)
    out = tmp_path_factory.mktemp("api")
    apigen.write_pages(out)
    return out


@pytest.mark.parametrize("package", ["rmdrake", "rmdrake.systems", "rmdrake.studies"])
def test_every_exported_name_has_an_entry(pages, package):
    text = (pages / f"{package}.md").read_text()
    entries = {line.strip().rsplit(".", 1)[-1] for line in text.splitlines()}
    missing = set(importlib.import_module(package).__all__) - entries
    assert not missing, f"{package}: not in the API reference: {sorted(missing)}"
