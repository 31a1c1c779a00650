"""Cartesian test paths and the joint programs that follow them.

A path is a closed planar curve (a circle, or a rectangle with rounded
corners, as path-accuracy tests in the manner of ISO 9283 use) in a plane of
the base frame B, parametrised by arc length u in [0, L] m. The tool runs it
once with a fixed orientation R_BE along the minimum-jerk time law

    u(t) = L (10 s^3 - 15 s^4 + 6 s^5),   s = t / T,

which starts and ends at rest (peak tool speed 1.875 L / T). The joint program
is planned on a robot model (the NOMINAL one, as a robot's programmer does):
the tool poses at ``samples`` instants evenly spaced in time are solved by
:func:`~rmdrake.compensation.correction.correct_path` (warm-started along the path) and
joined by a cubic spline with continuous accelerations and zero end velocity
(pydrake ``PiecewisePolynomial``). The duration T is the shortest for which
the spline's joint velocities and accelerations stay within ``speed`` times
the model's limits; joint velocities scale as 1/T and accelerations as 1/T^2,
so T is found from one spline at T = 1. Joint positions are in rad for a
revolute joint and in m for a prismatic one (``RobotModel.sigma``), their
rates and limits likewise.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rmdrake.arrays import as_finite_array
from rmdrake.compensation.correction import correct_path
from rmdrake.model.robot import RobotModel

__all__ = [
    "PATH_KINDS",
    "JointPathProgram",
    "PlanarPath",
    "min_jerk",
    "plan_path_program",
]

PATH_KINDS = ("circle", "rectangle", "line")
"""The shapes of :class:`PlanarPath`."""


@dataclasses.dataclass(frozen=True)
class PlanarPath:
    """A path in the plane through ``centre`` (m, in B) spanned by the first
    two columns of ``R_BP`` (its third column is the plane's normal).

    Attributes:
      kind: ``circle`` (diameter ``size``) or ``rectangle`` (``size`` wide
        along P's x, ``aspect * size`` high along P's y, corners rounded with
        radius ``corner`` times the shorter side), or ``line`` (straight, from
        ``centre`` ``size`` along P's x: an insertion-like move).
      centre: (3,) m in B.
      R_BP: (3, 3) rotation of the path plane in B.
      size: m.
      aspect: rectangle height / width.
      corner: rectangle corner radius / shorter side, in (0, 0.5].

    The closed ones start at the point (+size/2, 0) of the plane (on the right edge's
    middle for the rectangle) and run counter-clockwise about P's z.

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import PATH_KINDS, PlanarPath
    >>> centre = np.array([0.35, 0, 0.4])
    >>> path = PlanarPath("circle", centre=centre, R_BP=np.eye(3), size=0.1)
    >>> PATH_KINDS, path.kind
    (('circle', 'rectangle', 'line'), 'circle')
    """

    kind: str
    centre: np.ndarray
    R_BP: np.ndarray
    size: float
    aspect: float = 0.6
    corner: float = 0.2

    def __post_init__(self) -> None:
        if self.kind not in PATH_KINDS:
            raise ValueError(
                f"path kind: expected one of {', '.join(PATH_KINDS)}, "
                f"found {self.kind!r}"
            )
        for name, value, ok, rule in (
            ("size", self.size, self.size > 0, "> 0 m"),
            ("aspect", self.aspect, self.aspect > 0, "> 0"),
            ("corner", self.corner, 0 < self.corner <= 0.5, "in (0, 0.5]"),
        ):
            if not (np.isfinite(value) and ok):
                raise ValueError(f"path {name}: expected {rule}, found {value}")
        as_finite_array(self.centre, "path centre", (3,))
        R = as_finite_array(self.R_BP, "path R_BP", (3, 3))
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9):
            raise ValueError("path R_BP: expected a rotation matrix")

    def _segments(self) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
        """Straight ('line', start, direction, length) and arc ('arc', centre,
        start angle, length) pieces in the plane, counter-clockwise."""
        w, h = 0.5 * self.size, 0.5 * self.aspect * self.size
        if self.kind == "line":
            return [("line", np.zeros(2), np.array([1.0, 0.0]), self.size)]
        if self.kind == "circle":
            return [("arc", np.zeros(2), np.array([0.0, w]), 2 * np.pi * w)]
        r = self.corner * 2 * min(w, h)
        pieces: list[tuple[str, np.ndarray, np.ndarray, float]] = [
            ("line", np.array([w, 0.0]), np.array([0.0, 1.0]), h - r)
        ]
        corners = ((w - r, h - r), (-w + r, h - r), (-w + r, -h + r), (w - r, -h + r))
        sides = ((-1.0, 0.0, 2 * (w - r)), (0.0, -1.0, 2 * (h - r)),
                 (1.0, 0.0, 2 * (w - r)), (0.0, 1.0, 2 * (h - r)))  # fmt: skip
        for k, (c, (dx, dy, length)) in enumerate(zip(corners, sides, strict=True)):
            c = np.array(c)
            pieces.append(("arc", c, np.array([k * np.pi / 2, r]), np.pi * r / 2))
            start = c + r * np.array([np.cos((k + 1) * np.pi / 2),
                                      np.sin((k + 1) * np.pi / 2)])  # fmt: skip
            if k == 3:
                length = h - r  # back to the start point
            pieces.append(("line", start, np.array([dx, dy]), length))
        return [p for p in pieces if p[3] > 0]

    @property
    def length(self) -> float:
        """Arc length L of the path, m."""
        return float(sum(p[3] for p in self._segments()))

    def points(self, u: object) -> np.ndarray:
        """(M, 3) points in B at arc lengths ``u`` (M,) m, clipped to [0, L]."""
        u = np.clip(np.atleast_1d(as_finite_array(u, "u")), 0.0, self.length)
        xy = np.zeros((u.size, 2))
        offset = 0.0
        segments = self._segments()
        for i, (kind, a, b, length) in enumerate(segments):
            last = i == len(segments) - 1
            on = (u >= offset) & ((u < offset + length) | last)
            d = u[on] - offset
            if kind == "line":
                xy[on] = a + d[:, None] * b
            else:
                angle0, radius = b
                phi = angle0 + d / radius
                xy[on] = a + radius * np.column_stack([np.cos(phi), np.sin(phi)])
            offset += length
        R = np.asarray(self.R_BP, dtype=float)
        return np.asarray(self.centre, dtype=float) + xy @ R[:, :2].T


def min_jerk(s: np.ndarray) -> np.ndarray:
    """The fraction of the path done at normalised time s in [0, 1].

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import min_jerk
    >>> min_jerk(np.array([0.0, 0.5, 1.0]))
    array([0. , 0.5, 1. ])
    """
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)


@dataclasses.dataclass(frozen=True)
class JointPathProgram:
    """A joint program following a :class:`PlanarPath`.

    Attributes:
      path: the path.
      R_BE: (3, 3) the fixed tool orientation.
      duration: T, s.
      trajectory: the joint program, an (n, 1) ``PiecewisePolynomial`` on
        [0, T] (rad or m), twice continuously differentiable.
      knots: (M, n) the solved joint positions at the spline's knots, rad or m.
      speed: the fraction of the joint velocity and acceleration limits used.
      peak_tool_speed: 1.875 L / T, m/s.
      residual: largest tool position residual of the solved knots, m.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_poses
    >>> from rmdrake.compensation import JointPathProgram, PlanarPath
    >>> from rmdrake.compensation import plan_path_program
    >>> robot = load_robot("rv3sb")
    >>> q0 = np.array([0.0, 0.3, 1.2, 0.0, 0.8, 0.0])
    >>> X_BE = tool_poses(robot.table, q0[None])[0]
    >>> path = PlanarPath("line", centre=X_BE[:3, 3], R_BP=np.eye(3), size=0.02)
    >>> R_BE = X_BE[:3, :3]
    >>> program = plan_path_program(robot, path, R_BE, q_seed=q0, speed=0.5, samples=20)
    >>> isinstance(program, JointPathProgram), program.trajectory.rows()
    (True, 6)
    """

    path: PlanarPath
    R_BE: np.ndarray
    duration: float
    trajectory: PiecewisePolynomial
    knots: np.ndarray
    speed: float
    peak_tool_speed: float
    residual: float

    def tool_points(self, t: object) -> np.ndarray:
        """(M, 3) the path's points in B at times ``t`` (M,) s."""
        s = np.asarray(t, dtype=float) / self.duration
        return self.path.points(self.path.length * min_jerk(s))


def plan_path_program(
    model: RobotModel,
    path: PlanarPath,
    R_BE: np.ndarray,
    *,
    q_seed: np.ndarray,
    speed: float,
    samples: int = 1201,
) -> JointPathProgram:
    """Plans the joint program of ``model`` running ``path`` once with the tool
    orientation ``R_BE`` (3, 3) in B, as fast as ``speed`` (in (0, 1]) times the
    joint velocity and acceleration limits allow (see the module docstring).

    Args:
      q_seed: (n,) joint positions near the solution at the path's start, rad
        or m (they pick the branch: elbow, wrist).
      samples: knots of the spline (>= 10).

    Raises:
      ValueError: a speed out of (0, 1], too few samples, or a path point the
        model cannot reach with that orientation (its index and residual).

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_poses
    >>> from rmdrake.compensation import PlanarPath, plan_path_program
    >>> robot = load_robot("rv3sb")
    >>> q0 = np.array([0.0, 0.3, 1.2, 0.0, 0.8, 0.0])
    >>> X_BE = tool_poses(robot.table, q0[None])[0]
    >>> path = PlanarPath("line", centre=X_BE[:3, 3], R_BP=np.eye(3), size=0.02)
    >>> R_BE = X_BE[:3, :3]
    >>> program = plan_path_program(robot, path, R_BE, q_seed=q0, speed=0.5, samples=20)
    >>> program.knots.shape, bool(program.duration > 0)
    ((20, 6), True)
    """
    if not (np.isfinite(speed) and 0 < speed <= 1):
        raise ValueError(f"speed: expected a fraction in (0, 1], found {speed}")
    if samples < 10:
        raise ValueError(f"samples: expected at least 10, found {samples}")
    s = np.linspace(0.0, 1.0, samples)
    p = path.points(path.length * min_jerk(s))
    R = np.broadcast_to(as_finite_array(R_BE, "R_BE", (3, 3)), (samples, 3, 3))
    ik = correct_path(model, p, q_start=q_seed, orientation=R)
    if not ik.reachable.all():
        raise ValueError(f"path {path.kind}: {ik.summary()}")
    n = model.n_joints
    zero = np.zeros((n, 1))
    unit = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        s, ik.q.T, zero, zero
    )
    dense = np.linspace(0.0, 1.0, 8 * samples)
    v1 = np.abs(unit.MakeDerivative(1).vector_values(dense)).max(axis=1)
    a1 = np.abs(unit.MakeDerivative(2).vector_values(dense)).max(axis=1)
    lim = model.limits
    T = float(
        max(
            (v1 / (speed * lim.velocity)).max(),
            np.sqrt(a1 / (speed * lim.acceleration)).max(),
        )
    )
    trajectory = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        s * T, ik.q.T, zero, zero
    )
    return JointPathProgram(
        path=path,
        R_BE=np.array(R_BE, dtype=float),
        duration=T,
        trajectory=trajectory,
        knots=ik.q,
        speed=float(speed),
        peak_tool_speed=1.875 * path.length / T,
        residual=float(ik.position_residual.max()),
    )
