"""URDF in and out: the serial chain between two links of a URDF as a
:class:`~rmdrake.model.robot.RobotModel` (MDH table by Khalil's rules), and a model as a
URDF that Drake and Pinocchio load.

Import (:func:`robot_from_urdf`). Drake parses the file; the chain is the path of
joints from link ``base`` (L) down the tree to link ``tip`` (T). Its revolute
(``continuous`` too) and prismatic joints are the robot's joints 1..n; fixed
joints on the path are folded into the transforms. Every pose is taken with all
joints of the file at q = 0. Frames:

* z_j is joint j's axis (its URDF direction, so q keeps its sign). A revolute
  axis is the line through the URDF joint origin; a prismatic joint has only a
  direction: its line is taken through its URDF joint origin too (joint 1's is
  moved along the normal below so that B = L).
* Consecutive axes (the tip's z axis counts as axis n+1) more than
  :data:`PARALLEL_ANGLE` = 0.1 rad apart (lines, so anti-parallel is parallel):
  Khalil. x_j = z_j x z_{j+1} / |.| (so alpha_{j+1} is in (0, pi) and d_{j+1}
  has a sign), O_j = the foot of the common normal on z_j, beta_{j+1} = 0.
* Within 0.1 rad, exactly parallel included: Hayati. O_j = where the previous
  row's x' line meets z_j (so r_j = 0); x'_{j+1} points from O_j to the foot F
  of the perpendicular from O_j on z_{j+1} (d_{j+1} = |O_j F| >= 0); x_j is x'
  projected on the plane normal to z_j and beta_{j+1} the tilt between them
  (0 for exactly parallel axes). d, r stay within the link's size and |beta| <
  0.1 rad. Coincident axes (|O_j F| < 1e-12 m): x_j = the previous x', x'_{j+1}
  in the x_j z_j plane.
* The tool row: the tip's z axis is axis n+1 and the tip frame is frame n+1, so
  theta_n, r_n (free in frame n) and the tool row's five entries give its six
  degrees of freedom.
* Base: one row Rot_y(beta) Rot_x(alpha) Trans_x(d) reaches z_1 from L only if
  z_1 meets L's x axis turned about y (x' in L's xz plane, normal to z_1, with a
  non-negative x component). Otherwise (more than :data:`BASE_TOLERANCE` off) B
  is L moved, without rotation, by the shortest vector that makes it so; the
  model records X_LB in ``base_frame`` (p_L = X_LB p_B) and a warning says that
  targets are then in B. Gravity: L is taken as upright, g_L = (0, 0, -9.81),
  so g_B = g_L.

Inertials: link j is every body rigidly attached to joint j's child body (fixed
joints) plus the side branches that move (lumped at their q = 0, with a warning
naming their joints); link n takes every body beyond the tip too (a hand, its
fingers: a warning names those with mass), unless ``exclude`` drops them: an
excluded link and everything below it is left out of the import. Each link's
inertial is the file's (:func:`rmdrake.model.urdf.parse.body_inertial`): a link with
``<mass value="0">`` contributes nothing even with a nonzero ``<inertia>``
(Drake's parser makes it a 1 kg sphere), as does a link without ``<inertial>``;
a non-physical inertia of positive mass is Drake's stand-in (a sphere of that
mass); warnings name those links. The 13
standard parameters are about the MDH frame origin in MDH axes; URDF
``<dynamics damping friction>`` gives fv, fc; Drake's actuator (a
``<transmission>`` with ``drake:rotor_inertia``, ``drake:gear_ratio``) gives Ia =
rotor inertia * gear ratio^2 (0 without one).

Transmissions (ros_control's ``<transmission>``, read from the XML): a
``SimpleTransmission`` on a chain joint gives its gear ratio, the product of
its actuator's and joint's ``<mechanicalReduction>`` (1 where absent); a
``FourBarLinkageTransmission`` on joints (j1, j2) with actuator reductions
(n_a1, n_a2) and joint reductions (n_j1, n_j2) is ros_control's position map
x_a1 = n_j1 n_a1 x_j1, x_a2 = n_a2 (x_j1 + n_j2 x_j2): ratios n_j1 n_a1 and
n_a2 n_j2, and motor j2 coupled to joint j1 by 1 / n_j2 (a coupled wrist:
:mod:`rmdrake.model.transmission`; efforts follow by power balance). Other
types are left out with a warning. A file whose reductions are all 1 and that
has no four-bar gives no ``transmission``. The coupled motors' ``Iam, fvm,
fcm`` are not in a URDF: 0 (a warning says so).

Units: the chain's MDH table and limits pass the robot YAML's unit check
(:func:`~rmdrake.model.units.check_units`): a URDF written in mm or degrees is
refused (``mm?``) before anything is written.

Limits: lower, upper, velocity and effort from ``<limit>`` (velocity must be
positive; a negative velocity or effort, or lower > upper, is refused naming the
joint and the attribute); acceleration = velocity / DEFAULT_ACCELERATION_TIME (0.5 s). A
continuous joint (or infinite limits) gets +-:data:`CONTINUOUS_LIMIT` (2 pi, one
turn each way; the robot YAML needs finite limits), with a warning.

Kinematic-only URDFs (made for calibration: ``effort="0"`` or no effort, no or
massless inertials). When no joint of the chain has a positive ``<limit
effort>``, the model's effort limits are unknown (``limits.effort`` None); a
chain where some joints have one and others not is refused (a typo, not a
kinematic model). When every link's mass is 0 (no ``<inertial>`` counts as
mass 0), the model has no dynamics (``dynamics`` None; URDF damping, friction
and rotor inertia are then dropped, and the warning says so); some massless
links among massive ones keep the inertials, with the warning that they are
not physically valid. Either way one warning line says what the model lacks and
which commands refuse it (:data:`KINEMATIC_COMMANDS` work).

Reading the file: :mod:`rmdrake.model.urdf.parse`. Export: :func:`robot_to_urdf`
(:mod:`rmdrake.model.urdf.export`).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.multibody.tree import BodyIndex

from rmdrake.model.dynamic_parameters import check_physical, transform_inertial
from rmdrake.model.robot import (
    DEFAULT_ACCELERATION_TIME,
    BaseFrame,
    JointLimits,
    RobotModel,
)
from rmdrake.model.transmission import Transmission
from rmdrake.model.units import check_units
from rmdrake.model.urdf.export import robot_to_urdf
from rmdrake.model.urdf.parse import body_inertial, parse_urdf

__all__ = ["BASE_TOLERANCE", "CONTINUOUS_LIMIT", "KINEMATIC_COMMANDS"]
__all__ += ["PARALLEL_ANGLE"]
__all__ += ["robot_from_urdf", "robot_to_urdf"]

PARALLEL_ANGLE = 0.1
"""rad: consecutive axes closer than this are 'nearly parallel' (Hayati's beta)."""
BASE_TOLERANCE = 1e-10
"""m: a first axis this close to L's reachable plane is taken as in it (B = L)."""
CONTINUOUS_LIMIT = 2.0 * np.pi
"""rad: the position limits written for a continuous joint (+-)."""
KINEMATIC_COMMANDS = "show, calibrate, correct, export-urdf and excite"
"""The commands that take a kinematic-only model (no dynamics, no effort
limits): they use its MDH table and position, velocity and acceleration limits
only."""
_REFUSING = {  # what refuses a model without dynamics / without effort limits
    "dynamics": ("simulate", "validate", "identify-payload"),
    "effort": ("simulate", "identify (without a --prior with effort limits)",
               "identify-gains"),
}  # fmt: skip
_GRAVITY = np.array([0.0, 0.0, -9.81])
_KINDS = {"revolute": 0, "prismatic": 1}
_ODD = {
    "massless": "mass 0 with a nonzero <inertia>: taken as massless (Drake's parser "
    "makes them 1 kg spheres)",
    "stand-in": "non-physical <inertia>: Drake's stand-in used (a sphere of the "
    "link's mass at its centre of mass)",
}


def robot_from_urdf(
    path: str | os.PathLike,
    *,
    base: str | None = None,
    tip: str | None = None,
    name: str | None = None,
    exclude: Sequence[str] = (),
) -> RobotModel:
    """The serial chain from link ``base`` to link ``tip`` of a URDF as a robot
    model (see module docstring for the frames, lumping and defaults).

    Args:
      path: the URDF file.
      base, tip: link names; either may be omitted only when the file (below
        ``base``) is one chain.
      name: the model's name (default: the URDF robot's name).
      exclude: link names: each, and every link below it, is left out (e.g. a
        hand beyond the tip that is not mounted).

    Raises:
      ValueError: one line: the file does not parse, a link does not exist or
        is excluded, the links are not joined by a serial chain, or a joint on it
        is neither revolute, prismatic nor fixed, or lacks a positive velocity,
        or lacks a positive effort while another joint of the chain has one.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import load_robot, robot_from_urdf, robot_to_urdf
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp, "rv3sb.urdf")
    ...     _ = path.write_text(robot_to_urdf(load_robot("rv3sb")))
    ...     robot = robot_from_urdf(path, base="base", tip="tool")
    ...
    >>> robot.n_joints
    6
    """
    path = Path(path)
    plant, log, info = parse_urdf(path)
    inboard = {int(plant.get_joint(i).child_body().index()): plant.get_joint(i)
               for i in plant.GetJointIndices()}  # fmt: skip
    below: dict = {}
    for joint in inboard.values():
        below.setdefault(int(joint.parent_body().index()), []).append(joint)
    dropped = set()
    for link in exclude:
        dropped |= _subtree(_named(plant, link, "exclude", path), below)
    below = {b: [j for j in js if int(j.child_body().index()) not in dropped]
             for b, js in below.items()}  # fmt: skip
    base_body, tip_body = _ends(plant, below, base, tip, path)
    for end in (base_body, tip_body):
        if int(end.index()) in dropped:
            raise ValueError(f"{path}: link '{end.name()}' is excluded (--exclude)")
    path_joints = []  # base -> tip
    body = tip_body
    while body.index() != base_body.index():
        joint = inboard.get(int(body.index()))
        if joint is None:
            raise ValueError(f"{path}: {_not_below(inboard, base_body, tip_body)}")
        path_joints.append(joint)
        body = joint.parent_body()
    path_joints.reverse()
    chain = []
    for joint in path_joints:
        kind = joint.type_name()
        if kind == "weld":
            continue
        if kind not in _KINDS:
            raise ValueError(
                f"{path}: joint '{joint.name()}' between '{base_body.name()}' and "
                f"'{tip_body.name()}' is {kind}: expected revolute, prismatic, "
                "continuous or fixed"
            )
        chain.append(joint)
    if not chain:
        raise ValueError(
            f"{path}: links '{base_body.name()}' and '{tip_body.name()}' are "
            "joined by fixed joints only: robot has no actuated joints between "
            "base and tip"
        )
    n = len(chain)
    sigma = np.array([_KINDS[j.type_name()] for j in chain])
    ctx = plant.CreateDefaultContext()
    q0 = plant.GetPositions(ctx)
    for i in plant.GetJointIndices():
        if plant.get_joint(i).type_name() in _KINDS:
            q0[plant.get_joint(i).position_start()] = 0.0
    plant.SetPositions(ctx, q0)
    X_WL = plant.EvalBodyPoseInWorld(ctx, base_body)
    X_LW = X_WL.inverse()
    p, u = np.empty((n, 3)), np.empty((n, 3))
    for j, joint in enumerate(chain):
        X_LF = X_LW @ joint.frame_on_parent().CalcPoseInWorld(ctx)
        a = joint.revolute_axis() if sigma[j] == 0 else joint.translation_axis()
        p[j], u[j] = X_LF.translation(), X_LF.rotation() @ a
    X_LT = X_LW @ plant.EvalBodyPoseInWorld(ctx, tip_body)
    table, frames, p_LB = _mdh(p, u, sigma, X_LT.GetAsMatrix4())
    alerts = []
    base_frame = None
    if p_LB is not None:
        base_frame = BaseFrame(base_body.name(), p_LB, np.zeros(3))
        alerts.append(
            f"joint 1's axis does not meet the x axis of '{base_body.name()}' "
            f"(turned about y): the robot's base frame B is that link's frame "
            f"moved by {np.round(p_LB, 6).tolist()} m (base_frame in the YAML); "
            "targets are in B"
        )
    dyn, side, beyond, odd = _inertials(
        plant, ctx, chain, tip_body, (below, inboard), X_LW, frames, (info, path)
    )
    for j, joint in enumerate(chain):
        dyn[j, 11] = joint.default_damping()
        dyn[j, 12] = float(info["joints"].get(joint.name(), {}).get("friction", 0))
    if side:
        alerts.append(
            f"moving joints off the chain are lumped into its links at q = 0: "
            f"{', '.join(sorted(side))}"
        )
    if beyond:
        shown = ", ".join(f"{k} {m:.6g} kg" for k, m in beyond)
        alerts.append(
            f"links beyond the tip '{tip_body.name()}' are lumped into link {n} "
            f"(--exclude drops them): {shown}"
        )
    for kind, text in _ODD.items():
        if odd[kind]:
            alerts.append(f"link(s) {', '.join(odd[kind])}: {text}")
    transmission, notes = _transmission(info, [j.name() for j in chain], path)
    alerts += notes
    limits, continuous = _limits(chain, sigma, info, path)
    if continuous:
        alerts.append(
            f"continuous joint(s) {', '.join(continuous)}: limits set to +-2 pi "
            "(one turn each way)"
        )
    massless = not np.any(dyn[:, 9])
    if massless or limits.effort is None:
        alerts.append(_kinematic_only(dyn if massless else None, limits))
    bad = None if massless else check_physical(dyn)
    if bad is not None and not bad.ok:
        alerts.append(f"the URDF's inertials are not physically valid: {bad}")
    if log:
        alerts.append(f"Drake's URDF parser: {len(log)} warning(s), first: {log[0]}")
    try:  # a URDF in mm (or degrees) is refused as a robot YAML would be
        check_units(table[:-1], table[-1], limits, sigma, _GRAVITY)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    for alert in alerts:
        warnings.warn(f"{path.name}: {alert}", stacklevel=2)
    return RobotModel(
        name=name or info["name"] or path.stem,
        mdh=table[:-1],
        tool=table[-1],
        sigma=sigma,
        limits=limits,
        gravity=_GRAVITY,
        dynamics=None if massless else dyn,
        base_frame=base_frame,
        transmission=transmission,
    )


def _reduction(entry: dict, tr: dict, path) -> float:
    """A ``<mechanicalReduction>`` (1 where absent), non-zero and finite."""
    text = entry["reduction"]
    try:
        value = 1.0 if text is None else float(text)
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and value != 0):
        raise ValueError(
            f"{path}: transmission '{tr['name']}': mechanicalReduction {text!r} of "
            f"'{entry['name']}': expected a non-zero number"
        )
    return value


