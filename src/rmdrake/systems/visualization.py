"""Meshcat scenes of rmdrake robots, live or saved as self-contained HTML.

Meshcat is always created on ``localhost`` (Drake's default listens on every
interface, which a calibration tool on a plant network must not do). A port that is
already in use raises when the user named it; without a port Drake picks the first
free one in 7000..7099.

A Meshcat must be destroyed on the thread that made it: Drake aborts the whole
process otherwise (``meshcat.cc ... IsThread(main_thread_id_)``). The diagrams
that draw into a Meshcat hold it in reference cycles, which Python's collector
frees on whichever thread happens to allocate. So a Meshcat that rmdrake opens
for itself is opened and destroyed by :func:`with_own_meshcat`, on the calling
thread, before the call returns.

Drake logs ``Meshcat listening for connections at http://localhost:PORT`` (INFO,
logger ``drake``) for every Meshcat. rmdrake opens one for every HTML page it
saves, which nobody views live: that one line is dropped unless the Meshcat is
``live`` (``rmdrake run --meshcat``, ``rmdrake show --port``); every other Drake
message passes.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import html
import os
import threading
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TypeVar

import numpy as np
from pydrake.geometry import (
    Box,
    IllustrationProperties,
    Meshcat,
    MeshcatAnimation,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    Role,
    RoleAssign,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from rmdrake.drake_log import drake_messages_dropped
from rmdrake.io.atomic import atomic_write_text
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import RobotModel
from rmdrake.model.scene import Cell

_T = TypeVar("_T")

__all__ = [
    "MakeMeshcat",
    "with_own_meshcat",
    "RobotScene",
    "add_plate",
    "add_points",
    "save_calibration_html",
    "save_path_html",
    "save_robot_poses_html",
    "save_robot_states_html",
    "recolour",
    "state_path",
    "LOOP_REPETITIONS",
    "PAYLOAD_OPACITY",
    "STATE_COLOURS",
]


#: The start of Drake's INFO line for each new Meshcat (drake/geometry/meshcat.cc).
MESHCAT_LISTENING = "Meshcat listening for connections at "

#: How many times a looping animation plays (three.js counts repetitions; Drake's
#: MeshcatAnimation takes an int and plays once by default): about forever.
LOOP_REPETITIONS = 2**31 - 1


#: The start of Drake's WARNING for every illustration role replaced
#: (drake/geometry/geometry_state.cc), moot before the visualizer starts.
ROLE_REPLACED = "Updating illustration role properties must be done before"


def MakeMeshcat(port: int | None = None, *, live: bool = False) -> Meshcat:
    """A Meshcat server on localhost.

    Args:
      port: TCP port; None picks a free one: for a live Meshcat Drake's usual
        first free port from 7000 up (the address a user expects), otherwise any
        free port the system gives (port 0), so that a saved page never depends
        on what else listens on this machine.
      live: the user views this Meshcat in a browser while rmdrake runs: Drake's
        line with its URL is printed (once). Otherwise (a Meshcat that only
        renders a saved HTML page) that line is dropped; Drake's other messages
        are kept.

    Raises:
      RuntimeError: the named port is in use (the message says which).

    Example:

    >>> from rmdrake.systems import MakeMeshcat
    >>> meshcat = MakeMeshcat()  # a server on a free localhost port
    >>> meshcat.web_url().startswith("http://")
    True
    """
    params = MeshcatParams(host="localhost")
    if port is not None:
        params.port = int(port)
    elif not live:
        params.port = 0  # any free port
    try:
        with drake_messages_dropped(*(() if live else (MESHCAT_LISTENING,))):
            return Meshcat(params)
    except RuntimeError as e:
        where = f"port {port}" if port is not None else "a free port"
        raise RuntimeError(
            f"Meshcat could not listen on localhost {where} ({e}); "
            "choose a free port or omit it"
        ) from None


def with_own_meshcat(
    draw: Callable[..., _T],
    /,
    *args: object,
    port: int | None = None,
    live: bool = False,
    **kwargs: object,
) -> _T:
    """Returns ``draw(*args, meshcat=MakeMeshcat(port, live=live), **kwargs)``
    (``live``: the user watches it, its URL is printed) and destroys
    that Meshcat on this thread before returning, also when ``draw`` raises;
    ``draw`` must not return the Meshcat or anything that holds it.

    The rule it keeps: a Meshcat is destroyed on the thread that made it. The
    diagrams ``draw`` built on it are cyclic garbage that keeps it alive; this
    call holds the Meshcat until collections run on this thread find no garbage
    left (another thread's collection in progress makes ``gc.collect`` return
    at once, so it waits for that one to end and collects again), then drops
    the last reference here. An exception's frames are cleared first (file and
    line kept), so its traceback holds no reference either. A Meshcat still
    held after that (a leak in ``draw``) is kept until the process ends rather
    than destroyed elsewhere.

    Example:

    >>> from rmdrake.systems import with_own_meshcat
    >>> def draw(*, meshcat):
    ...     return meshcat.web_url().startswith("http://")
    ...
    >>> with_own_meshcat(draw)  # the Meshcat is gone once draw returns
    True
    """
    meshcat = MakeMeshcat(port, live=live)
    try:
        return draw(*args, meshcat=meshcat, **kwargs)
    except BaseException as e:
        traceback.clear_frames(e.__traceback__)
        raise
    finally:
        if not _collected_on_this_thread():
            _KEPT_ALIVE.append(meshcat)
        del meshcat


_KEPT_ALIVE: list[Meshcat] = []
"""Meshcats that could not be shown unreferenced: never destroyed off-thread."""


def _collected_on_this_thread(timeout: float = 30.0) -> bool:
    """Collects garbage on this thread until a whole collection run here finds
    none: freeing one batch can release the last outside reference of the
    next (a pydrake diagram survives the collection that frees its owner and
    dies in the one after). Another thread's collection in progress makes
    ``gc.collect`` return at once: it then waits 1 ms and tries again, up to
    ``timeout`` s. Returns whether a collection here found nothing left."""
    me = threading.get_ident()
    ran: list[bool] = []

    def started(phase: str, info: dict) -> None:
        if phase == "start" and info["generation"] == 2:
            ran.append(threading.get_ident() == me)

    gc.callbacks.append(started)
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            ran.clear()
            found = gc.collect()
            if any(ran) and found == 0:
                return True
            if not any(ran):
                time.sleep(0.001)  # let the other thread's collection finish
        return False
    finally:
        gc.callbacks.remove(started)


def _meshcat_optional(draw: Callable[..., _T]) -> Callable[..., _T]:
    """``draw`` with ``meshcat=None`` meaning: a Meshcat of its own, opened and
    destroyed on this thread (:func:`with_own_meshcat`)."""

    @functools.wraps(draw)
    def drawn(*args: object, meshcat: Meshcat | None = None, **kwargs: object) -> _T:
        if meshcat is not None:
            return draw(*args, meshcat=meshcat, **kwargs)
        return with_own_meshcat(draw, *args, **kwargs)

    return drawn


def _reach(model: RobotModel) -> float:
    """An upper bound of the tool's distance from the base, m: the sum of the
    MDH lengths |d| and |r| plus each prismatic joint's largest |q|."""
    slide = model.sigma == 1
    stroke = np.maximum(np.abs(model.limits.lower), np.abs(model.limits.upper))
    return float(np.abs(model.table[:, [1, 3]]).sum() + stroke[slide].sum())


