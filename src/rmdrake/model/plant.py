"""A Drake MultibodyPlant built from a :class:`~rmdrake.model.robot.RobotModel`.

Bodies ``link1..linkn`` carry the MDH frames: the body frame of link j *is* MDH
frame j. Joint ``joint<j>`` turns about z_j (a RevoluteJoint, ``sigma`` 0) or
slides along it (a PrismaticJoint, ``sigma`` 1); its parent frame is fixed on
link j-1 (the world for j = 1) at the static part of the MDH row,

    X_{j-1,F} = Rot_y(beta_j) Rot_x(alpha_j) Trans_x(d_j) Rot_z(theta_j) Trans_z(r_j)

which is right because Rot_z(theta + q) Trans_z(r) = Rot_z(theta) Trans_z(r)
Rot_z(q) and Trans_z(r + q) = Trans_z(r) Trans_z(q). The plant's world frame is
the robot base B; the frame ``tool`` (E) is fixed on link n by the tool row.
Each link carries the 13 standard parameters: mass, first moments and inertia
about the link origin as a SpatialInertia, rotor inertia Ia on the joint's
actuator (gear ratio 1, so the reflected inertia is Ia; with a transmission,
:mod:`rmdrake.model.transmission`, gear ratio n_j and rotor inertia Ia / n_j^2,
Drake's reflected inertia n_j^2 I_r = Ia again).

Coupled motors (a transmission whose motor m turns at s = c_m . qd with
off-diagonal entries in c_m, e.g. a coupled wrist's motor 6 at qd5 + qd6) are
built on discrete plants only, as Drake models them: per coupled motor a
separate chain of revolute joints ``motor<m>_joint<j>``
(:func:`motor_joint_name`) about one axis fixed in the world (1 m below the
base, one metre apart per motor), one joint per joint j with c_mj != 0, each
tied to joint j by a coupler constraint (``AddCouplerConstraint``, q_stage =
c_mj q_j; Drake supports couplers only with the SAP solver of a discrete
plant), ending in the body
``motor<m>_rotor`` of inertia Iam about the axis. Its absolute angle is then
c_m . q, its kinetic energy Iam s^2 / 2 (the regressor's term, no gyroscopic
coupling with the arm), and its centre of mass on the fixed axis never moves
(gravity does no work on it). The first stage's body, whose speed is
c_mj1 qd_j1 alone, carries half of joint j1's rotor inertia (taken off that
joint's actuator, so the sum is exact; j1 the joint with the largest
Ia_j / c_mj^2); further stages of a motor coupled to three or more joints
weigh 1e-9 Iam (an error of that size). With ``coulomb_width`` each stage
gets a PD actuator ``motor<m>_joint<j>_coulomb`` (kp 0, kd fcm / width, limit
fcm) for the motor's Coulomb friction: a torque on the rotor about the world
axis is the same generalized force on every stage, so each stage's actuator,
whose desired velocity :func:`rmdrake.systems.friction.AddDiscretePlantFriction`
sets to minus the other stages' (so it acts on the rotor's speed s), applies
-fcm s(s) implicitly. A continuous plant (kinematics, controllers) leaves
coupled motors out; a controller may take the diagonal Iam c_mj^2 of their
inertia on its joints (:func:`coupled_rotors_on_diagonal`).
Joint damping is zero: viscous and Coulomb friction are applied by the friction
systems of the simulation (rmdrake.systems), not by the plant; a discrete plant
built with ``coulomb_width`` carries the Coulomb part itself, as one more
actuator per joint that the SAP solver applies implicitly (``joint<j>_coulomb``,
PD-controlled with kp = 0, kd = fc / coulomb_width, effort limit fc).

An elastic joint j (``model.compliance``, stiffness k_j > 0) is two joints on
the same axis with coincident frames: the actuated motor side ``joint<j>`` (the
encoder's q_m, with the actuator and its rotor inertia Ia, so friction, sensors
and controllers keep reading it) from the parent frame to a body ``rotor<j>``
of negligible inertia (1e-6 kg), then the unactuated ``joint<j>_link``
(:func:`link_joint_name`) from ``rotor<j>`` to ``link<j>``, whose position is
the deflection q_l - q_m, loaded by a Drake ``RevoluteSpring``
(``PrismaticSpring`` on a slide) of stiffness k_j and nominal position 0, with
the structural damping ``compliance.damping`` as its joint damping. Link j's
body frame is still MDH frame j, at q_l = q_m + deflection. At rest the spring
holds the gravity force on the link side, k_j (q_l - q_m) = tau_j(q_l), as
:func:`rmdrake.dynamics.compliance.link_angles`; the motor then holds -tau_j(q_l). The
plant's positions of an elastic robot are no longer the n joints in order: pick
them by name (``rmdrake.systems.joint_state``). A rigid robot (no compliance,
or every stiffness 0) builds exactly the plant above.

Collision geometry (``collision_radius``, off by default): each link j
(0: the base, anchored to the world) carries capsules of that radius along its
MDH segments, from the origin of frame j along x'_{j+1} (length d_{j+1}) then
along z_{j+1} (length r_{j+1}) to the origin of frame j+1 (the tool frame for
link n): the same segments as the visual cylinders. Links i < j are never
tested against each other when the segments of the links between them are
shorter in total than four radii (two capsule diameters,
:func:`collision_filtered_pairs`): adjacent links, links joined through a
spherical wrist's zero-length links, and links joined by a short offset (the
RV-3SB's 95 mm shoulder) always come that close, whatever the configuration.
A ``cell`` (:class:`rmdrake.model.scene.Cell`) adds its shapes to the world
body as anchored collision (and visual) geometry named ``cell/<name>``;
SceneGraph never tests anchored geometry against anchored geometry, so the base
column is not tested against the cell.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import (
    Capsule,
    CollisionFilterDeclaration,
    Cylinder,
    GeometrySet,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import (
    AddMultibodyPlantSceneGraph,
    CoulombFriction,
    MultibodyPlant,
)
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    JointActuator,
    PdControllerGains,
    PrismaticJoint,
    PrismaticSpring,
    RevoluteJoint,
    RevoluteSpring,
    RotationalInertia,
    SpatialInertia,
    UnitInertia,
)
from pydrake.systems.framework import DiagramBuilder

from rmdrake.model.robot import DYNAMIC_KEYS, Payload, RobotModel
from rmdrake.model.scene import Cell

__all__ = [
    "CELL_PREFIX",
    "MakePlant",
    "TOOL_FRAME",
    "collision_filtered_pairs",
    "joint_name",
    "link_joint_name",
    "link_name",
    "link_segments",
    "motor_joint_name",
    "set_coupled_motor_state",
    "coupled_rotors_on_diagonal",
    "mdh_static_transform",
    "payload_inertia",
    "rotor_name",
    "spatial_inertia_from_standard",
]

TOOL_FRAME = "tool"
CELL_PREFIX = "cell/"
"""Geometry names of a cell's shapes: ``cell/<name>``."""
_IA = DYNAMIC_KEYS.index("Ia")
_FC = DYNAMIC_KEYS.index("fc")
_LINK_RGBA = np.array([0.93, 0.55, 0.14, 1.0])
_BASE_RGBA = np.array([0.35, 0.35, 0.38, 1.0])
_PAYLOAD_RGBA = np.array([0.25, 0.45, 0.8, 0.8])
_CELL_RGBA = np.array([0.6, 0.62, 0.58, 0.6])


