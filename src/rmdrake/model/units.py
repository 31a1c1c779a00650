"""The units of a robot model: SI (m, rad, rad/s, m/s^2), checked against
values no manipulator has, so a model written in mm or degrees is refused at
load instead of calibrating and driving a robot a thousand times too large.

:func:`check_units` is the one check, applied at every door a robot comes in
by: a robot YAML or shipped model
(:meth:`~rmdrake.model.robot.RobotModel.from_dict`) and a URDF
(:func:`~rmdrake.model.urdf.importer.robot_from_urdf`: ``import-urdf`` and
``--robot x.urdf`` on every command), before anything is written. A model
computed in SI (a calibration result) is judged by the calibration's own
checks instead."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["MAX_ANGLE", "MAX_GRAVITY", "MAX_LENGTH", "MAX_VELOCITY", "check_units"]

MAX_LENGTH = 100.0
"""m: no MDH length (d, r) of a manipulator is longer; a longer one is a robot
written in mm."""
MAX_ANGLE = 4.0 * math.pi
"""rad: no MDH angle offset or joint limit beyond two turns; a larger one is
written in degrees."""
MAX_VELOCITY = 100.0
"""rad/s: no joint is faster (industrial arms reach about 10); a faster one is
a limit written in deg/s."""
MAX_GRAVITY = 30.0
"""m/s^2: no robot works under a stronger gravity (Earth's is 9.81, Jupiter's
about 25); a stronger one is in cm/s^2 or mm/s^2, or a typo, and would make
every simulation step tiny (1e6 m/s^2 estimated 2,146 s for a short run)."""


def check_units(
    mdh: np.ndarray,
    tool: np.ndarray,
    limits: object,
    sigma: object = None,
    gravity: object = None,
) -> None:
    """ValueError when the model is evidently in mm or degrees: a length over
    :data:`MAX_LENGTH`, an angle or revolute joint limit over :data:`MAX_ANGLE`,
    a prismatic joint limit over :data:`MAX_LENGTH`, a velocity limit over
    :data:`MAX_VELOCITY`, a ``gravity`` (3,) (m/s^2; None: not checked) whose
    norm is over :data:`MAX_GRAVITY`. ``limits`` has arrays ``lower``,
    ``upper`` (rad, or m where ``sigma`` is 1) and ``velocity`` (rad/s or
    m/s).

    Example:

    >>> import numpy as np
    >>> from rmdrake.model.robot import JointLimits
    >>> from rmdrake.model.units import check_units
    >>> limits = JointLimits([-1.0], [1.0], [2.0], [4.0])
    >>> mdh, tool = np.zeros((1, 5)), np.array([0.0, 0.0, 0.0, 350.0, 0.0])
    >>> try:
    ...     check_units(mdh, tool, limits)
    ... except ValueError as e:
    ...     print(e)
    mdh tool: r = 350 is beyond 100 m: ... (this looks like mm? convert the lengths ...
    """
    n = np.shape(mdh)[0]
    prismatic = np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1
    rows = np.vstack([mdh, tool])
    names = ("alpha", "d", "theta", "r", "beta")
    for col, name in enumerate(names):
        bound, unit = (MAX_LENGTH, "m") if name in ("d", "r") else (MAX_ANGLE, "rad")
        big = np.flatnonzero(np.abs(rows[:, col]) > bound)
        if big.size:
            i = int(big[0])
            where = "tool" if i == mdh.shape[0] else f"row {i + 1}"
            raise ValueError(
                f"mdh {where}: {name} = {rows[i, col]:g} is beyond {bound:.4g} {unit}: "
                f"the model must be in {unit}"
                + (
                    " (this looks like mm? convert the lengths to m)"
                    if unit == "m"
                    else " (this looks like degrees? convert the angles to rad)"
                )
            )
    for key, bound, unit in (
        ("lower", MAX_ANGLE, "rad"),
        ("upper", MAX_ANGLE, "rad"),
        ("velocity", MAX_VELOCITY, "rad/s"),
    ):
        vals = np.asarray(getattr(limits, key))
        bounds = np.where(prismatic, MAX_LENGTH if key != "velocity" else bound, bound)
        big = np.flatnonzero(np.abs(vals) > bounds)
        if big.size:
            j = int(big[0])
            if prismatic[j]:
                unit, looks = unit.replace("rad", "m"), "mm"
            else:
                looks = "degrees"
            raise ValueError(
                f"limits.{key}: joint {j + 1} has {vals[j]:g}, beyond "
                f"{bounds[j]:.4g} {unit}: limits are in {unit} (this looks like "
                f"{looks}?)"
            )
    if gravity is not None:
        _check_gravity(np.asarray(gravity, dtype=float))


def _check_gravity(g: np.ndarray) -> None:
    """ValueError naming the ``gravity`` key when ``|g|`` is over
    :data:`MAX_GRAVITY` m/s^2, with the unit it looks like (cm/s^2, mm/s^2)."""
    norm = float(np.linalg.norm(g))
    if norm <= MAX_GRAVITY:
        return
    looks = ""
    for unit, factor in (("cm/s^2", 100.0), ("mm/s^2", 1000.0)):
        if 5.0 <= norm / factor <= MAX_GRAVITY:
            looks = f" (this looks like {unit}? convert to m/s^2)"
    raise ValueError(
        f"gravity: |g| = {norm:g} m/s^2 is beyond {MAX_GRAVITY:g} m/s^2 (Earth's "
        f"is 9.81): gravity is in m/s^2{looks}"
    )