class RobotScene:
    """A robot model drawn in Meshcat through a MultibodyPlant and SceneGraph.

    The diagram is: MultibodyPlant (positions set directly) -> SceneGraph ->
    MeshcatVisualizer. ``set_positions`` + ``publish`` draws a pose; with
    ``recording=True`` every published pose becomes a frame of an animation
    that ``html()`` saves.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import MakeMeshcat, RobotScene
    >>> scene = RobotScene(model=load_robot("rv3sb"), meshcat=MakeMeshcat())
    >>> scene.set_positions(np.zeros(6))
    >>> scene.publish()
    """

    def __init__(
        self,
        *,
        model: RobotModel,
        meshcat: Meshcat,
        recording: bool = False,
        cell: Cell | None = None,
    ) -> None:
        builder = DiagramBuilder()
        # An elastic robot is drawn by its link side: the rigid plant at the
        # link angles (set_positions takes n joint positions either way).
        rigid = dataclasses.replace(model, compliance=None)
        self.plant, self.scene_graph = MakePlant(rigid, builder=builder, cell=cell)
        self.meshcat = meshcat
        self.visualizer = MeshcatVisualizer.AddToBuilder(
            builder, self.scene_graph, meshcat
        )
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self._plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        # Frame the robot: Meshcat's default camera suits a 1 m scene, which
        # makes the RV-3SB a speck and puts the camera inside a DEMO-class arm.
        reach = _reach(model)
        meshcat.SetCameraPose(
            camera_in_world=np.array([0.8, -0.8, 0.55]) * reach,
            target_in_world=np.array([0.0, 0.0, 0.3]) * reach,
        )
        if recording:
            self.visualizer.StartRecording(False)
        self._recording = recording

    def set_positions(self, q: np.ndarray, time: float | None = None) -> None:
        """Sets joint positions q (rad or m) and, if given, the scene time (s)."""
        if time is not None:
            self.context.SetTime(float(time))
        self.plant.SetPositions(self._plant_context, np.asarray(q, dtype=float))

    def publish(self) -> None:
        """Sends the current pose to Meshcat (and records it when recording)."""
        self.diagram.ForcedPublish(self.context)

    def html(self, *, loop: bool = False) -> str:
        """The scene (with its animation, if recorded) as self-contained HTML.

        Args:
          loop: the animation repeats (:data:`LOOP_REPETITIONS` times, about
            forever) instead of playing once and stopping on its last frame.
        """
        if self._recording:
            self.visualizer.StopRecording()
            animation = self.visualizer.get_mutable_recording()
            if loop:
                animation.set_loop_mode(MeshcatAnimation.LoopMode.kLoopRepeat)
                animation.set_repetitions(LOOP_REPETITIONS)
            self.visualizer.PublishRecording()
            self._recording = False
        return self.meshcat.StaticHtml()


