"""Clearance of a robot in its cell, batched over joint configurations.

:class:`ClearanceChecker` builds the robot's plant with collision capsules along
its MDH segments and the cell's shapes as anchored geometry
(:func:`rmdrake.model.plant.MakePlant`, ``collision_radius`` and ``cell``), and
for (N, n) joint positions returns, per configuration, the smallest signed
distance (m) between the robot and the cell and between links that are not
filtered as adjacent (:func:`rmdrake.model.plant.collision_filtered_pairs`), by
Drake's ``QueryObject.ComputeSignedDistancePairwiseClosestPoints``. Negative:
penetration depth.

The capsule radius is ``radius`` (m) or by default
:data:`DEFAULT_RADIUS_FRACTION` times the robot's size
(:func:`rmdrake.kinematics.forward.robot_reach`): 0.047 m on the RV-3SB
(reach 1.18 m), about its arm's half-width. An elastic robot is checked on its
link side: q are the link angles (rigid plant).

:meth:`ClearanceChecker.clear`, the yes/no test the designs use, stops at the
first pair closer than the clearance and is much cheaper than
:meth:`ClearanceChecker.distances`, which computes every pair (fewer with
``max_distance``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import pickle

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
from pydrake.systems.framework import DiagramBuilder

from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.plant import CELL_PREFIX, MakePlant
from rmdrake.model.robot import RobotModel
from rmdrake.model.scene import Cell

__all__ = ["DEFAULT_RADIUS_FRACTION", "ClearanceChecker", "default_collision_radius"]

DEFAULT_RADIUS_FRACTION = 0.04
"""Default capsule radius as a fraction of the robot's size (robot_reach)."""


def default_collision_radius(model: RobotModel) -> float:
    """:data:`DEFAULT_RADIUS_FRACTION` x :func:`robot_reach` (m)."""
    return DEFAULT_RADIUS_FRACTION * robot_reach(model)


class _Query:
    """A plant of ``model`` with collision capsules (radius + margin, m) and
    optionally the cell, and the means to query its SceneGraph at q."""

    def __init__(
        self,
        model: RobotModel,
        radius: float,
        margin: float,
        cell: Cell | None,
        self_pairs: bool,
    ) -> None:
        builder = DiagramBuilder()
        rigid = dataclasses.replace(model, compliance=None)
        self.plant, self.scene_graph = MakePlant(
            rigid,
            builder=builder,
            visual=False,
            collision_radius=radius,
            collision_margin=margin,
            cell=cell,
        )
        inspector = self.scene_graph.model_inspector()
        ids = inspector.GetAllGeometryIds()
        self.cell_ids = {g for g in ids if inspector.GetName(g).startswith(CELL_PREFIX)}
        if not self_pairs:
            robot = [g for g in ids if g not in self.cell_ids]
            self.scene_graph.collision_filter_manager().Apply(
                CollisionFilterDeclaration().ExcludeWithin(GeometrySet(robot))
            )
        self.diagram = builder.Build()  # after the filters: the context has them
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.sg_context = self.scene_graph.GetMyContextFromRoot(self.context)
        self.port = self.scene_graph.get_query_output_port()

    def at(self, q: np.ndarray):
        """The QueryObject at joint positions q (n,), rad or m."""
        self.plant.SetPositions(self.plant_context, q)
        return self.port.Eval(self.sg_context)