def joint_name(j: int) -> str:
    """Name of joint j (1-based) in the plant."""
    return f"joint{j}"


def link_joint_name(j: int) -> str:
    """Name of the unactuated link-side joint of elastic joint j (1-based): its
    position is the deflection q_l - q_m (rad or m)."""
    return f"{joint_name(j)}_link"


def rotor_name(j: int) -> str:
    """Name of the body between the two sides of elastic joint j (1-based)."""
    return f"rotor{j}"


def motor_joint_name(m: int, j: int) -> str:
    """Name of the stage of coupled motor m's chain tied to joint j (both
    1-based): its position is c_mj q_j (module docstring)."""
    return f"motor{m}_joint{j}"


def coupled_rotors_on_diagonal(model: RobotModel) -> RobotModel:
    """``model`` with each coupled motor m's inertia Iam c_mj^2 added to
    joint j's Ia (the diagonal of Iam c_m c_m^T, kg m^2): what a continuous
    plant, which has no coupled motor, can carry of it (for a controller's
    plant; the off-diagonal Iam c_mj c_mk is lost). E.g. the coupled wrist
    with c_6 = (0, 0, 0, 0, 1, 1) adds Iam6 to Ia5 and Ia6. A model without
    coupled motors is returned as it is."""
    if not model.coupled_motors or model.dynamics is None:
        return model
    dyn = np.array(model.dynamics)
    C = model.transmission.coupling[list(model.coupled_motors)]
    dyn[:, _IA] += model.motor_terms[:, 0] @ C**2
    return model.with_dynamics(dyn)