@_meshcat_optional
def save_robot_poses_html(
    model: RobotModel,
    poses: Sequence[np.ndarray] | np.ndarray,
    path: str | os.PathLike,
    *,
    seconds_per_pose: float = 1.0,
    meshcat: Meshcat | None = None,
    cell: Cell | None = None,
) -> Path:
    """Writes an HTML animation of ``model`` visiting ``poses`` (rad or m),
    atomically; with its ``cell``'s shapes (visual geometry ``cell/<name>``).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import save_robot_poses_html
    >>> poses = np.array([[0.0, 0.0, 1.0, 0.0, 0.5, 0.0], [0.5, 0.3, 1.2, 0, 0.5, 0]])
    >>> robot = load_robot("rv3sb")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_robot_poses_html(robot, poses, Path(tmp, "p.html"))
    ...     print(path.name, path.stat().st_size > 0)
    ...
    p.html True
    """
    scene = RobotScene(model=model, meshcat=meshcat, recording=True, cell=cell)
    for k, q in enumerate(np.atleast_2d(poses)):
        scene.set_positions(q, time=k * seconds_per_pose)
        scene.publish()
    return atomic_write_text(path, scene.html())


# ---- plane-constraint calibration scenes ---------------------------------------
def add_plate(
    meshcat: Meshcat,
    path: str,
    X_BP: np.ndarray,
    size: Sequence[float],
    *,
    thickness: float = 0.004,
    rgba: Sequence[float] = (0.55, 0.6, 0.7, 0.5),
) -> None:
    """Draws a plate as a thin box whose top face is the plate plane.

    Args:
      meshcat: the scene.
      path: Meshcat path, e.g. ``/calibration/plates/0``.
      X_BP: (4, 4) plate pose in the robot base B (z_P = normal), m.
      size: (2,) edge lengths along x_P, y_P, m.
      thickness: box thickness behind the plane (along -z_P), m.
      rgba: colour.
    """
    meshcat.SetObject(path, Box(float(size[0]), float(size[1]), thickness), Rgba(*rgba))
    X = RigidTransform(np.asarray(X_BP)) @ RigidTransform([0, 0, -thickness / 2])
    meshcat.SetTransform(path, X)


