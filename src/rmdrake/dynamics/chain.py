"""Serial chains of revolute and prismatic joints: what the regressor runs on.

A :class:`SerialChain` of n one-degree-of-freedom joints is, per joint j (0-based
here, 1-based in names and messages):

* ``X_PF[j]``: pose of the joint's parent frame F in the parent link frame P (4x4;
  P is the base frame B, the world of a plant, for the first joint);
* ``axis[j]``: unit joint axis, expressed in F (and in M, equal at q = 0): the
  rotation axis of a revolute joint, the translation axis of a prismatic one;
* ``prismatic[j]``: False for a revolute joint (q_j in rad), True for a
  prismatic one (q_j in m);
* ``X_CM[j]``: pose of the joint's child frame M in the child link frame C (4x4).

So X_PC(q_j) = X_PF Rot(axis, q_j) X_CM^-1 (revolute) or X_PF Trans(axis q_j)
X_CM^-1 (prismatic). The link frame C is the frame in which that link's standard
parameters are given (the MDH frame for a RobotModel, the Drake body frame for a
plant or URDF). Gravity is in B (m/s^2).

Internally every link also gets a *canonical* frame K fixed on it, whose z axis is
the joint axis through its origin, so that X_{K(j-1) K(j)}(q) = A_j Rot_z(q_j)
(revolute) or A_j Trans_z(q_j) (prismatic) with a constant A_j (exactly the MDH
form). The same A_j serves both kinds, because Rot(a, q) = R Rot_z(q) R^T and
Trans(a q) = R Trans_z(q) R^T for any rotation R taking z to a. Parameters in C
map to K by a constant 10x10 matrix
(:func:`~rmdrake.model.dynamic_parameters.transform_inertial`), identity for MDH chains
and for URDF joints along z.
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.model.dynamic_parameters import (
    N_PER_LINK,
    standard_from_spatial_inertia,
    transform_inertial,
)
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:  # Drake is imported where a chain is built from it
    from pydrake.multibody.plant import MultibodyPlant

__all__ = ["SerialChain", "as_serial_chain", "plant_standard_parameters"]


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


def _inv(X: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = X[:3, :3].T
    out[:3, 3] = -X[:3, :3].T @ X[:3, 3]
    return out


def _hom(R: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
    X = np.eye(4)
    X[:3, :3] = R
    if p is not None:
        X[:3, 3] = p
    return X


@dataclasses.dataclass(frozen=True, eq=False)
class SerialChain:
    """A serial chain of revolute and prismatic joints (see module docstring).

    Attributes:
      X_PF: (n, 4, 4) joint parent frames in the parent link frames.
      axis: (n, 3) unit joint axes in F.
      X_CM: (n, 4, 4) joint child frames in the child link frames.
      gravity: (3,) gravity in the base frame, m/s^2.
      joint_names, link_names: n names each, base to tip.
      q_indices: (n,) position index of each joint in a plant's q when built
        from a plant (``q_chain = q_plant[:, q_indices]``), else ``0..n-1``.
      prismatic: (n,) bool, True where joint j slides along its axis (q_j in
        m); empty (the default) means all revolute (q_j in rad).
      coupling: (n, n) motor coupling C of a transmission with coupled motors
        (:mod:`rmdrake.model.transmission`: motor m turns at c_m . qd, c_m
        row m, in joint-reflected units), or None (every motor turns with its
        own joint only). The regressor's coupled-motor columns use it.

    Example:

    >>> from rmdrake import MakePlant, SerialChain, load_robot
    >>> chain = SerialChain.from_model(load_robot("rv3sb"))
    >>> chain.n_joints, chain.n_parameters
    (6, 78)
    >>> plant, _ = MakePlant(load_robot("rv3sb"))
    >>> SerialChain.from_plant(plant).n_joints
    6
    """

    X_PF: np.ndarray
    axis: np.ndarray
    X_CM: np.ndarray
    gravity: np.ndarray
    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    q_indices: tuple[int, ...] = ()
    prismatic: np.ndarray | tuple = ()
    coupling: np.ndarray | None = None

    def __post_init__(self) -> None:
        X_PF = np.asarray(self.X_PF, dtype=np.float64)
        n = X_PF.shape[0] if X_PF.ndim == 3 else -1
        if n < 1 or X_PF.shape != (n, 4, 4):
            raise ValueError(f"X_PF: expected shape (n, 4, 4), found {X_PF.shape}")
        axis = np.asarray(self.axis, dtype=np.float64)
        X_CM = np.asarray(self.X_CM, dtype=np.float64)
        for what, arr, shape in (
            ("axis", axis, (n, 3)),
            ("X_CM", X_CM, (n, 4, 4)),
            ("gravity", np.asarray(self.gravity), (3,)),
        ):
            if arr.shape != shape:
                raise ValueError(f"{what}: expected shape {shape}, found {arr.shape}")
        norms = np.linalg.norm(axis, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-9):
            j = int(np.argmax(np.abs(norms - 1.0)))
            raise ValueError(
                f"axis of joint '{self.joint_names[j]}': expected a unit vector, "
                f"found norm {norms[j]}"
            )
        if len(self.joint_names) != n or len(self.link_names) != n:
            raise ValueError(f"expected {n} joint and link names")
        object.__setattr__(self, "X_PF", _frozen(X_PF))
        object.__setattr__(self, "axis", _frozen(axis))
        object.__setattr__(self, "X_CM", _frozen(X_CM))
        object.__setattr__(self, "gravity", _frozen(self.gravity))
        object.__setattr__(self, "joint_names", tuple(self.joint_names))
        object.__setattr__(self, "link_names", tuple(self.link_names))
        qi = tuple(int(i) for i in self.q_indices) or tuple(range(n))
        object.__setattr__(self, "q_indices", qi)
        kind = np.asarray(self.prismatic)
        if kind.size == 0:
            kind = np.zeros(n, dtype=bool)
        if kind.shape != (n,) or not np.all((kind == 0) | (kind == 1)):
            raise ValueError(
                f"prismatic: expected {n} flags (False revolute, True prismatic), "
                f"found {kind.tolist()}"
            )
        kind = kind.astype(bool)
        kind.flags.writeable = False
        object.__setattr__(self, "prismatic", kind)
        if self.coupling is not None:
            C = np.asarray(self.coupling, dtype=np.float64)
            if C.shape != (n, n) or np.any(np.diag(C) != 1.0):
                raise ValueError(
                    f"coupling: expected ({n}, {n}) with a unit diagonal, found "
                    f"shape {C.shape}"
                )
            object.__setattr__(self, "coupling", _frozen(C))
        self._canonicalize()

    # ---- canonical (z-axis) form used by the regressor -----------------------
    def _canonicalize(self) -> None:
        n = self.n_joints
        A = np.empty((n, 4, 4))
        T: list[np.ndarray | None] = []
        X_prevK_P = np.eye(4)  # pose of the parent link frame in its K frame
        for j in range(n):
            a = self.axis[j]
            if np.allclose(a, [0.0, 0.0, 1.0], rtol=0, atol=1e-15):
                R_MK = np.eye(3)
            else:
                from pydrake.math import RotationMatrix

                R_MK = RotationMatrix.MakeFromOneVector(a, 2).matrix()
            A[j] = X_prevK_P @ self.X_PF[j] @ _hom(R_MK)
            X_KC = _hom(R_MK.T) @ _inv(self.X_CM[j])
            if np.allclose(X_KC, np.eye(4), rtol=0, atol=1e-15):
                T.append(None)
            else:
                Tj = np.empty((10, 10))
                for c in range(10):
                    Tj[:, c] = transform_inertial(
                        np.eye(10)[c], X_KC[:3, :3], X_KC[:3, 3]
                    )
                T.append(Tj)
            X_prevK_P = X_KC
        object.__setattr__(self, "_A", A)
        object.__setattr__(self, "_T", tuple(T))

    # ---- properties ------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Number of joints n (revolute and prismatic)."""
        return int(self.X_PF.shape[0])

    @property
    def coupled_motors(self) -> tuple[int, ...]:
        """0-based indices of the motors whose row of ``coupling`` has an
        off-diagonal entry (none without a coupling)."""
        if self.coupling is None:
            return ()
        off = self.coupling - np.diag(np.diag(self.coupling))
        return tuple(int(m) for m in np.flatnonzero(np.any(off != 0, axis=1)))

    @property
    def n_parameters(self) -> int:
        """13 n standard parameters."""
        return N_PER_LINK * self.n_joints

    # ---- constructors ----------------------------------------------------------
    @classmethod
    def from_model(cls, model: RobotModel) -> SerialChain:
        """The chain of a RobotModel: link frames are the MDH frames 1..n;
        joint types from ``model.sigma``."""
        from rmdrake.model.plant import joint_name, link_name, mdh_static_transform

        n = model.n_joints
        X_PF = np.stack([mdh_static_transform(r).GetAsMatrix4() for r in model.mdh])
        return cls(
            X_PF=X_PF,
            axis=np.tile([0.0, 0.0, 1.0], (n, 1)),
            X_CM=np.tile(np.eye(4), (n, 1, 1)),
            gravity=model.gravity,
            joint_names=tuple(joint_name(j) for j in range(1, n + 1)),
            link_names=tuple(link_name(j) for j in range(1, n + 1)),
            prismatic=np.asarray(model.sigma) == 1,
            coupling=(model.transmission.coupling if model.coupled_motors else None),
        )

    @classmethod
    def from_plant(cls, plant: MultibodyPlant) -> SerialChain:
        """The chain of a finalized MultibodyPlant of a fixed-base serial arm.

        Welded bodies count as part of the link they are welded to (they change
        its parameters, not the kinematics). Link frames are the Drake body
        frames of the bodies moved by each revolute or prismatic joint (the
        axis of a PrismaticJoint is its ``translation_axis()``).

        Raises:
          ValueError: naming the joint, if a joint is neither revolute, prismatic
            nor a weld, or if two joints follow the same link (not a serial
            chain).
        """
        walk = _walk_plant(plant)
        ctx = plant.CreateDefaultContext()
        X_PF, axis, X_CM, qi = [], [], [], []
        for joint, parent_link in zip(walk.joints, walk.parent_links, strict=True):
            X_PF.append(
                plant.CalcRelativeTransform(
                    ctx, parent_link.body_frame(), joint.frame_on_parent()
                ).GetAsMatrix4()
            )
            X_CM.append(
                plant.CalcRelativeTransform(
                    ctx, joint.child_body().body_frame(), joint.frame_on_child()
                ).GetAsMatrix4()
            )
            slide = joint.type_name() == "prismatic"
            axis.append(joint.translation_axis() if slide else joint.revolute_axis())
            qi.append(joint.position_start())
        return cls(
            X_PF=np.array(X_PF),
            axis=np.array(axis),
            X_CM=np.array(X_CM),
            gravity=plant.gravity_field().gravity_vector(),
            joint_names=tuple(j.name() for j in walk.joints),
            link_names=tuple(j.child_body().name() for j in walk.joints),
            q_indices=tuple(qi),
            prismatic=np.array([j.type_name() == "prismatic" for j in walk.joints]),
        )

    @classmethod
    def from_urdf(cls, path: str | os.PathLike) -> SerialChain:
        """The chain of a URDF serial arm, parsed with Drake (see
        :func:`rmdrake.model.urdf.parse.urdf_plant`; the root link is welded to
        the world)."""
        from rmdrake.model.urdf.parse import urdf_plant

        return cls.from_plant(urdf_plant(path))


