"""Drake's ``Meshcat listening for connections at URL`` line: printed for a
live Meshcat (``rmdrake run --meshcat``, ``show --port``), dropped for the
Meshcats that only render a saved HTML page, with the rest of Drake's log
untouched."""

from __future__ import annotations

import logging

from rmdrake.systems.visualization import MESHCAT_LISTENING, MakeMeshcat

DRAKE = logging.getLogger("drake")


def _listening(caplog) -> list[str]:
    return [
        r.getMessage() for r in caplog.records if MESHCAT_LISTENING in r.getMessage()
    ]


def test_a_page_meshcat_logs_no_listening_line(caplog):
    caplog.set_level(logging.INFO, logger="drake")
    meshcat = MakeMeshcat()
    assert meshcat.web_url().startswith("http://localhost:")
    assert _listening(caplog) == []
    assert DRAKE.filters == []  # only around the construction
    del meshcat


def test_a_live_meshcat_logs_its_url_once(caplog):
    caplog.set_level(logging.INFO, logger="drake")
    meshcat = MakeMeshcat(live=True)
    assert _listening(caplog) == [f"{MESHCAT_LISTENING}{meshcat.web_url()}"]
    del meshcat


def test_other_drake_messages_pass(caplog):
    caplog.set_level(logging.INFO, logger="drake")
    meshcat = MakeMeshcat()
    DRAKE.warning("a real warning")
    assert [r.getMessage() for r in caplog.records] == ["a real warning"]
    del meshcat