def add_points(
    meshcat: Meshcat,
    path: str,
    p_BM: np.ndarray,
    *,
    radius: float = 0.002,
    rgba: Sequence[float] = (0.9, 0.1, 0.1, 1.0),
) -> None:
    """Draws points (N, 3) in B (m) as small spheres under ``path``/<i>."""
    for i, p in enumerate(np.atleast_2d(p_BM)):
        meshcat.SetObject(f"{path}/{i}", Sphere(radius), Rgba(*rgba))
        meshcat.SetTransform(f"{path}/{i}", RigidTransform(np.asarray(p, float)))


@_meshcat_optional
def save_calibration_html(
    model: RobotModel,
    q: np.ndarray,
    plates: Sequence[tuple[np.ndarray, Sequence[float]]],
    point_sets: Mapping[str, tuple[np.ndarray, Sequence[float]]],
    path: str | os.PathLike,
    *,
    seconds_per_pose: float = 0.5,
    meshcat: Meshcat | None = None,
) -> Path:
    """Writes a Meshcat HTML of a plane-constraint calibration, atomically.

    The robot visits the measurement poses ``q`` (an animation), the plates are
    thin boxes under ``/calibration/plates``, each point set is a group of
    spheres under ``/calibration/<name>`` (toggle them in the Meshcat menu).

    Args:
      model: the robot drawn.
      q: (N, n) joint positions of the readings, rad or m.
      plates: (X_BP (4, 4), size (2,)) per plate, m.
      point_sets: name -> ((N, 3) points in B in m, rgba).
      path: HTML file.
      seconds_per_pose: animation time per pose, s.
      meshcat: an existing Meshcat, or None to open one on localhost.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.systems import save_calibration_html
    >>> robot = load_robot("rv3sb")
    >>> q = np.array([[0.0, 0.3, 1.2, 0.0, 0.5, 0.0], [0.3, 0.3, 1.2, 0, 0.5, 0]])
    >>> plate = (np.eye(4), (0.2, 0.2, 0.8, 0.5))  # X_BP and rgba
    >>> points = {"tool": (tool_points(robot.table, q), (0.9, 0.2, 0.1, 1.0))}
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_calibration_html(robot, q, [plate], points, Path(tmp, "c.html"))
    ...     print(path.name, path.stat().st_size > 0)
    ...
    c.html True
    """
    scene = RobotScene(model=model, meshcat=meshcat, recording=True)
    for i, (X_BP, size) in enumerate(plates):
        add_plate(meshcat, f"/calibration/plates/{i}", X_BP, size)
    for name, (points, rgba) in point_sets.items():
        add_points(meshcat, f"/calibration/{name}", points, rgba=rgba)
    for k, qk in enumerate(np.atleast_2d(q)):
        scene.set_positions(qk, time=k * seconds_per_pose)
        scene.publish()
    return atomic_write_text(path, scene.html())


# ---- path-tracking scenes -----------------------------------------------------
@_meshcat_optional
def save_path_html(
    model: RobotModel,
    t: np.ndarray,
    q: np.ndarray,
    lines: Mapping[str, tuple[np.ndarray, Sequence[float]]],
    path: str | os.PathLike,
    *,
    meshcat: Meshcat | None = None,
    frame_step: int = 3,
) -> Path:
    """Writes an HTML animation of ``model`` at joint positions ``q`` (K, n;
    rad or m) at times ``t`` (K, s; every ``frame_step``-th sample is a frame)
    with polylines ``lines``: name -> ((N, 3) points in B, m; rgba), drawn
    under ``/paths/<name>``. The animation loops (it restarts at its end,
    :meth:`RobotScene.html` with ``loop=True``). The camera looks at the
    lines' centre from 0.6 of the robot's reach.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.systems import save_path_html
    >>> robot = load_robot("rv3sb")
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> q = np.outer(t, [0.5, 0.2, 0.3, 0.0, 0.4, 0.0])
    >>> lines = {"tool": (tool_points(robot.table, q), (0.1, 0.6, 0.2, 1.0))}
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = save_path_html(robot, t, q, lines, Path(tmp, "path.html"))
    ...     print(path.name, path.stat().st_size > 0)
    ...
    path.html True
    """
    scene = RobotScene(model=model, meshcat=meshcat, recording=True)
    for k in range(0, len(t), max(1, int(frame_step))):
        scene.set_positions(q[k], time=float(t[k]))
        scene.publish()
    points = np.concatenate([np.atleast_2d(p) for p, _ in lines.values()])
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    reach = _reach(model)
    meshcat.SetCameraPose(
        camera_in_world=centre + 0.6 * reach * np.array([0.8, -0.8, 0.55]),
        target_in_world=centre,
    )
    for name, (p_B, rgba) in lines.items():
        vertices = np.ascontiguousarray(np.asarray(p_B, dtype=float).T)
        meshcat.SetLine(f"/paths/{name}", vertices, 2.0, Rgba(*rgba))
    return atomic_write_text(path, scene.html(loop=True))