def set_coupled_motor_state(plant: MultibodyPlant, context, model: RobotModel) -> None:
    """Puts each coupled motor's stages (:func:`motor_joint_name`) of a plant
    built by :func:`MakePlant` where their coupler constraints hold: stage
    (m, j) at c_mj q_j rad and c_mj qd_j rad/s, from the joints' state in
    ``context`` (a plant without coupled motors is left as it is)."""
    for m in model.coupled_motors:
        c = model.transmission.coupling[m]
        for j in np.flatnonzero(c):
            name = motor_joint_name(m + 1, int(j) + 1)
            if not plant.HasJointNamed(name):
                return
            joint = plant.GetJointByName(joint_name(int(j) + 1))
            stage = plant.GetJointByName(name)
            stage.set_angle(context, c[j] * joint.get_angle(context))
            stage.set_angular_rate(context, c[j] * joint.get_angular_rate(context))


def link_name(j: int) -> str:
    """Name of link body j (1-based) in the plant."""
    return f"link{j}"


def mdh_static_transform(row: np.ndarray) -> RigidTransform:
    """X_{j-1,j} at q_j = 0 for one MDH row ``(alpha, d, theta, r, beta)``."""
    alpha, d, theta, r, beta = (float(v) for v in row)
    S = RotationMatrix.MakeYRotation(beta) @ RotationMatrix.MakeXRotation(alpha)
    R = S @ RotationMatrix.MakeZRotation(theta)
    return RigidTransform(R, S @ np.array([d, 0.0, 0.0]) + R @ np.array([0, 0, r]))


def payload_inertia(payload: Payload, mass: float | None = None) -> SpatialInertia:
    """M_PEo_E: the payload's spatial inertia about the tool origin in tool axes
    (the body ``payload`` welded to the tool), with its mass replaced by
    ``mass`` kg if given (the inertia scaled with it; 0 gives zero)."""
    if mass is not None:
        payload = payload.with_mass(mass)
    if payload.mass == 0:
        return SpatialInertia.Zero()
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = payload.inertia
    return SpatialInertia.MakeFromCentralInertia(
        payload.mass, payload.p_EPcm, RotationalInertia(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)
    )


def spatial_inertia_from_standard(
    params: np.ndarray, skip_validity_check: bool = False
) -> SpatialInertia:
    """Drake SpatialInertia M_BBo_B of a link from its standard parameters.

    Args:
      params: at least the first 10 of ``XX XY XZ YY YZ ZZ MX MY MZ M``: inertia
        about the link origin Bo in link axes (kg m^2), first moments (kg m),
        mass (kg).
      skip_validity_check: passed to Drake (for parameter sets that are not
        physically valid, as in regressor tests).

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import spatial_inertia_from_standard
    >>> params = np.array([0.0, 0, 0, 0.02, 0, 0.02, 0.2, 0, 0, 2.0])
    >>> M = spatial_inertia_from_standard(params)
    >>> M.get_mass(), M.get_com().round(3)
    (2.0, array([0.1, 0. , 0. ]))
    """
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = (float(v) for v in params[:10])
    if M == 0.0:
        if any((XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ)):
            raise ValueError("a link with zero mass must have zero moments")
        return SpatialInertia.Zero()
    return SpatialInertia(
        M,
        np.array([MX, MY, MZ]) / M,
        UnitInertia(XX / M, YY / M, ZZ / M, XY / M, XZ / M, YZ / M),
        skip_validity_check,
    )


