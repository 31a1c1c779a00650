"""Named kinematic error parameters of a robot's MDH table.

Error parameters are named ``dalpha<j>``, ``dd<j>``, ``dtheta<j>``, ``dr<j>``,
``dbeta<j>`` with j = 1..n+1 (n+1 = the tool row); each adds to one entry of the
table ``RobotModel.table`` (rad or m). Re-exported by :mod:`rmdrake.robot`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.arrays import as_finite_array

if TYPE_CHECKING:  # robot.py imports this module; no import back at run time
    from rmdrake.robot import RobotModel

__all__ = [
    "MDH_KEYS",
    "apply_deltas",
    "error_parameter_indices",
    "error_parameter_names",
]

#: The columns of an MDH row, in table order.
MDH_KEYS: tuple[str, ...] = ("alpha", "d", "theta", "r", "beta")
_PARAM_RE = re.compile(r"^d(alpha|d|theta|r|beta)(\d+)$")


def error_parameter_names(model: RobotModel, preset: str = "paper") -> list[str]:
    """Named error parameters of a preset.

    Presets:
      ``paper``: the 17 of the paper's Table 1 (6-joint arms only): dalpha2..7,
        dd2..7, dr2, dr4, dr5, dr6, dbeta3.
      ``full``: all five parameters of every row 1..n+1 (5(n+1) names); not all
        are identifiable from any measurement, see the calibration's
        identifiability analysis.
    """
    n = model.n_joints
    if preset == "paper":
        if n != 6:
            raise ValueError(
                f"preset 'paper' is the 17 parameters of the paper's 6-joint arm; "
                f"this robot has {n} joints (use 'full' or name the parameters)"
            )
        return (
            [f"dalpha{j}" for j in range(2, 8)]
            + [f"dd{j}" for j in range(2, 8)]
            + ["dr2", "dr4", "dr5", "dr6", "dbeta3"]
        )
    if preset == "full":
        return [f"d{k}{j}" for j in range(1, n + 2) for k in MDH_KEYS]
    raise ValueError(f"unknown parameter preset '{preset}': expected 'paper' or 'full'")


def error_parameter_indices(model: RobotModel, names: Iterable[str]) -> np.ndarray:
    """Flat indices into ``model.table.ravel()`` of named error parameters.

    Raises:
      ValueError: for an unknown or duplicated name, or a row outside 1..n+1.
    """
    n = model.n_joints
    out = []
    for name in names:
        m = _PARAM_RE.match(name)
        if not m or not 1 <= int(m.group(2)) <= n + 1:
            raise ValueError(
                f"unknown error parameter '{name}': expected d<alpha|d|theta|r|beta>"
                f"<j> with j in 1..{n + 1} (tool = {n + 1})"
            )
        out.append((int(m.group(2)) - 1) * 5 + MDH_KEYS.index(m.group(1)))
    idx = np.array(out, dtype=np.intp)
    if np.unique(idx).size != idx.size:
        raise ValueError("error parameters: a name is given twice")
    return idx


def apply_deltas(
    model: RobotModel, names: Sequence[str], values: Sequence[float] | np.ndarray
) -> RobotModel:
    """Returns a copy of ``model`` with each named error parameter added to its
    table entry (rad or m)."""
    idx = error_parameter_indices(model, names)
    values = as_finite_array(values, "deltas", (len(idx),))
    table = model.table.ravel().copy()
    table[idx] += values
    return model.with_table(table.reshape(-1, 5))