#: The colours of the copies of :func:`save_robot_states_html`, in order:
#: (name shown in the page, (r, g, b) in [0, 1]).
STATE_COLOURS: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("grey", (0.55, 0.55, 0.58)),
    ("red", (0.85, 0.15, 0.10)),
    ("green", (0.10, 0.65, 0.20)),
    ("blue", (0.15, 0.35, 0.85)),
    ("purple", (0.55, 0.25, 0.70)),
    ("orange", (0.95, 0.55, 0.10)),
)

#: The opacity of a copy's payload relative to the copy's own: the payload, a
#: sphere sized by its mass, would hide the wrist of every copy.
PAYLOAD_OPACITY = 0.25


def state_path(label: str, colour: str) -> str:
    """The Meshcat path of :func:`save_robot_states_html`'s copy ``label``
    drawn in ``colour`` (a name of :data:`STATE_COLOURS`)."""
    return f"/drake/{label} ({colour})"


def recolour(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    rgb: Sequence[float],
    opacity: float,
    *,
    payload_opacity: float = PAYLOAD_OPACITY,
    base: bool = True,
) -> None:
    """Gives every illustration geometry of ``plant`` (registered in
    ``scene_graph``, before a context is made) the diffuse colour ``rgb``
    ((3,), [0, 1]) at ``opacity`` in (0, 1]; the body ``payload``'s at
    ``opacity * payload_opacity``; the shapes fixed to the world (pedestal,
    base link) opaque, or, ``base`` False, without their illustration role, so
    that a copy drawn over another does not draw the same base again.

    The colour is the material's, so it holds in a live Meshcat and in its
    saved HTML alike (a Meshcat property set on the copy's path is sent
    before its shapes in a saved page and is lost; and
    ``MeshcatVisualizerParams.default_color`` colours only shapes without a
    colour of their own, which no shape of :func:`MakePlant` is)."""
    with drake_messages_dropped(ROLE_REPLACED):  # before any visualizer reads them
        _recolour(plant, scene_graph, rgb, opacity, payload_opacity, base)


def _recolour(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    rgb: Sequence[float],
    opacity: float,
    payload_opacity: float,
    base: bool,
) -> None:
    """:func:`recolour` without its logging filter."""
    inspector = scene_graph.model_inspector()
    source = plant.get_source_id()
    for geometry in inspector.GetAllGeometryIds(Role.kIllustration):
        if not inspector.BelongsToSource(geometry, source):
            continue
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
        fixed = body is not None and body.index() == plant.world_body().index()
        if fixed and not base:
            scene_graph.RemoveRole(source, geometry, Role.kIllustration)
            continue
        payload = body is not None and body.name() == "payload"
        alpha = 1.0 if fixed else opacity * (payload_opacity if payload else 1.0)
        properties = IllustrationProperties(
            inspector.GetIllustrationProperties(geometry)
        )
        properties.UpdateProperty("phong", "diffuse", Rgba(*rgb[:3], alpha))
        scene_graph.AssignRole(source, geometry, properties, RoleAssign.kReplace)


