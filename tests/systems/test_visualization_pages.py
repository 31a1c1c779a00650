"""What a saved Meshcat page shows, read from the Meshcat and the HTML without a
browser: each copy of ``save_robot_states_html`` in its own colour and named
by it (in the scene tree and in a legend box), its payload see-through, and a
tracking page's animation that loops."""

from __future__ import annotations

import base64
import re
import struct
from pathlib import Path

import numpy as np

from rmdrake.dynamics.compliance import link_angles, with_payload_mass
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.loading import load_robot
from rmdrake.systems.visualization import (
    LOOP_REPETITIONS,
    PAYLOAD_OPACITY,
    STATE_COLOURS,
    RobotScene,
    save_path_html,
    save_robot_states_html,
    state_path,
    with_own_meshcat,
)

#: The Meshcat path of a shape on link 1 of demo_rh_elastic, under a copy's path.
LINK1 = "demo_rh_elastic/link1/demo_rh_elastic/drum1"

#: The msgpack keys of a three.js material's colour and opacity.
COLOR = b"\xa5color"
OPACITY = b"\xa7opacity\xcb"


def _colour(packed: bytes) -> int:
    """The first material's colour (0xRRGGBB) in a packed Meshcat object."""
    at = packed.index(COLOR) + len(COLOR)
    kind = packed[at]
    if kind < 0x80:  # positive fixint
        return kind
    size = {0xCC: 1, 0xCD: 2, 0xCE: 4}[kind]
    return int.from_bytes(packed[at + 1 : at + 1 + size], "big")


def _opacity(packed: bytes) -> float:
    at = packed.index(OPACITY) + len(OPACITY)
    return struct.unpack(">d", packed[at : at + 8])[0]


def _is(colour: int, rgb) -> bool:
    """Whether 0xRRGGBB is (r, g, b) in [0, 1], to one level of 255."""
    channels = [(colour >> shift) & 0xFF for shift in (16, 8, 0)]
    return all(abs(c - 255 * x) <= 1 for c, x in zip(channels, rgb, strict=True))


def _commands(html: str) -> list[bytes]:
    """The packed Meshcat commands a saved page replays."""
    found = re.findall(r'data:application/octet-binary;base64,([^"]*)"', html)
    return [base64.b64decode(c) for c in found]


def _states(tmp_path: Path):
    model = load_robot("demo_rh_elastic")
    model = with_payload_mass(model, 4500.0)
    q = np.array([0.0, 0.5, 0.3, 0.0, 0.6, 0.0])
    sag = link_angles(model, q, 4500.0) - q
    states = {
        "nominal": (q, 0.35),
        "sagging x20": (q + 20.0 * sag, 1.0),
        "compensated x20": (q - 20.0 * sag, 0.8),
    }
    return model, states


def _packed_object(commands: list[bytes], path: str) -> bytes:
    """The ``set_object`` command of Meshcat path ``path`` (its path string is
    followed by its ``object`` key)."""
    (found,) = [c for c in commands if path.encode() + b"\xa6object" in c]
    return found


def test_each_copy_has_its_own_colour_and_name(tmp_path):
    model, states = _states(tmp_path)
    path = save_robot_states_html(model, states, tmp_path / "c.html")
    roots = [
        state_path(label, name)
        for label, (name, _) in zip(states, STATE_COLOURS, strict=False)
    ]
    assert roots == [
        "/drake/nominal (grey)",
        "/drake/sagging x20 (red)",
        "/drake/compensated x20 (green)",
    ]
    html = path.read_text()
    commands = _commands(html)
    colours = []
    for root, (_, opacity), (name, rgb) in zip(
        roots, states.values(), STATE_COLOURS, strict=False
    ):
        arm = _packed_object(commands, f"{root}/{LINK1}")
        payload = _packed_object(
            commands, f"{root}/demo_rh_elastic/payload/demo_rh_elastic/payload"
        )
        colours.append(_colour(arm))
        assert _colour(arm) == _colour(payload) and _is(_colour(arm), rgb), name
        assert np.isclose(_opacity(arm), opacity), name
        assert np.isclose(_opacity(payload), PAYLOAD_OPACITY * opacity), name
        assert _opacity(payload) < 0.5, name  # the arm shows through it
    assert len(set(colours)) == len(states), colours
    # the base, fixed, is drawn once: by the first copy
    bases = [c for c in commands if b"/pedestal\xa6object" in c]
    assert len(bases) == 1 and roots[0].encode() in bases[0]
    # the legend box: a square of each copy's colour and its name
    assert 'id="rmdrake-legend"' in html
    for label, (name, rgb) in zip(states, STATE_COLOURS, strict=False):
        r, g, b = (round(255 * c) for c in rgb)
        assert f"rgba({r},{g},{b}," in html
        assert f"{label} ({name})" in html


def test_recolouring_logs_no_drake_warning(tmp_path, caplog):
    model, states = _states(tmp_path)
    save_robot_states_html(model, states, tmp_path / "c.html")
    assert not [r for r in caplog.records if r.name == "drake"], caplog.records


def test_a_tracking_page_loops(tmp_path):
    model = load_robot("rv3sb")
    t = np.linspace(0.0, 1.0, 12)
    q = np.outer(np.sin(np.pi * t), 0.4 * np.ones(model.n_joints))
    p = tool_points(model.table, q)
    lines = {"commanded": (p, (0.1, 0.4, 0.9, 1.0))}
    html = save_path_html(model, t, q, lines, tmp_path / "tracking.html").read_text()
    (animation,) = [c for c in _commands(html) if b"set_animation" in c]
    assert b"\xa8loopMode\xcd\x08\x99" in animation  # THREE.LoopRepeat, 2201
    repetitions = b"\xabrepetitions\xce" + LOOP_REPETITIONS.to_bytes(4, "big")
    assert repetitions in animation


def test_robot_scene_loop_mode_is_repeat():
    from pydrake.geometry import MeshcatAnimation

    def draw(*, meshcat):
        scene = RobotScene(model=load_robot("rv3sb"), meshcat=meshcat, recording=True)
        for k in range(3):
            scene.set_positions(np.full(6, 0.1 * k), time=0.5 * k)
            scene.publish()
        scene.html(loop=True)
        recording = scene.visualizer.get_mutable_recording()
        return recording.loop_mode(), recording.repetitions()

    mode, repetitions = with_own_meshcat(draw)
    assert mode == MeshcatAnimation.LoopMode.kLoopRepeat
    assert repetitions == LOOP_REPETITIONS > 1_000_000