@dataclasses.dataclass
class _Walk:
    joints: list  # revolute and prismatic joints, base to tip
    parent_links: list  # the moving (or world) body each joint's parent is on
    clusters: list  # per joint: bodies rigidly attached to its child link


def _walk_plant(plant: MultibodyPlant) -> _Walk:
    if not plant.is_finalized():
        raise ValueError("plant: expected a finalized MultibodyPlant")
    world = plant.world_body()
    inboard = {}  # body index -> joint
    for i in range(plant.num_joints()):
        joint = plant.get_joint(plant.GetJointIndices()[i])
        inboard[joint.child_body().index()] = joint
    moving = []
    for joint in inboard.values():
        kind = joint.type_name()
        if kind == "weld":
            continue
        if kind not in ("revolute", "prismatic"):
            raise ValueError(
                f"joint '{joint.name()}' is {kind}: expected a serial arm of "
                "revolute and prismatic joints, and welds (weld a free base to "
                "the world)"
            )
        moving.append(joint)

    def link_of(body):
        while body.index() != world.index():
            joint = inboard.get(body.index())
            if joint is None or joint.type_name() != "weld":
                return body
            body = joint.parent_body()
        return body

    by_parent: dict = {}
    for joint in moving:
        by_parent.setdefault(link_of(joint.parent_body()).index(), []).append(joint)
    joints, parents = [], []
    link = world
    while True:
        nxt = by_parent.pop(link.index(), [])
        if len(nxt) > 1:
            names = ", ".join(f"'{j.name()}'" for j in nxt)
            raise ValueError(
                f"joint '{nxt[1].name()}': not a serial chain: joints {names} all "
                f"follow link '{link.name()}'"
            )
        if not nxt:
            break
        joints.append(nxt[0])
        parents.append(link)
        link = nxt[0].child_body()
    if by_parent:
        rest = next(iter(by_parent.values()))[0]
        raise ValueError(
            f"joint '{rest.name()}': not a serial chain: not reached from the world "
            "through the other revolute and prismatic joints"
        )
    if not joints:
        raise ValueError(
            "plant: expected at least one revolute or prismatic joint, found none"
        )
    from pydrake.multibody.tree import BodyIndex

    bodies = [plant.get_body(BodyIndex(i)) for i in range(plant.num_bodies())]
    clusters = [
        [
            b
            for b in bodies
            if b.index() != world.index()
            and link_of(b).index() == joint.child_body().index()
        ]
        for joint in joints
    ]
    return _Walk(joints, parents, clusters)