def _legend_html(
    entries: Sequence[tuple[str, Sequence[float], float]], note: str = ""
) -> str:
    """A fixed box at the page's top left listing (label, (r, g, b), opacity)
    as a coloured square and its label, then ``note`` (plain text) in small
    type; the page's mouse input passes through it."""
    rows = "".join(
        '<div style="margin:2px 0"><span style="display:inline-block;width:12px;'
        "height:12px;margin-right:6px;vertical-align:middle;background:"
        f"rgba({round(255 * r)},{round(255 * g)},{round(255 * b)},"
        f'{max(a, 0.35):.2f});border:1px solid #333"></span>{html.escape(label)}'
        "</div>"
        for label, (r, g, b), a in entries
    )
    if note:
        rows += (
            '<div style="margin-top:4px;max-width:260px;font-size:11px">'
            f"{html.escape(note)}</div>"
        )
    return (
        '<div id="rmdrake-legend" style="position:fixed;top:8px;left:8px;'
        "z-index:10;padding:6px 8px;background:rgba(255,255,255,0.85);"
        'font:13px sans-serif;border-radius:4px;pointer-events:none">'
        f"{rows}</div>\n"
    )


@_meshcat_optional
def save_robot_states_html(
    model: RobotModel,
    states: Mapping[str, tuple[np.ndarray, float]],
    path: str | os.PathLike,
    *,
    meshcat: Meshcat | None = None,
    colours: Sequence[tuple[str, Sequence[float]]] = STATE_COLOURS,
    note: str = "",
) -> Path:
    """Writes a Meshcat HTML of ``model`` drawn several times at once, atomically,
    e.g. an elastic arm's nominal pose, its sag and its compensation.

    ``states`` maps a label to (q (n,), rad or m; opacity in (0, 1]). Copy k is
    drawn all in the k-th colour of ``colours`` ((name, (r, g, b)) pairs,
    cycled; grey, red, green, ... by default) at its opacity, its payload
    sphere (if any) at :data:`PAYLOAD_OPACITY` of that, so that it hides no
    arm; the base, fixed, is drawn once, by the first copy.

    Meshcat has no legend (nor text), so the page names each copy twice:
    (1) its path, ``/drake/<label> (<colour>)``
    (:func:`state_path`), which is its entry in Meshcat's control panel, where
    it can be hidden, and (2) a fixed box at the top left of the page with a
    square of each copy's colour and its label (plain HTML over the scene),
    followed by ``note`` (plain text, e.g. a magnification), if any.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.systems import save_robot_states_html
    >>> q = np.array([0.0, 0.5, 0.5, 0.0, 0.5, 0.0])
    >>> states = {"nominal": (q, 1.0), "moved": (q + 0.2, 0.5)}  # name: (q, opacity)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     robot = load_robot("rv3sb")
    ...     path = save_robot_states_html(robot, states, Path(tmp, "s.html"))
    ...     print(path.name, path.stat().st_size > 0)
    ...
    s.html True
    """
    rigid = dataclasses.replace(model, compliance=None)
    builder = DiagramBuilder()
    plants = []
    entries: list[tuple[str, Sequence[float], float]] = []
    for k, (label, (_, opacity)) in enumerate(states.items()):
        name, rgb = colours[k % len(colours)]
        plant, scene_graph = MakePlant(rigid, builder=builder)
        plant.set_name(f"plant_{label}")
        scene_graph.set_name(f"scene_graph_{label}")
        recolour(plant, scene_graph, rgb, float(opacity), base=k == 0)
        prefix = state_path(label, name).removeprefix("/drake/")
        params = MeshcatVisualizerParams(prefix=prefix)
        visualizer = MeshcatVisualizer.AddToBuilder(
            builder, scene_graph, meshcat, params
        )
        visualizer.set_name(f"meshcat_{label}")
        plants.append(plant)
        entries.append((f"{label} ({name})", rgb, float(opacity)))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    for plant, (q, _) in zip(plants, states.values(), strict=True):
        plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q)
    diagram.ForcedPublish(context)
    reach = _reach(model)
    meshcat.SetCameraPose(
        camera_in_world=np.array([0.8, -0.8, 0.55]) * reach,
        target_in_world=np.array([0.0, 0.0, 0.3]) * reach,
    )
    page = meshcat.StaticHtml()
    at = page.rfind("</body>")
    page = page[:at] + _legend_html(entries, note) + page[at:]
    return atomic_write_text(path, page)
