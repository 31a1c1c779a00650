"""What a new user sees in the first hour is true and quiet: ``export-urdf``
prints no Drake warning about the friction it writes, ``show`` prints Meshcat's
URL only for a port the user named, and ``--help`` shows the defaults that say
something (no ``(default: None)``, no self-reference)."""

from __future__ import annotations

import argparse
import logging
import socket

import pytest

from rmdrake.cli.commands import build_parser, main
from rmdrake.model.urdf.parse import urdf_plant
from rmdrake.systems.visualization import MESHCAT_LISTENING


def test_export_urdf_writes_nothing_to_stderr(tmp_path, capfd):
    out = tmp_path / "rv3sb.urdf"
    assert main(["export-urdf", "--robot", "rv3sb", "--out", str(out)]) == 0
    printed, err = capfd.readouterr()
    assert err == ""
    assert f"wrote {out}" in printed and 'friction="' in out.read_text()


# Drake's warnings on a URDF whose joint has friction and whose link has mass 0
# with a nonzero inertia: the first is known and harmless, the second is not.
ODD = """<robot name="odd"><link name="base"/>
<link name="l1"><inertial><mass value="0"/>
<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
<dynamics damping="0.1" friction="0.5"/></joint></robot>
"""


def test_urdf_plant_drops_the_friction_warning_alone(tmp_path, caplog):
    """The exported URDF keeps fc in <dynamics friction>, which Drake's plant
    ignores with a warning per joint: dropped; Drake's other warnings pass."""
    exported = tmp_path / "rv3sb.urdf"
    assert main(["export-urdf", "--robot", "rv3sb", "--out", str(exported)]) == 0
    odd = tmp_path / "odd.urdf"
    odd.write_text(ODD)
    caplog.set_level(logging.WARNING, logger="drake")
    urdf_plant(exported)
    assert caplog.records == []
    urdf_plant(odd)
    messages = [r.getMessage() for r in caplog.records]
    assert messages and not any("'friction'" in m for m in messages)
    assert any("re-expressing as central inertia" in m for m in messages)
    assert logging.getLogger("drake").filters == []


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("named", [False, True])
def test_show_prints_no_meshcat_url(tmp_path, caplog, named):
    """show's server lives only while the page is drawn: a URL printed would
    be dead before anyone opened it, with or without a named port."""
    caplog.set_level(logging.INFO, logger="drake")
    port = _free_port() if named else None
    argv = ["show", "--robot", "rv3sb", "--html", str(tmp_path / "r.html")]
    assert main(argv + ([] if port is None else ["--port", str(port)])) == 0
    listening = [r for r in caplog.records if MESHCAT_LISTENING in r.getMessage()]
    assert listening == []


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return " ".join(sub.choices[command].format_help().split())  # unwrapped


def test_help_shows_defaults_and_no_noise():
    simulate = _help("simulate")
    assert "log rate, Hz (default: 150.0)" in simulate
    calibrate = _help("calibrate")
    assert "LM loss (default: linear)" in calibrate
    assert "DE's seed; CV split's (default: 0)" in calibrate
    for command in ("simulate", "calibrate", "correct", "identify", "excite", "run"):
        text = _help(command)
        assert "(default: None)" not in text and "(default: False)" not in text
        assert "==SUPPRESS==" not in text
    correct = _help("correct")
    assert "see --help" not in correct
    assert "the program's robot (default: the shipped robot named in" in correct
    assert "(default: out/demo)" in _help("demo")


def test_every_option_with_a_default_has_help():
    """An option without help text would hide its default from --help."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    silent = [
        (name, a.option_strings[0])
        for name, p in sub.choices.items()
        for a in p._actions
        if a.option_strings and not a.help and a.default not in (None, False)
    ]
    assert silent == []
