"""Named kinematic error parameters of a robot's MDH table.

Error parameters are named ``dalpha<j>``, ``dd<j>``, ``dtheta<j>``, ``dr<j>``,
``dbeta<j>`` with j = 1..n+1 (n+1 = the tool row); each adds to one entry of the
table ``RobotModel.table`` (rad or m).

The elastostatic calibration adds joint compliances ``c<j>`` (j = 1..n): the
value itself (not a delta), c_j = 1 / k_j in rad/(N m) (m/N on a slide), of the
spring between joint j's motor and link side (:mod:`rmdrake.dynamics.compliance`).
:func:`split_error_parameters` separates them from the MDH names; they come
after every MDH entry in the identifiability's preference order.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable, Sequence

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.model.robot import MDH_KEYS, Compliance, RobotModel

__all__ = [
    "apply_deltas",
    "compliance_parameter_names",
    "error_parameter_indices",
    "error_parameter_names",
    "is_compliance_name",
    "split_error_parameters",
]

_PARAM_RE = re.compile(r"^d(alpha|d|theta|r|beta)(\d+)$")
_COMPLIANCE_RE = re.compile(r"^c(\d+)$")


def is_compliance_name(name: str) -> bool:
    """True for a joint-compliance name ``c<j>``.

    Example:

    >>> from rmdrake.model import is_compliance_name
    >>> is_compliance_name("c3"), is_compliance_name("dd2")
    (True, False)
    """
    return bool(_COMPLIANCE_RE.match(name))


def compliance_parameter_names(model: RobotModel) -> list[str]:
    """``c1`` .. ``c<n>``: the compliance of every joint.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.model import compliance_parameter_names
    >>> compliance_parameter_names(load_robot("rv3sb"))
    ['c1', 'c2', 'c3', 'c4', 'c5', 'c6']
    """
    return [f"c{j}" for j in range(1, model.n_joints + 1)]


def split_error_parameters(
    model: RobotModel, names: Iterable[str]
) -> tuple[list[str], np.ndarray]:
    """(the MDH error-parameter names in their order, (m,) 0-based joints of the
    ``c<j>`` names in their order).

    Raises:
      ValueError: an unknown or duplicated name (naming it), a ``c<j>`` with j
        outside 1..n.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.model import split_error_parameters
    >>> split_error_parameters(load_robot("rv3sb"), ["dd2", "c3", "dalpha2"])
    (['dd2', 'dalpha2'], array([2]))
    """
    n = model.n_joints
    geometric, joints = [], []
    for name in names:
        m = _COMPLIANCE_RE.match(name)
        if m is None:
            geometric.append(name)
            continue
        if not 1 <= int(m.group(1)) <= n:
            raise ValueError(
                f"unknown error parameter '{name}': a joint compliance is c<j> with "
                f"j in 1..{n}"
            )
        joints.append(int(m.group(1)) - 1)
    error_parameter_indices(model, geometric)
    if len(set(joints)) != len(joints):
        raise ValueError("error parameters: a name is given twice")
    return geometric, np.array(joints, dtype=np.intp)


def error_parameter_names(model: RobotModel, preset: str = "paper") -> list[str]:
    """Named error parameters of a preset.

    Presets:
      ``paper``: the 17 of the paper's Table 1 (6-joint arms only): dalpha2..7,
        dd2..7, dr2, dr4, dr5, dr6, dbeta3.
      ``full``: all five parameters of every row 1..n+1 (5(n+1) names); not all
        are identifiable from any measurement, see the calibration's
        identifiability analysis.

    Example:

    >>> from rmdrake import error_parameter_names, load_robot
    >>> names = error_parameter_names(load_robot("rv3sb"))
    >>> len(names), names[:3]
    (17, ['dalpha2', 'dalpha3', 'dalpha4'])
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

    Example:

    >>> from rmdrake import error_parameter_indices, load_robot
    >>> error_parameter_indices(load_robot("rv3sb"), ["dalpha2", "dd2"])
    array([5, 6])
    """
    n = model.n_joints
    out = []
    for name in names:
        m = _PARAM_RE.match(name)
        if is_compliance_name(name):
            raise ValueError(
                f"'{name}' is a joint compliance, not an MDH table entry (see "
                "split_error_parameters)"
            )
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
    table entry (rad or m) and each compliance ``c<j>`` (rad/(N m) or m/N) set
    as joint j's stiffness 1 / c_j (a value <= 0: a rigid joint, stiffness 0;
    the other joints keep theirs; damping by the :class:`Compliance` default
    rule).

    Example:

    >>> from rmdrake import apply_deltas, load_robot
    >>> robot = load_robot("rv3sb")
    >>> moved = apply_deltas(robot, ["dd2"], [0.001])
    >>> round(float(moved.table[1, 1] - robot.table[1, 1]), 6)
    0.001
    """
    names = list(names)
    values = as_finite_array(values, "deltas", (len(names),))
    geometric, joints = split_error_parameters(model, names)
    is_c = np.array([is_compliance_name(n) for n in names], dtype=bool)
    idx = error_parameter_indices(model, geometric)
    table = model.table.ravel().copy()
    table[idx] += values[~is_c]
    out = model.with_table(table.reshape(-1, 5))
    if joints.size == 0:
        return out
    c = values[is_c]
    k = np.zeros(model.n_joints)
    if model.compliance is not None:
        k[:] = model.compliance.stiffness
    k[joints] = np.where(c > 0, 1.0 / np.where(c > 0, c, 1.0), 0.0)
    return dataclasses.replace(out, compliance=Compliance(k))
