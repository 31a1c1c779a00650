"""A robot model as a URDF that Drake and Pinocchio load (re-exported by
:mod:`rmdrake.model.urdf.importer`, which reads URDFs).

Links ``base``, ``link1..n``, ``tool`` (and
``payload``), joints ``joint1..n`` with origins from the MDH rows (X_LB first if
``base_frame``), axis z, limits, ``<dynamics damping=fv friction=fc>``, inertials
from the 13 parameters, Ia as a transmission with ``drake:rotor_inertia``.

Transmissions (:mod:`rmdrake.model.transmission`) as ros_control writes them:
an uncoupled joint j of gear ratio n_j is a ``SimpleTransmission`` whose
actuator has ``<mechanicalReduction>`` n_j, ``drake:gear_ratio`` n_j and
``drake:rotor_inertia`` Ia_j / n_j^2 (Drake's reflected inertia is Ia_j). A
coupled motor m turning with one other joint k (row m of the coupling has
one off-diagonal entry c = C[m, k], and motor k is not coupled: a coupled
wrist) is with joint k a ``FourBarLinkageTransmission`` on joints (k, m):
actuator reductions (n_k, n_m c), joint reductions (1, 1 / c), so that
ros_control's x_a2 = n_a2 (x_j1 + n_j2 x_j2) is n_m (c q_k + q_m). Drake's
parser ignores four-bars, so joints k and m carry no rotor inertia in
Drake's plant of the file, and the coupled motor's ``Iam, fvm, fcm`` have no
place in a URDF: a warning says what is not written. Other couplings are
refused (no ros_control form).

A kinematic-only model: without ``dynamics`` the links have no ``<inertial>``
and the joints ``<dynamics damping="0" friction="0">``; without effort limits
every ``<limit effort="0">`` (the attribute is required by URDF parsers such as
Pinocchio's; :func:`~rmdrake.model.urdf.importer.robot_from_urdf` reads 0 as
unknown, so the file re-imports as the same kinematic-only model). Drake's
parser skips a transmission on a joint of effort 0, so such a model's rotor
inertias reach Drake's plant of the file no more: a warning says so.
"""

from __future__ import annotations

import warnings
from xml.sax.saxutils import quoteattr

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

from rmdrake.model.plant import joint_name, link_name, mdh_static_transform
from rmdrake.model.robot import RobotModel

__all__ = ["robot_to_urdf"]


def _num(values) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


def _origin(X: RigidTransform) -> str:
    rpy = RollPitchYaw(X.rotation()).vector()
    return f'<origin xyz="{_num(X.translation())}" rpy="{_num(rpy)}"/>'


def _inertial(mass: float, com: np.ndarray, I_com: np.ndarray) -> str:
    """``<inertial>`` of a body: mass (kg), centre of mass in the link frame (m),
    inertia tensor about it in link axes (kg m^2)."""
    if mass <= 0.0:
        return ""
    (ixx, ixy, ixz), (_, iyy, iyz), (*_, izz) = I_com
    return (
        f'<inertial><origin xyz="{_num(com)}" rpy="0 0 0"/>'
        f'<mass value="{_num(mass)}"/><inertia ixx="{_num(ixx)}" ixy="{_num(ixy)}"'
        f' ixz="{_num(ixz)}" iyy="{_num(iyy)}" iyz="{_num(iyz)}" izz="{_num(izz)}"/>'
        "</inertial>"
    )


def _link_inertial(params: np.ndarray) -> str:
    """The inertial of the 10 standard parameters (about the link origin)."""
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = params[:10]
    if M <= 0.0:
        return ""
    c = np.array([MX, MY, MZ]) / M
    I_o = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    return _inertial(M, c, I_o - M * ((c @ c) * np.eye(3) - np.outer(c, c)))


def _four_bars(model: RobotModel) -> dict[int, tuple[int, int]]:
    """{joint: (k, m)} of each coupled motor m turning with one joint k that
    is not coupled itself (module docstring); ValueError for other couplings,
    a warning for what a four-bar cannot carry."""
    tr = model.transmission
    if tr is None or not tr.coupled:
        return {}
    out: dict[int, tuple[int, int]] = {}
    for m in tr.coupled:
        others = [k for k in np.flatnonzero(tr.coupling[m]) if k != m]
        k = int(others[0])
        if len(others) != 1 or k in tr.coupled or k in out:
            raise ValueError(
                f"robot '{model.name}': motor {m + 1}'s coupling "
                f"{_num(tr.coupling[m])} has no ros_control transmission form "
                "(a four-bar couples one motor to one other joint); keep the "
                "robot YAML"
            )
        out[k] = out[m] = (k, m)
    joints = ", ".join(str(j + 1) for j in sorted(out))
    warnings.warn(
        f"robot '{model.name}': the coupled motors' Iam, fvm, fcm and the rotor "
        f"inertias of joints {joints} (in four-bar transmissions, which Drake's "
        "parser ignores) are not written; keep the robot YAML for them",
        stacklevel=3,
    )
    return out