def _transmission(
    info: dict, names: list[str], path
) -> tuple[Transmission | None, list[str]]:
    """The chain's transmission from the file's ros_control ``<transmission>``
    elements (module docstring), and warnings."""
    n = len(names)
    ratio, C, notes, geared = np.ones(n), np.eye(n), [], False
    for tr in info.get("transmissions", []):
        kind = tr["type"].rsplit("/", 1)[-1]
        joints = [names.index(j["name"]) if j["name"] in names else -1
                  for j in tr["joints"]]  # fmt: skip
        if not joints or min(joints) < 0:
            continue  # off the chain
        if kind == "SimpleTransmission" and len(joints) == 1 and tr["actuators"]:
            r = _reduction(tr["actuators"][0], tr, path)
            r *= _reduction(tr["joints"][0], tr, path)
            ratio[joints[0]] = r
            geared |= r != 1.0
        elif kind == "FourBarLinkageTransmission" and len(joints) == 2:
            if len(tr["actuators"]) != 2:
                raise ValueError(
                    f"{path}: transmission '{tr['name']}': a four-bar linkage has "
                    f"2 actuators, found {len(tr['actuators'])}"
                )
            na = [_reduction(a, tr, path) for a in tr["actuators"]]
            nj = [_reduction(j, tr, path) for j in tr["joints"]]
            j1, j2 = joints
            ratio[j1], ratio[j2] = nj[0] * na[0], na[1] * nj[1]
            C[j2, j1] = 1.0 / nj[1]
            geared = True
        else:
            notes.append(
                f"transmission '{tr['name']}' ({tr['type'] or 'no type'}) is not "
                "read: rmdrake reads ros_control's SimpleTransmission and "
                "FourBarLinkageTransmission"
            )
    if not geared:
        return None, notes
    try:
        out = Transmission(ratio, C)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    if out.coupled:
        motors = ", ".join(str(m + 1) for m in out.coupled)
        notes.append(
            f"coupled motor(s) {motors}: their Iam, fvm, fcm are not in a URDF "
            "(read as 0; identify them, or keep the robot YAML)"
        )
    return out, notes