def link_segments(row_next: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The two segments (a, b), points in m in link j's frame, from its origin
    to the origin of frame j+1 whose MDH row is ``row_next``: along x'_{j+1}
    (length |d|), then along z_{j+1} (length |r|)."""
    alpha, d, _, r, beta = (float(v) for v in row_next)
    S = (
        RotationMatrix.MakeYRotation(beta) @ RotationMatrix.MakeXRotation(alpha)
    ).matrix()
    a = S @ np.array([d, 0.0, 0.0])
    b = a + S @ np.array([0.0, 0.0, r])
    return [(np.zeros(3), a), (a, b)]


def collision_filtered_pairs(table: np.ndarray, radius: float) -> list[tuple[int, int]]:
    """Link pairs (i, j), i < j (0: the base), whose capsules of ``radius`` (m)
    are not tested: those whose links strictly between have MDH segments
    shorter in total than 4 ``radius`` (adjacent links included). ``table``:
    the (n+1, 5) MDH table, tool row last."""
    table = np.asarray(table, dtype=float)
    length = np.abs(table[:, 1]) + np.abs(table[:, 3])  # link j: row j+1
    n = table.shape[0] - 1
    return [
        (i, j)
        for i in range(n + 1)
        for j in range(i + 1, n + 1)
        if length[i + 1 : j].sum() < 4.0 * radius
    ]


def _add_link_collision(
    plant: MultibodyPlant, body, row_next: np.ndarray, radius: float, j: int
) -> list:
    """Capsules of ``radius`` (m) along link j's segments (:func:`link_segments`)
    as collision geometry ``collision<j>a`` and ``collision<j>b``; returns their
    GeometryIds."""
    ids = []
    for (a, b), tag in zip(link_segments(row_next), "ab", strict=True):
        frame = _segment_frame(a, b)
        if frame is None:
            continue
        X, length = frame
        ids.append(
            plant.RegisterCollisionGeometry(
                body,
                X,
                Capsule(radius, length),
                f"collision{j}{tag}",
                CoulombFriction(),
            )
        )
    return ids


def _add_cell(plant: MultibodyPlant, cell: Cell, visual: bool) -> None:
    """The cell's shapes on the world body (anchored): collision geometry and,
    with ``visual``, visual geometry, named ``cell/<name>``."""
    for shape in cell.shapes():
        X_BG = shape.X_BG.transform()
        name = CELL_PREFIX + shape.name
        plant.RegisterCollisionGeometry(
            plant.world_body(), X_BG, shape.shape(), name, CoulombFriction()
        )
        if visual:
            drawn = getattr(shape, "visual_shape", shape.shape)()
            plant.RegisterVisualGeometry(
                plant.world_body(), X_BG, drawn, name, _CELL_RGBA
            )


def _filter_links(
    scene_graph: SceneGraph,
    geometries: list[list],
    table: np.ndarray,
    radius: float,
) -> None:
    """Excludes the pairs of :func:`collision_filtered_pairs` from SceneGraph's
    collision queries (``geometries[k]``: the collision GeometryIds of link k,
    0 the base)."""
    manager = scene_graph.collision_filter_manager()
    for i, j in collision_filtered_pairs(table, radius):
        ids = geometries[i] + geometries[j]
        if ids:
            manager.Apply(CollisionFilterDeclaration().ExcludeWithin(GeometrySet(ids)))


def _segment(
    plant: MultibodyPlant,
    body,
    a: np.ndarray,
    b: np.ndarray,
    radius: float,
    name: str,
    rgba: np.ndarray,
) -> None:
    """Registers a cylinder from point a to point b (body frame) as visual."""
    frame = _segment_frame(a, b)
    if frame is not None:
        X, length = frame
        plant.RegisterVisualGeometry(body, X, Cylinder(radius, length), name, rgba)


def _segment_frame(a: np.ndarray, b: np.ndarray) -> tuple[RigidTransform, float] | None:
    """(X, length) of the segment from point a to point b (m, in a body frame
    B): X = X_BG with G at the midpoint and z_G along b - a, Drake's axis of a
    capsule or cylinder; None for a segment shorter than 1 nm."""
    v = b - a
    length = float(np.linalg.norm(v))
    if length < 1e-9:
        return None
    R = RotationMatrix.MakeFromOneVector(v / length, 2)
    return RigidTransform(R, (a + b) / 2), length


def _add_link_visuals(
    plant: MultibodyPlant,
    body,
    row_next: np.ndarray,
    radius: float,
    j: int,
    rgba: np.ndarray,
) -> None:
    """Visual of the link from its frame origin to the next frame origin: a
    segment along x' (length d) then along z (length r), and a joint drum."""
    alpha, d, _, r, beta = row_next
    S = (
        RotationMatrix.MakeYRotation(beta) @ RotationMatrix.MakeXRotation(alpha)
    ).matrix()
    a = S @ np.array([d, 0.0, 0.0])
    b = a + S @ np.array([0.0, 0.0, r])
    _segment(plant, body, np.zeros(3), a, radius, f"seg{j}a", rgba)
    _segment(plant, body, a, b, radius, f"seg{j}b", rgba)
    if j > 0:
        plant.RegisterVisualGeometry(
            body,
            RigidTransform(),
            Cylinder(1.3 * radius, 3.0 * radius),
            f"drum{j}",
            rgba,
        )


def _compliance(model: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """(stiffness, damping), each (n,), zeros for a rigid robot; ValueError for
    an elastic joint without rotor inertia."""
    n = model.n_joints
    if model.compliance is None:
        return np.zeros(n), np.zeros(n)
    k = np.asarray(model.compliance.stiffness, dtype=float)
    rotor = np.zeros(n) if model.dynamics is None else model.dynamics[:, _IA]
    bad = np.flatnonzero((k > 0) & ~(rotor > 0))
    if bad.size:
        raise ValueError(
            f"compliance: elastic joint {bad[0] + 1} of robot '{model.name}' needs "
            "a rotor inertia Ia > 0 in dynamics (the motor side has no other inertia)"
        )
    return k, np.asarray(model.compliance.damping, dtype=float)


def _add_spring(
    plant: MultibodyPlant,
    kind: type,
    j: int,
    rotor,
    body,
    stiffness: np.ndarray,
    damping: np.ndarray,
) -> None:
    """The link side of elastic joint j: ``joint<j>_link`` from the rotor to link
    j on the same axis, with its spring (nominal 0) and structural damping."""
    joint = plant.AddJoint(
        kind(
            link_joint_name(j),
            rotor.body_frame(),
            body.body_frame(),
            [0.0, 0.0, 1.0],
            damping=float(damping[j - 1]),
        )
    )
    spring = PrismaticSpring if kind is PrismaticJoint else RevoluteSpring
    plant.AddForceElement(spring(joint, 0.0, float(stiffness[j - 1])))


def coulomb_levels(model: RobotModel) -> np.ndarray:
    """(n,) symmetric Coulomb level (fc + fcn) / 2 per joint, N m or N: the
    effort limit of the ``joint<j>_coulomb`` actuators of :func:`MakePlant`
    (joints at level 0 get none)."""
    fc = model.dynamics[:, _FC]
    return 0.5 * (fc + (fc if model.fcn is None else model.fcn))


def _add_coulomb_actuators(
    plant: MultibodyPlant, model: RobotModel, width: float, rotor: np.ndarray
) -> None:
    for j, level in enumerate(coulomb_levels(model), start=1):
        if level > 0:
            actuator = plant.AddJointActuator(
                f"{joint_name(j)}_coulomb",
                plant.GetJointByName(joint_name(j)),
                float(level),
            )
            actuator.set_controller_gains(PdControllerGains(p=0.0, d=level / width))
            # A joint's reflected inertia is its last actuator's (Drake 1.51),
            # so this one repeats the motor's gear ratio and rotor inertia.
            _set_rotor(actuator, model, j, rotor)


def _gear_ratios(model: RobotModel) -> np.ndarray:
    """(n,) each joint actuator's gear ratio: the transmission's, else 1."""
    tr = model.transmission
    return np.ones(model.n_joints) if tr is None else np.asarray(tr.ratio)


def _set_rotor(
    actuator: JointActuator, model: RobotModel, j: int, rotor: np.ndarray
) -> None:
    """Gear ratio n_j and rotor inertia rotor_j / n_j^2 (kg m^2 at the motor
    shaft) on joint j's (1-based) actuator: reflected inertia rotor_j."""
    ratio = float(_gear_ratios(model)[j - 1])
    actuator.set_default_gear_ratio(ratio)
    actuator.set_default_rotor_inertia(float(rotor[j - 1]) / ratio**2)


def _coupled_stages(model: RobotModel) -> list[tuple[int, np.ndarray, float]]:
    """Per coupled motor m (0-based): (m, the joints it turns with in chain
    order, the first stage body's inertia about the axis, kg m^2)."""
    out = []
    Ia = model.dynamics[:, _IA]
    for i, m in enumerate(model.coupled_motors):
        c = model.transmission.coupling[m]
        joints = np.flatnonzero(c)
        room = Ia[joints] / c[joints] ** 2  # inertia each first stage may take
        joints = joints[np.argsort(-room, kind="stable")]
        tiny = 1e-9 * max(float(model.motor_terms[i, 0]), 1e-9)
        first = 0.5 * float(room.max()) if room.max() > 0 else tiny
        out.append((m, joints, first))
    return out


def _add_coupled_motors(
    plant: MultibodyPlant, model: RobotModel, width: float | None
) -> np.ndarray:
    """The coupled motors' chains of the module docstring (discrete plant);
    with ``width`` each stage also gets a PD actuator for the motor's Coulomb
    friction (``<stage>_coulomb``, kp 0, kd fcm / width, limit fcm); returns
    the (n,) rotor inertia left on each joint's actuator."""
    rotor = np.array(model.dynamics[:, _IA], dtype=float)
    instance = plant.AddModelInstance(f"{model.name}_motors")
    for i, (m, joints, first) in enumerate(_coupled_stages(model)):
        c = model.transmission.coupling[m]
        Iam = max(float(model.motor_terms[i, 0]), 1e-9)
        rotor[joints[0]] -= first * c[joints[0]] ** 2
        frame = plant.AddFrame(
            FixedOffsetFrame(
                f"motor{m + 1}_axis",
                plant.world_frame(),
                RigidTransform([0.0, float(i), -1.0]),
            )
        )
        parent = frame
        for k, j in enumerate(joints, start=1):
            last = k == joints.size
            I = Iam if last else (first if k == 1 else 1e-9 * Iam)
            name = f"motor{m + 1}_rotor" if last else f"motor{m + 1}_stage{k}_body"
            body = plant.AddRigidBody(
                name,
                instance,
                SpatialInertia(1.0, np.zeros(3), UnitInertia(0.5 * I, 0.5 * I, I)),
            )
            joint = plant.AddJoint(
                RevoluteJoint(
                    motor_joint_name(m + 1, int(j) + 1),
                    parent,
                    body.body_frame(),
                    [0.0, 0.0, 1.0],
                )
            )
            plant.AddCouplerConstraint(
                joint, plant.GetJointByName(joint_name(int(j) + 1)), float(c[j])
            )
            fcm = float(model.motor_terms[i, 2])
            if width is not None and fcm > 0:
                actuator = plant.AddJointActuator(f"{joint.name()}_coulomb", joint, fcm)
                actuator.set_controller_gains(PdControllerGains(p=0.0, d=fcm / width))
            parent = body.body_frame()
    return rotor


def MakePlant(
    model: RobotModel,
    *,
    builder: DiagramBuilder | None = None,
    time_step: float = 0.0,
    visual: bool = True,
    skip_validity_check: bool = False,
    collision_radius: float | None = None,
    collision_margin: float = 0.0,
    cell: Cell | None = None,
    coulomb_width: float | None = None,
) -> tuple[MultibodyPlant, SceneGraph]:
    """Builds the finalized MultibodyPlant (and its SceneGraph) of ``model``.

    The plant has no joint friction: its joint damping is zero and it ignores
    the model's ``fv``, ``fc`` (and ``fcn``, ``tau0``), which rmdrake applies
    through the plant's ``applied_generalized_force`` input instead (module
    docstring). A plant of a real arm in your own diagram therefore moves
    with less resistance than the arm; add the friction with
    :meth:`rmdrake.systems.friction.JointFriction.AddToBuilder` (continuous
    plant: fv v + fc tanh(v / v_eps), N m or N), which connects plant state ->
    friction -> ``applied_generalized_force``; on a discrete plant, build it
    with ``coulomb_width`` and add
    :func:`rmdrake.systems.friction.AddDiscretePlantFriction`. There is no
    flag here that adds it: the friction is a system of the diagram, not part
    of the plant (the station, :mod:`rmdrake.systems.station`, adds it for
    you). Example (continuous plant)::

        from pydrake.systems.framework import DiagramBuilder
        from rmdrake import MakePlant, load_robot
        from rmdrake.systems import JointFriction

        robot = load_robot("rv3sb")
        builder = DiagramBuilder()
        plant, _ = MakePlant(robot, builder=builder, visual=False)
        fv, fc = robot.dynamics[:, 11], robot.dynamics[:, 12]  # N m s/rad, N m
        JointFriction.AddToBuilder(builder, plant, fv=fv, fc=fc,
                                   fcn=robot.fcn, tau0=robot.tau0)

    Args:
      model: the robot; without ``dynamics`` every link gets a small nominal
        mass (1e-3 kg) so the plant is still simulable; without effort limits
        (``limits.effort`` None) the actuators are unlimited.
      builder: if given, plant and scene graph are added to it
        (AddMultibodyPlantSceneGraph); otherwise they are standalone objects.
      time_step: 0 for a continuous plant, > 0 for a discrete one (s).
      visual: register cylinder/drum visual geometry for Meshcat.
      skip_validity_check: accept physically invalid inertias (tests only).
      collision_radius: if given, capsules of this radius (m) along every
        link's MDH segments as collision geometry, with the link pairs of
        :func:`collision_filtered_pairs` filtered (module docstring); None: no
        collision geometry on the robot (the default plant).
      collision_margin: added to the capsules' radius (m) but not to the
        filter rule: a capsule inflated by c touches what the plain one comes
        within c of (what :mod:`rmdrake.kinematics.clearance` uses).
      cell: the cell's shapes as anchored collision geometry (and visual
        geometry with ``visual``), named ``cell/<name>``, X_BG in the world
        (= base) frame.
      coulomb_width: discrete plants only (``time_step > 0``): if given
        (rad/s or m/s, > 0), each joint with Coulomb friction gets a second
        actuator ``joint<j>_coulomb`` after the n motor actuators (so those
        keep indices 0..n-1): a PD-controlled actuator with kp = 0, kd =
        level / coulomb_width and effort limit level = (fc + fcn) / 2, which
        the SAP solver applies implicitly as clamp(-kd v, -level, level), the
        symmetric part of the Coulomb friction regularised linearly over
        |v| < coulomb_width (module docstring; its desired state must be
        connected, to zero).

    Returns:
      (plant, scene_graph); joints ``joint1..n`` in q order (revolute or
      prismatic by ``model.sigma``), bodies
      ``link1..n``, frame ``tool``, actuators ``joint1..n`` with rotor inertia;
      an elastic joint j adds a body ``rotor<j>`` and a joint
      :func:`link_joint_name` after ``joint<j>`` (module docstring).

    Raises:
      ValueError: an elastic joint without rotor inertia (Ia = 0), or
        ``coulomb_width`` on a continuous plant, a model without dynamics or
        a width that is not positive.

    Example:

    >>> from rmdrake import MakePlant, load_robot
    >>> plant, scene_graph = MakePlant(load_robot("rv3sb"))
    >>> plant.num_positions(), plant.is_finalized()
    (6, True)

    With the robot's friction (a system beside the plant, see above):

    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from rmdrake.systems import JointFriction
    >>> robot = load_robot("rv3sb")
    >>> builder = DiagramBuilder()
    >>> plant, _ = MakePlant(robot, builder=builder, visual=False)
    >>> friction = JointFriction.AddToBuilder(
    ...     builder, plant, fv=robot.dynamics[:, 11], fc=robot.dynamics[:, 12]
    ... )
    >>> builder.IsConnectedOrExported(plant.get_applied_generalized_force_input_port())
    True
    """
    if coulomb_width is not None:
        if not (time_step > 0 and model.dynamics is not None):
            raise ValueError(
                "coulomb_width: expected a discrete plant (time_step > 0) of a "
                f"model with dynamics, found time_step {time_step}"
            )
        if not (np.isfinite(coulomb_width) and coulomb_width > 0):
            raise ValueError(
                f"coulomb_width: expected > 0 rad/s or m/s, found {coulomb_width}"
            )
    if builder is not None:
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step)
    else:
        plant = MultibodyPlant(time_step)
        scene_graph = SceneGraph()
        plant.RegisterAsSourceForSceneGraph(scene_graph)
    instance = plant.AddModelInstance(model.name)
    plant.mutable_gravity_field().set_gravity_vector(model.gravity)
    table = model.table
    n = model.n_joints
    scale = max(float(np.max(np.abs(table[:, [1, 3]]))), 0.05)
    radius = 0.07 * scale
    geometries: list[list] = []
    if collision_radius is not None:
        if not (np.isfinite(collision_radius) and collision_radius > 0):
            raise ValueError(
                f"collision_radius: expected a positive finite m, found "
                f"{collision_radius}"
            )
        capsule = collision_radius + collision_margin
        geometries.append(
            _add_link_collision(plant, plant.world_body(), table[0], capsule, 0)
        )
    if cell is not None:
        _add_cell(plant, cell, visual)
    if visual:
        plant.RegisterVisualGeometry(
            plant.world_body(),
            RigidTransform([0, 0, -radius]),
            Cylinder(2.5 * radius, 2 * radius),
            "pedestal",
            _BASE_RGBA,
        )
        _add_link_visuals(plant, plant.world_body(), table[0], radius, 0, _BASE_RGBA)

    stiffness, damping = _compliance(model)
    actuators: list[JointActuator] = []
    parent = plant.world_body()
    for j in range(1, n + 1):
        row = table[j - 1]
        if model.dynamics is not None:
            inertia = spatial_inertia_from_standard(
                model.dynamics[j - 1], skip_validity_check
            )
        else:
            inertia = SpatialInertia.SolidSphereWithMass(1e-3, 0.01)
        body = plant.AddRigidBody(link_name(j), instance, inertia)
        frame_on_parent = plant.AddFrame(
            FixedOffsetFrame(
                f"{joint_name(j)}_parent",
                parent.body_frame(),
                mdh_static_transform(row),
            )
        )
        kind = PrismaticJoint if model.sigma[j - 1] else RevoluteJoint
        motor_body = body
        if stiffness[j - 1] > 0:
            motor_body = plant.AddRigidBody(
                rotor_name(j), instance, SpatialInertia.SolidSphereWithMass(1e-6, 0.01)
            )
        joint = plant.AddJoint(
            kind(
                joint_name(j),
                frame_on_parent,
                motor_body.body_frame(),
                [0.0, 0.0, 1.0],
                model.limits.lower[j - 1],
                model.limits.upper[j - 1],
                0.0,
            )
        )
        v = model.limits.velocity[j - 1]
        a = model.limits.acceleration[j - 1]
        joint.set_velocity_limits([-v], [v])
        joint.set_acceleration_limits([-a], [a])
        effort = model.limits.effort  # unknown: unlimited, Drake's default
        actuator = plant.AddJointActuator(
            joint_name(j), joint, np.inf if effort is None else float(effort[j - 1])
        )
        actuators.append(actuator)
        if motor_body is not body:
            _add_spring(plant, kind, j, motor_body, body, stiffness, damping)
        if visual:
            _add_link_visuals(plant, body, table[j], radius, j, _LINK_RGBA)
        if collision_radius is not None:
            geometries.append(_add_link_collision(plant, body, table[j], capsule, j))
        parent = body

    rotor = np.zeros(n) if model.dynamics is None else model.dynamics[:, _IA]
    if time_step > 0 and model.coupled_motors and model.dynamics is not None:
        rotor = _add_coupled_motors(plant, model, coulomb_width)
    for j, actuator in enumerate(actuators, start=1):
        _set_rotor(actuator, model, j, rotor)
    if coulomb_width is not None:
        _add_coulomb_actuators(plant, model, coulomb_width, rotor)
    tool = plant.AddFrame(
        FixedOffsetFrame(
            TOOL_FRAME, parent.body_frame(), mdh_static_transform(table[n])
        )
    )
    if visual:
        plant.RegisterVisualGeometry(
            parent,
            tool.GetFixedPoseInBodyFrame(),
            Sphere(0.8 * radius),
            "tool",
            _BASE_RGBA,
        )
    if model.payload is not None and model.payload.mass > 0:
        pl = model.payload
        body = plant.AddRigidBody("payload", instance, payload_inertia(pl))
        plant.WeldFrames(tool, body.body_frame(), RigidTransform())
        if visual:
            side = 2.0 * np.cbrt(pl.mass / 8000.0)  # a steel-dense cube, for show
            plant.RegisterVisualGeometry(
                body,
                RigidTransform(pl.p_EPcm),
                Sphere(0.6 * side),
                "payload",
                _PAYLOAD_RGBA,
            )
    plant.Finalize()
    if collision_radius is not None:
        _filter_links(scene_graph, geometries, table, collision_radius)
    return plant, scene_graph
