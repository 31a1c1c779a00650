"""Elastic joints of the true robot in the station: link-side positions, the
rest state, and the rule that keeps the joint controller below the arm's
lowest structural mode.

An elastic joint j of :func:`rmdrake.model.plant.MakePlant` is two plant joints: the
motor side ``joint<j>`` (q_m, what the encoder reads and the controller feeds
back) and ``joint<j>_link`` whose position is the deflection q_l - q_m. The
link-side position is therefore q_l = q_m + deflection, one row of a 0/1
matrix on the plant state (:func:`link_position_selector`).

The rule (:func:`check_controller_bandwidth`): a controller that feeds back the
motor side only cannot damp the structure, so its bandwidth (rad/s, the triple
closed-loop pole of the station's controllers) must stay below the lowest
structural mode w_s of the arm
(:func:`rmdrake.dynamics.compliance.lowest_structural_mode`,
rad/s, at the true robot's payload) where the motion starts; the station
refuses a ``controller.bandwidth`` >= w_s. Stay well below (w_s / 3 or less):
near the mode the loop excites it and the tool rings.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

from rmdrake.dynamics.compliance import link_angles, lowest_structural_mode
from rmdrake.model.plant import joint_name, link_joint_name
from rmdrake.model.robot import RobotModel

__all__ = [
    "check_controller_bandwidth",
    "link_position_selector",
    "set_link_rest",
]


def _link_joints(plant: MultibodyPlant, n: int) -> list[object | None]:
    """The link-side joint of each of joint1..n, None where rigid."""
    return [
        plant.GetJointByName(link_joint_name(j))
        if plant.HasJointNamed(link_joint_name(j))
        else None
        for j in range(1, n + 1)
    ]


def link_position_selector(plant: MultibodyPlant, n: int) -> np.ndarray:
    """The (n, nq + nv) 0/1 matrix L with L @ plant state = q_l (rad or m): row
    j picks ``joint<j>``'s position plus, on an elastic joint, the deflection
    of ``joint<j>_link`` (= the motor side on a rigid joint)."""
    L = np.zeros((n, plant.num_positions() + plant.num_velocities()))
    for j, link in enumerate(_link_joints(plant, n)):
        L[j, plant.GetJointByName(joint_name(j + 1)).position_start()] = 1.0
        if link is not None:
            L[j, link.position_start()] = 1.0
    return L


def set_link_rest(
    plant: MultibodyPlant, context: Context, model: RobotModel
) -> np.ndarray:
    """Puts the link side of every elastic joint of ``plant`` at rest for the
    motor-side positions in ``context`` (``plant``'s context): deflection =
    :func:`~rmdrake.dynamics.compliance.link_angles` - q_m at ``model``'s payload,
    deflection rate 0 (the link moves with the motor). Returns q_l (n,)."""
    n = model.n_joints
    q = plant.GetPositions(context).copy()
    v = plant.GetVelocities(context).copy()
    q_m = np.array(
        [
            q[plant.GetJointByName(joint_name(j)).position_start()]
            for j in range(1, n + 1)
        ]
    )
    q_l = link_angles(model, q_m)
    for j, link in enumerate(_link_joints(plant, n)):
        if link is not None:
            q[link.position_start()] = q_l[j] - q_m[j]
            v[link.velocity_start()] = 0.0
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    return q_l


def check_controller_bandwidth(
    model: RobotModel, q_start: np.ndarray, bandwidth: float | None
) -> float | None:
    """The rule of the module docstring: returns the lowest structural mode
    (rad/s) of the elastic ``model`` at motor positions ``q_start`` (n, rad or
    m) with its own payload, None for a rigid model or a controller without a
    ``bandwidth``.

    Raises:
      ValueError: ``bandwidth`` (rad/s) at or above that mode (one line, with
        the mode and the fix).
    """
    if model.compliance is None or not np.any(model.compliance.elastic):
        return None
    mode = lowest_structural_mode(model, q_start)
    if bandwidth is not None and float(bandwidth) >= mode:
        raise ValueError(
            f"controller.bandwidth: {float(bandwidth):g} rad/s is above the lowest "
            f"structural mode {mode:.3g} rad/s ({mode / (2 * np.pi):.3g} Hz) of the "
            f"elastic robot '{model.name}' where the motion starts; set "
            f"controller.bandwidth (rmdrake simulate --bandwidth) below it (about "
            f"{mode / 3:.2g} rad/s or less)"
        )
    return mode
