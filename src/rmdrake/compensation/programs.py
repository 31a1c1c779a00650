"""Tool targets and joint programs: their types and CSV files.

Tool targets (for program correction), columns ``x,y,z`` (m, base frame B) and
optionally ``roll,pitch,yaw`` (rad, Drake's RollPitchYaw: R = Rz(yaw) Ry(pitch)
Rx(roll)) and ``t`` (s). Joint programs, columns ``q1..qn`` (rad for a revolute
joint, m for a prismatic one) and optionally ``t`` (s). Columns may come in any
order; writes are atomic, at full precision, and round-trip exactly; errors
name the file, line and column.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.io.csv import read_csv_columns, write_csv_columns

__all__ = [
    "JointProgram",
    "ToolTargets",
    "read_joint_program",
    "read_tool_targets",
    "write_joint_program",
    "write_tool_targets",
]


class ToolTargets(NamedTuple):
    """Tool targets in B, CSV columns ``x,y,z`` (m), optionally ``roll,pitch,
    yaw`` (rad, Drake's RollPitchYaw) and ``t`` (s), in any order.

    Attributes:
      p_BE: (M, 3) positions, m.
      rpy: (M, 3) roll, pitch, yaw, rad, or None.
      t: (M,) strictly increasing times, s, or None.

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import ToolTargets
    >>> targets = ToolTargets(p_BE=np.array([[0.3, 0, 0.4], [0.3, 0.1, 0.4]]))
    >>> targets.p_BE.shape, targets.rpy
    ((2, 3), None)
    """

    p_BE: np.ndarray
    rpy: np.ndarray | None = None
    t: np.ndarray | None = None


class JointProgram(NamedTuple):
    """A joint program: q (M, n) in rad or m (revolute or prismatic joints;
    CSV columns ``q1..qn``) and t (M,) strictly increasing in s (column ``t``)
    or None, in any order.

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import JointProgram
    >>> program = JointProgram(q=np.zeros((3, 6)), t=np.array([0.0, 1, 2]))
    >>> program.q.shape, program.t.tolist()
    ((3, 6), [0.0, 1.0, 2.0])
    """

    q: np.ndarray
    t: np.ndarray | None = None


def _time(t: object, M: int) -> np.ndarray | None:
    """Checked times of M >= 1 rows for writing, or None."""
    if M < 1:
        raise ValueError("expected at least one row to write, found none")
    t = None if t is None else as_finite_array(t, "t", (M,))
    if t is not None and np.any(np.diff(t) <= 0):
        raise ValueError("t: expected strictly increasing times")
    return t


def read_tool_targets(path: str | os.PathLike) -> ToolTargets:
    """Reads a tool-target CSV (see :class:`ToolTargets`).

    Raises:
      ValueError: one line naming the file, line and column of the problem.

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import ToolTargets, read_tool_targets
    >>> from rmdrake.compensation import write_tool_targets
    >>> targets = ToolTargets(p_BE=np.array([[0.3, 0, 0.4]]))
    >>> path = write_tool_targets("targets.csv", targets)
    >>> read_tool_targets(path).p_BE.round(3)
    array([[0.3, 0. , 0.4]])
    """
    groups = {"p": ["x", "y", "z"], "rpy": ["roll", "pitch", "yaw"], "t": ["t"]}
    v = read_csv_columns(path, "tool targets", lambda header: groups)
    return ToolTargets(v["p"], v["rpy"], None if v["t"] is None else v["t"][:, 0])


def write_tool_targets(path: str | os.PathLike, targets: ToolTargets) -> Path:
    """Writes tool targets atomically as CSV (``t`` first when given).

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import ToolTargets, write_tool_targets
    >>> targets = ToolTargets(p_BE=np.zeros((1, 3)), rpy=np.zeros((1, 3)))
    >>> write_tool_targets("targets.csv", targets).read_text().splitlines()[0]
    'x,y,z,roll,pitch,yaw'
    """
    p = as_finite_array(targets.p_BE, "p_BE", (None, 3))
    rpy = targets.rpy
    rpy = [None] * 3 if rpy is None else as_finite_array(rpy, "rpy", p.shape).T
    columns = {"t": _time(targets.t, p.shape[0]), "x": p[:, 0], "y": p[:, 1]}
    columns.update(z=p[:, 2], roll=rpy[0], pitch=rpy[1], yaw=rpy[2])
    return write_csv_columns(path, columns)


def read_joint_program(
    path: str | os.PathLike, n_joints: int | None = None
) -> JointProgram:
    """Reads a joint-program CSV (see :class:`JointProgram`); ``n_joints``, if
    given, is the joint count expected (the robot's).

    Raises:
      ValueError: one line naming the file, line and column of the problem.

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import JointProgram, read_joint_program
    >>> from rmdrake.compensation import write_joint_program
    >>> path = write_joint_program("program.csv", JointProgram(q=np.zeros((2, 6))))
    >>> read_joint_program(path, n_joints=6).q.shape
    (2, 6)
    """

    def groups(header: list[str]) -> dict[str, list[str]]:
        n = max(1, sum(re.fullmatch(r"q\d+", c) is not None for c in header))
        return {"q": [f"q{j}" for j in range(1, n + 1)], "t": ["t"]}

    v = read_csv_columns(path, "joint program", groups)
    if n_joints is not None and v["q"].shape[1] != n_joints:
        raise ValueError(
            f"{path}: line 1: {v['q'].shape[1]} joint columns, expected {n_joints}"
        )
    return JointProgram(v["q"], None if v["t"] is None else v["t"][:, 0])


def write_joint_program(path: str | os.PathLike, program: JointProgram) -> Path:
    """Writes a joint program atomically as CSV (``t`` first when given).

    Example:

    >>> import numpy as np
    >>> from rmdrake.compensation import JointProgram, write_joint_program
    >>> path = write_joint_program("program.csv", JointProgram(q=np.zeros((2, 3))))
    >>> path.read_text().splitlines()[0]
    'q1,q2,q3'
    """
    q = as_finite_array(program.q, "q", (None, None))
    columns = {"t": _time(program.t, q.shape[0])}
    columns.update((f"q{j + 1}", q[:, j]) for j in range(q.shape[1]))
    return write_csv_columns(path, columns)