def _four_bar(model: RobotModel, k: int, m: int) -> list[str]:
    """ros_control's FourBarLinkageTransmission of joints (k, m), 0-based."""
    tr = model.transmission
    c = float(tr.coupling[m, k])
    return [
        f'  <transmission name="{joint_name(k + 1)}_{joint_name(m + 1)}_four_bar">',
        "    <type>transmission_interface/FourBarLinkageTransmission</type>",
        f'    <joint name="{joint_name(k + 1)}"><mechanicalReduction>1.0'
        "</mechanicalReduction></joint>",
        f'    <joint name="{joint_name(m + 1)}"><mechanicalReduction>{_num(1 / c)}'
        "</mechanicalReduction></joint>",
        f'    <actuator name="motor{k + 1}"><mechanicalReduction>{_num(tr.ratio[k])}'
        "</mechanicalReduction></actuator>",
        f'    <actuator name="motor{m + 1}"><mechanicalReduction>'
        f"{_num(tr.ratio[m] * c)}</mechanicalReduction></actuator>",
        "  </transmission>",
    ]


def robot_to_urdf(model: RobotModel) -> str:
    """The model as URDF text (see module docstring): links ``base``,
    ``link1..n``, ``tool`` (and ``payload``); joint j's origin is MDH row j at
    q = 0 (X_LB first when the model has ``base_frame``). A robot's
    ``compliance`` is not written (URDF has no joint stiffness): a warning says
    so; effort limits unknown: ``effort="0"`` (module docstring).

    Example:

    >>> from rmdrake import load_robot, robot_to_urdf
    >>> text = robot_to_urdf(load_robot("rv3sb"))
    >>> text.lstrip().startswith("<?xml"), text.count("<joint ")
    (True, 13)
    """
    if model.compliance is not None:
        warnings.warn(
            f"robot '{model.name}': its joint compliance is not written (URDF has "
            "no joint stiffness); keep the robot YAML for the elastic model",
            stacklevel=2,
        )
    lines = [
        '<?xml version="1.0"?>',
        f'<robot name={quoteattr(model.name)} xmlns:drake="http://drake.mit.edu">',
        '  <link name="base"/>',
    ]
    X0 = RigidTransform()
    if model.base_frame is not None:
        X0 = RigidTransform(RollPitchYaw(model.base_frame.rpy), model.base_frame.xyz)
    lim = model.limits
    effort = np.zeros(model.n_joints) if lim.effort is None else lim.effort
    if lim.effort is None and model.dynamics is not None and any(model.dynamics[:, 10]):
        warnings.warn(
            f"robot '{model.name}' has no joint effort limits: its joints get "
            'effort="0", on which Drake\'s parser skips the transmissions that '
            "carry the rotor inertias (Ia); keep the robot YAML for them",
            stacklevel=2,
        )
    pairs = _four_bars(model)  # {joint k or m (0-based): (k, m)}
    parent = "base"
    for j in range(1, model.n_joints + 1):
        dyn = model.dynamics[j - 1] if model.dynamics is not None else np.zeros(13)
        X = mdh_static_transform(model.mdh[j - 1])
        X = X0.multiply(X) if j == 1 else X
        kind = "prismatic" if model.sigma[j - 1] else "revolute"
        i = j - 1
        lines += [
            f'  <link name="{link_name(j)}">{_link_inertial(dyn)}</link>',
            f'  <joint name="{joint_name(j)}" type="{kind}">',
            f'    <parent link="{parent}"/><child link="{link_name(j)}"/>',
            f'    {_origin(X)}<axis xyz="0 0 1"/>',
            f'    <limit lower="{_num(lim.lower[i])}" upper="{_num(lim.upper[i])}"'
            f' velocity="{_num(lim.velocity[i])}" effort="{_num(effort[i])}"/>',
            f'    <dynamics damping="{_num(dyn[11])}" friction="{_num(dyn[12])}"/>',
            "  </joint>",
        ]
        ratio = 1.0 if model.transmission is None else model.transmission.ratio[i]
        if i in pairs:
            if pairs[i][1] == i:  # written once both joints exist
                lines += _four_bar(model, *pairs[i])
        elif dyn[10] > 0 or ratio != 1.0:
            reduction = (
                ""
                if ratio == 1.0
                else f"<mechanicalReduction>{_num(ratio)}</mechanicalReduction>"
            )
            lines += [
                f'  <transmission name="{joint_name(j)}_transmission">',
                "    <type>transmission_interface/SimpleTransmission</type>",
                f'    <joint name="{joint_name(j)}"/>',
                f'    <actuator name="{joint_name(j)}">{reduction}<drake:rotor_inertia '
                f'value="{_num(dyn[10] / ratio**2)}"/><drake:gear_ratio '
                f'value="{_num(ratio)}"/></actuator>',
                "  </transmission>",
            ]
        parent = link_name(j)
    lines += [
        '  <link name="tool"/>',
        f'  <joint name="tool_joint" type="fixed"><parent link="{parent}"/>'
        f'<child link="tool"/>{_origin(mdh_static_transform(model.tool))}</joint>',
    ]
    if model.payload is not None and model.payload.mass > 0:
        pl = model.payload
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = pl.inertia
        I_c = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])
        lines += [
            f'  <link name="payload">{_inertial(pl.mass, pl.p_EPcm, I_c)}</link>',
            '  <joint name="payload_joint" type="fixed"><parent link="tool"/>'
            '<child link="payload"/><origin xyz="0 0 0" rpy="0 0 0"/></joint>',
        ]
    return "\n".join([*lines, "</robot>", ""])