def _kinematic_only(dropped: np.ndarray | None, limits: JointLimits) -> str:
    """The one warning on a kinematic-only import: what the model lacks (no
    dynamics: ``dropped`` is the (n, 13) parameters left out, every mass 0;
    None: it has them; no effort limits: ``limits.effort`` None) and which
    commands refuse it."""
    lacks, refusing = [], ["simulate"]
    if dropped is not None:
        columns = {"damping": 11, "friction": 12, "rotor inertia": 10}
        named = [k for k, c in columns.items() if np.any(dropped[:, c])]
        also = f"; its joint {', '.join(named)} dropped" if named else ""
        lacks.append(f"every link mass is 0 (no dynamics written{also})")
        refusing += _REFUSING["dynamics"]
    if limits.effort is None:
        lacks.append("no joint has an effort limit")
        refusing += _REFUSING["effort"]
    refusing = list(dict.fromkeys(refusing)) + ["the closed-loop studies"]
    return (
        f"kinematic-only model: {' and '.join(lacks)}; {KINEMATIC_COMMANDS} "
        f"work, {', '.join(refusing[:-1])} and {refusing[-1]} refuse it"
    )


def _inertials(plant, ctx, chain, tip, trees, X_LW, frames, source):
    """(n, 13) parameters (Ia filled, fv and fc 0) of the links: link j is every
    body below joint j's child, less those below joint j+1's child, about MDH
    frame j (X_LJ = ``frames[j]``), from the file's inertials (``source`` =
    (info, path)); also the moving joints so lumped, (name, kg) of the bodies
    with mass below ``tip``, and {"massless"|"stand-in": link names} (see
    :func:`rmdrake.model.urdf.parse.body_inertial`)."""
    (below, inboard), (info, path) = trees, source
    n = len(chain)
    subtree = [_subtree(j.child_body(), below) for j in chain] + [set()]
    reflected = {}
    for i in plant.GetJointActuatorIndices():
        act = plant.get_joint_actuator(i)
        Ia = act.default_rotor_inertia() * act.default_gear_ratio() ** 2
        reflected[int(act.joint().index())] = Ia
    dyn, side, beyond = np.zeros((n, 13)), [], []
    odd: dict = {"massless": [], "stand-in": []}
    for j, joint in enumerate(chain):
        child = joint.child_body()
        bodies = sorted(subtree[j] - subtree[j + 1])
        side += [
            inboard[b].name()
            for b in bodies
            if inboard[b].type_name() != "weld" and b != int(child.index())
        ]
        X_JL = np.linalg.inv(frames[j])
        for b in map(plant.get_body, map(BodyIndex, bodies)):
            p_B, note = body_inertial(info, b, path)
            if note:
                odd[note].append(b.name())
            X_JB = X_JL @ X_LW.multiply(b.EvalPoseInWorld(ctx)).GetAsMatrix4()
            dyn[j, :10] += transform_inertial(p_B, X_JB[:3, :3], X_JB[:3, 3])
            if j == n - 1 and b.index() != tip.index() and p_B[9] != 0.0:
                beyond += [(b.name(), p_B[9])] if _is_below(b, tip, inboard) else []
        dyn[j, 10] = reflected.get(int(joint.index()), 0.0)
    return dyn, side, beyond, odd