def plant_standard_parameters(plant: MultibodyPlant, context=None) -> np.ndarray:
    """The (13n,) standard parameters of the serial arm in ``plant``.

    Per link of :meth:`SerialChain.from_plant`: the spatial inertia of the link
    body and every body welded to it, about the link body origin in its axes;
    Ia = the actuator's reflected inertia (rotor inertia * gear ratio^2, 0 without
    an actuator; Drake adds it to the mass matrix diagonal of the joint's
    coordinate, so for a prismatic joint it is a mass in kg, for a revolute one
    an inertia in kg m^2); fv = the joint damping (N m s/rad or N s/m); fc = 0
    (MultibodyPlant has no Coulomb friction).

    Args:
      plant: finalized plant; context: its context (default parameters if None).

    Example:

    >>> import numpy as np
    >>> from rmdrake import MakePlant, load_robot, standard_parameters
    >>> from rmdrake.dynamics import plant_standard_parameters
    >>> robot = load_robot("rv3sb")
    >>> plant, _ = MakePlant(robot)
    >>> chi = plant_standard_parameters(plant)
    >>> chi.shape, bool(np.allclose(chi[9::13], standard_parameters(robot)[9::13]))
    ((78,), True)
    """
    walk = _walk_plant(plant)
    ctx = context if context is not None else plant.CreateDefaultContext()
    reflected = {}
    for i in plant.GetJointActuatorIndices():
        act = plant.get_joint_actuator(i)
        reflected[act.joint().index()] = (
            act.rotor_inertia(ctx) * act.gear_ratio(ctx) ** 2
        )
    chi = np.zeros((len(walk.joints), N_PER_LINK))
    for j, (joint, cluster) in enumerate(zip(walk.joints, walk.clusters, strict=True)):
        M = plant.CalcSpatialInertia(
            ctx, joint.child_body().body_frame(), [b.index() for b in cluster]
        )
        chi[j, :10] = standard_from_spatial_inertia(M)
        chi[j, 10] = reflected.get(joint.index(), 0.0)
        chi[j, 11] = float(joint.GetDamping(ctx))
    return chi.ravel()


def as_serial_chain(chain: SerialChain | RobotModel) -> SerialChain:
    """``chain`` itself, or the serial chain of a robot model.

    Raises:
      TypeError: neither a SerialChain nor a RobotModel.
    """
    if isinstance(chain, RobotModel):
        return SerialChain.from_model(chain)
    if not isinstance(chain, SerialChain):
        raise TypeError(
            f"chain: expected a SerialChain or RobotModel, found {type(chain).__name__}"
        )
    return chain
