"""The units of a robot model: SI (m, rad, rad/s), checked against values no
manipulator has, so a model written in mm or degrees is refused at load
instead of calibrating and driving a robot a thousand times too large."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["MAX_ANGLE", "MAX_LENGTH", "MAX_VELOCITY", "check_units"]

MAX_LENGTH = 100.0
"""m: no MDH length (d, r) of a manipulator is longer; a longer one is a robot
written in mm."""
MAX_ANGLE = 4.0 * math.pi
"""rad: no MDH angle offset or joint limit beyond two turns; a larger one is
written in degrees."""
MAX_VELOCITY = 100.0
"""rad/s: no joint is faster (industrial arms reach about 10); a faster one is
a limit written in deg/s."""


def check_units(
    mdh: np.ndarray, tool: np.ndarray, limits: object, sigma: object = None
) -> None:
    """ValueError when the model is evidently in mm or degrees: a length over
    :data:`MAX_LENGTH`, an angle or revolute joint limit over :data:`MAX_ANGLE`,
    a prismatic joint limit over :data:`MAX_LENGTH`, a velocity limit over
    :data:`MAX_VELOCITY`. ``limits`` has arrays ``lower``, ``upper`` (rad, or m
    where ``sigma`` is 1) and ``velocity`` (rad/s or m/s)."""
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
                    " (this looks like mm)"
                    if unit == "m"
                    else " (this looks like degrees)"
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
                f"{looks})"
            )