# ---- the MDH table ---------------------------------------------------------------
def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _row(R_prev, o_prev, xp, u, H, x_next, O) -> tuple[np.ndarray, np.ndarray]:
    """The MDH row from frame (R_prev, o_prev) to the frame with origin O on the
    axis (H, u) and x axis x_next, given the row's x' (xp, in the previous frame's
    xz plane and normal to u) that meets the axis at H. Returns the row and the
    new frame's rotation."""
    xl = R_prev.T @ xp
    beta = np.arctan2(-xl[2], xl[0])
    S = R_prev @ RotationMatrix.MakeYRotation(beta).matrix()
    v = S.T @ u
    alpha = np.arctan2(-v[1], v[2])
    M = S @ RotationMatrix.MakeXRotation(alpha).matrix()
    theta = np.arctan2(x_next @ M[:, 1], x_next @ M[:, 0])
    row = [alpha, (H - o_prev) @ xp, theta, (O - H) @ u, beta]
    return np.array(row), np.column_stack([x_next, np.cross(u, x_next), u])


def _mdh(p, u, sigma, X_LT) -> tuple[np.ndarray, list[np.ndarray], np.ndarray | None]:
    """The (n+1, 5) table of the axes (p_j, u_j) in L and the tip pose X_LT (see
    module docstring); also the MDH frames X_LJ (4x4, j = 1..n, in L) and p_LB
    (None when B = L)."""
    n = len(u)
    P = np.vstack([p, X_LT[:3, 3]])
    U = np.vstack([u, X_LT[:3, 2]])
    # base: x' in L's xz plane, normal to z_1, with x' . e_x >= 0
    c = np.cross([0.0, 1.0, 0.0], U[0])
    if np.linalg.norm(c) < 1e-12:  # z_1 along y: any x' in the xz plane will do
        c = P[0] * [1.0, 0.0, 1.0]
        c = c if np.linalg.norm(c) > 1e-12 else np.array([1.0, 0.0, 0.0])
    xp = _unit(c)
    if xp[0] < 0 or (xp[0] == 0 and xp[2] > 0):
        xp = -xp
    normal = np.cross(xp, U[0])
    off = P[0] @ normal
    if sigma[0] == 1:  # a prismatic line may move: put it where B = L works
        P[0] -= off * normal
        off = 0.0
    o = o_B = off * normal if abs(off) > BASE_TOLERANCE else np.zeros(3)
    R = np.eye(3)
    H = o + ((P[0] - o) @ xp) * xp
    rows, frames = [], []
    for j in range(n + 1):
        if j == n:  # the tip frame
            x_next, O = X_LT[:3, 0], X_LT[:3, 3]
        else:
            un, pn = U[j + 1], P[j + 1]
            s = np.cross(U[j], un)
            if np.linalg.norm(s) >= np.sin(PARALLEL_ANGLE):  # Khalil
                x_next = _unit(s)
                b, w0 = U[j] @ un, H - pn
                den = 1.0 - b * b
                O = H + (b * (un @ w0) - U[j] @ w0) / den * U[j]
                H_next = pn + ((un @ w0) - b * (U[j] @ w0)) / den * un
                xp_next = x_next
            else:  # Hayati: O_j = H_j (r_j = 0), x' to the foot on z_{j+1}
                O = H
                H_next = pn + ((O - pn) @ un) * un
                v = H_next - O
                if np.linalg.norm(v) > 1e-12:
                    xp_next = _unit(v)
                    x_next = _unit(v - (v @ U[j]) * U[j])
                else:  # coincident axes
                    x_next = xp
                    xp_next = _unit(np.cross(np.cross(U[j], xp), un))
                    xp_next *= np.sign(xp_next @ x_next) or 1.0
        row, R_next = _row(R, o, xp, U[j], H, x_next, O)
        rows.append(row)
        if j < n:
            frames.append(np.block([[R_next, O[:, None]], [np.zeros((1, 3)), 1.0]]))
            R, o, xp, H = R_next, O, xp_next, H_next
    return np.array(rows), frames, (o_B if np.any(o_B) else None)