class ClearanceChecker:
    """Signed distances of a robot to its cell and to itself, per configuration.

    Attributes:
      model: the robot; cell: its cell; radius: the capsule radius, m.
      self_collision: whether :meth:`clear` and :meth:`clearance` count the
        distance between links too (:meth:`distances` always reports it).
        Off by default: the capsules lie on the MDH segments, in the arm's
        plane, where a real arm's links sit side by side, so an elbow folded
        within its joint limits (the RV-3SB's q3 up to 171 deg) overlaps
        capsules the real links keep apart.
    """

    def __init__(
        self,
        *,
        model: RobotModel,
        cell: Cell,
        radius: float | None = None,
        self_collision: bool = False,
    ) -> None:
        self.model = model
        self.cell = cell
        self.self_collision = bool(self_collision)
        self.radius = default_collision_radius(model) if radius is None else radius
        self._query = _Query(model, self.radius, 0.0, cell, True)
        self._inflated: dict[float, tuple[_Query, _Query]] = {}

    def __reduce__(self) -> tuple:
        """Pickles as its description (robot, cell, capsule radius m,
        self-collision): the Drake plant inside is rebuilt where it is
        unpickled, once per process (:func:`_rebuilt_checker`)."""
        fields = (self.model, self.cell, self.radius, self.self_collision)
        key = hashlib.sha256(pickle.dumps(fields)).hexdigest()
        return _rebuilt_checker, (key, *fields)

    def distances(
        self, q: np.ndarray, max_distance: float = math.inf
    ) -> tuple[np.ndarray, np.ndarray]:
        """(d_cell, d_self), each (N,) in m, for joint positions q (N, n) or (n,)
        (rad or m): the smallest signed distance between a robot capsule and a
        cell shape, and between two robot capsules of non-filtered links
        (``ComputeSignedDistancePairwiseClosestPoints``). Pairs farther than
        ``max_distance`` (m) are not reported: a minimum above it is ``inf``."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        d_cell = np.full(q.shape[0], np.inf)
        d_self = np.full(q.shape[0], np.inf)
        cell_ids = self._query.cell_ids
        for i, qi in enumerate(q):
            query = self._query.at(qi)
            for pair in query.ComputeSignedDistancePairwiseClosestPoints(max_distance):
                d = pair.distance
                if pair.id_A in cell_ids or pair.id_B in cell_ids:
                    d_cell[i] = min(d_cell[i], d)
                else:
                    d_self[i] = min(d_self[i], d)
        return d_cell, d_self

    def nearest_link(self, q: np.ndarray) -> tuple[float, str]:
        """(signed distance m, link name) of the robot's link nearest the cell
        at one configuration q (n,) (rad or m): the link (``link<j>``, or
        ``base``) whose capsule is closest to (negative: inside) a cell
        shape, as :meth:`distances` measures it.

        Example:

        >>> import numpy as np
        >>> from rmdrake import load_robot
        >>> from rmdrake.kinematics.clearance import ClearanceChecker
        >>> from rmdrake.model.scene import load_cell
        >>> checker = ClearanceChecker(model=load_robot("rv3sb"),
        ...                            cell=load_cell("rv3sb_table"))
        >>> d, link = checker.nearest_link(np.zeros(6))
        >>> bool(d > 0), link.startswith(("link", "base"))
        (True, True)
        """
        query = self._query
        found = query.at(np.asarray(q, dtype=float))
        inspector = query.scene_graph.model_inspector()
        best, link = math.inf, ""
        for pair in found.ComputeSignedDistancePairwiseClosestPoints():
            ids = {pair.id_A, pair.id_B}
            robot = ids - query.cell_ids
            if len(robot) != 1 or pair.distance >= best:
                continue  # a pair of two links, or of two cell shapes
            frame = inspector.GetFrameId(robot.pop())
            best = pair.distance
            link = query.plant.GetBodyFromFrameId(frame).name()
        return best, link

    def clearance(self, q: np.ndarray, max_distance: float = math.inf) -> np.ndarray:
        """(N,) the distance of :meth:`distances` to the cell, m, or with
        ``self_collision`` the smaller of the two."""
        d_cell, d_self = self.distances(q, max_distance)
        return np.minimum(d_cell, d_self) if self.self_collision else d_cell

    def clear(self, q: np.ndarray, clearance: float) -> np.ndarray:
        """(N,) True where configuration q[i] (rad or m) keeps at least
        ``clearance`` (m) from the cell (and, with ``self_collision``, between
        non-filtered links).

        Exact and about 10x cheaper than :meth:`distances`: a capsule comes
        within c of a shape exactly when the capsule inflated by c touches it,
        so this asks SceneGraph's ``HasCollisions`` of two plants built once
        per clearance: capsules inflated by c against the cell, and capsules
        inflated by c / 2 against each other.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        hit = self._hit(clearance)
        return np.array([not hit(qi) for qi in q], dtype=bool)

    def clear_prefix(self, q: np.ndarray, clearance: float) -> int:
        """How many of the configurations q (S, n) keep ``clearance`` (m)
        before the first that does not (S: all do); :meth:`clear`'s test,
        stopping at the first failure."""
        hit = self._hit(clearance)
        for k, qk in enumerate(np.atleast_2d(np.asarray(q, dtype=float))):
            if hit(qk):
                return k
        return int(np.atleast_2d(q).shape[0])

    def _hit(self, clearance: float):
        """The test q (n,) -> True when q comes closer than ``clearance`` (m)."""
        c = float(clearance)
        if not (math.isfinite(c) and c >= 0):
            raise ValueError(f"clearance: expected a finite m >= 0, found {c}")
        if c not in self._inflated:
            self._inflated[c] = (
                _Query(self.model, self.radius, c, self.cell, False),
                _Query(self.model, self.radius, 0.5 * c, None, True),
            )
        to_cell, to_self = self._inflated[c]

        def hit(qi: np.ndarray) -> bool:
            if to_cell.at(qi).HasCollisions():
                return True
            return self.self_collision and to_self.at(qi).HasCollisions()

        return hit


_REBUILT: dict[str, ClearanceChecker] = {}
"""This process's last checker rebuilt from a pickle, by its description's
digest (a design's tasks all carry the same one)."""


def _rebuilt_checker(
    key: str, model: RobotModel, cell: Cell, radius: float, self_collision: bool
) -> ClearanceChecker:
    """The checker of a pickle (:meth:`ClearanceChecker.__reduce__`), built
    once per process for a description (``key``, its digest)."""
    found = _REBUILT.get(key)
    if found is None:
        found = ClearanceChecker(
            model=model, cell=cell, radius=radius, self_collision=self_collision
        )
        _REBUILT.clear()  # one design at a time: keep the last checker only
        _REBUILT[key] = found
    return found
