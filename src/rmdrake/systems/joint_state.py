"""Picking a robot's joints out of a MultibodyPlant's state.

:func:`joint_state_selector` is the 0/1 matrix of the joints' positions and
velocities; :func:`add_selector` and :func:`map_port` apply such a matrix to an
output port in a diagram (as :func:`rmdrake.systems.station.MakeStation` does).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import MatrixGain

__all__ = ["add_selector", "joint_state_selector", "map_port"]


def joint_state_selector(plant: MultibodyPlant, joints: Sequence[str]) -> np.ndarray:
    """The (2n, nq + nv) 0/1 matrix S with S @ [q; v] = [q_joints; v_joints].

    Row j picks the position of the one-dof joint named ``joints[j]`` (its
    ``position_start``), row n + j its velocity (``nq + velocity_start``), so
    the result does not depend on where, or whether, other coordinates sit in
    the plant state. It is ``plant.MakeStateSelectorMatrix`` of the joints.
    """
    found = [plant.GetJointByName(name) for name in joints]
    for joint in found:
        if joint.num_positions() != 1 or joint.num_velocities() != 1:
            raise ValueError(f"joint '{joint.name()}': expected one dof")
    return plant.MakeStateSelectorMatrix([joint.index() for joint in found])


def add_selector(
    builder: DiagramBuilder, port: OutputPort, matrix: np.ndarray, name: str
) -> OutputPort:
    """``matrix @ port`` as a MatrixGain named ``name``; returns its output."""
    gain = builder.AddNamedSystem(name, MatrixGain(matrix))
    builder.Connect(port, gain.get_input_port())
    return gain.get_output_port()


def map_port(
    builder: DiagramBuilder, port: OutputPort, matrix: np.ndarray, name: str
) -> OutputPort:
    """:func:`add_selector`, or ``port`` itself when the matrix is the identity
    (the common case; saves a system)."""
    n = matrix.shape[0]
    if matrix.shape == (n, n) and np.array_equal(matrix, np.eye(n)):
        return port
    return add_selector(builder, port, matrix, name)