# ---- the URDF's tree ----------------------------------------------------------------
def _subtree(body, below: dict) -> set:
    """Indices of ``body`` and every body below it."""
    out, todo = set(), [body]
    while todo:
        b = todo.pop()
        out.add(int(b.index()))
        todo += [j.child_body() for j in below.get(int(b.index()), [])]
    return out


def _is_below(body, top, inboard: dict) -> bool:
    """Whether ``body`` is ``top`` or below it."""
    while body.index() != top.index():
        if int(body.index()) not in inboard:
            return False
        body = inboard[int(body.index())].parent_body()
    return True


def _leaves(body, below: dict) -> list:
    out, todo = [], [body]
    while todo:
        b = todo.pop()
        kids = [j.child_body() for j in below.get(int(b.index()), [])]
        out += [] if kids else [b]
        todo += kids
    return out


def _ends(plant, below: dict, base, tip, path):
    """The base and tip bodies: named, or (omitted) the ends of the one chain."""
    if not base and not below.get(0):
        raise ValueError(
            f"{path}: the file has no links: robot has no actuated joints between "
            "base and tip"
        )
    top = _named(plant, base, "base", path) if base else below[0][0].child_body()
    leaves = _leaves(top, below)
    if (base is None or tip is None) and len(leaves) != 1:
        shown = ", ".join(sorted(b.name() for b in leaves)[:8])
        raise ValueError(
            f"{path}: give --base and --tip: the tree below '{top.name()}' is not "
            f"one chain but ends in {len(leaves)} leaf links ({shown}"
            f"{', ...' if len(leaves) > 8 else ''})"
        )
    end = _named(plant, tip, "tip", path) if tip else leaves[0]
    if end.index() == top.index():
        raise ValueError(
            f"{path}: base and tip are the same link '{top.name()}': robot has no "
            "actuated joints between base and tip"
        )
    return top, end


def _named(plant, link: str, what: str, path):
    """The body of link ``link`` (``--what`` names the option in the error)."""
    if not plant.HasBodyNamed(link):
        names = [
            plant.get_body(BodyIndex(i)).name() for i in range(1, plant.num_bodies())
        ]
        shown = ", ".join(names[:6]) + (", ..." if len(names) > 6 else "")
        raise ValueError(f"{path}: no link '{link}' (--{what}); links: {shown}")
    return plant.GetBodyByName(link)


def _not_below(inboard: dict, base, tip) -> str:
    """Why ``tip`` is not reached from ``base`` going down the tree."""
    ancestors, body = set(), base
    while True:
        ancestors.add(int(body.index()))
        if int(body.index()) not in inboard:
            break
        body = inboard[int(body.index())].parent_body()
    body = tip
    while int(body.index()) not in ancestors:
        body = inboard[int(body.index())].parent_body()
    if body.index() == tip.index():
        return f"tip link '{tip.name()}' is above base link '{base.name()}'"
    return (
        f"links '{base.name()}' and '{tip.name()}' are not joined by a serial "
        f"chain: tip is not below base, the path branches at link '{body.name()}'"
    )


def _limits(chain, sigma, info: dict, path) -> tuple[JointLimits, list[str]]:
    """Joint limits from the plant (position, velocity) and the XML (effort:
    None when no joint of the chain has a positive one, module docstring)."""
    n = len(chain)
    lo, hi, vel, eff, continuous = (np.empty(n), np.empty(n), np.empty(n),
                                    np.empty(n), [])  # fmt: skip
    for j, joint in enumerate(chain):
        xml_joint = info["joints"].get(joint.name(), {})
        lo[j] = joint.position_lower_limits()[0]
        hi[j] = joint.position_upper_limits()[0]
        if sigma[j] == 0 and (
            xml_joint.get("type") == "continuous"
            or not np.isfinite(lo[j])
            or not np.isfinite(hi[j])
        ):
            lo[j], hi[j] = -CONTINUOUS_LIMIT, CONTINUOUS_LIMIT
            continuous.append(joint.name())
        vel[j] = joint.velocity_upper_limits()[0]
        eff[j] = float(xml_joint.get("effort", "nan"))
        if not (np.isfinite(vel[j]) and vel[j] > 0):
            raise ValueError(
                f"{path}: joint '{joint.name()}': <limit velocity> is missing or "
                "not positive (the robot needs one)"
            )
        if not (np.isfinite(lo[j]) and np.isfinite(hi[j])):
            raise ValueError(f"{path}: joint '{joint.name()}': <limit> lower/upper")
    known = np.isfinite(eff) & (eff > 0)
    if np.any(known) and not np.all(known):
        no, yes = (chain[int(np.flatnonzero(k)[0])].name() for k in (~known, known))
        raise ValueError(
            f"{path}: joint '{no}': <limit effort> is missing or not positive "
            f"while joint '{yes}' has one: give every joint of the chain a "
            'positive effort, or none (effort="0": a kinematic-only model)'
        )
    limits = JointLimits(
        lo, hi, vel, vel / DEFAULT_ACCELERATION_TIME, eff if np.all(known) else None
    )
    return limits, continuous
