"""``rmdrake correct``: a tool-target file or a nominal joint program corrected
for a calibrated robot, written as a joint program CSV (motor-side, i.e.
pre-deflected for the payload, when the calibrated robot has elastic joints)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rmdrake.calibration.sanity import CalibrationBounds
from rmdrake.compensation.correction import (
    correct_targets,
    filter_program,
    inverse_kinematics,
)
from rmdrake.compensation.programs import (
    JointProgram,
    read_joint_program,
    read_tool_targets,
    write_joint_program,
)
from rmdrake.dynamics.compliance import joint_compliances, payload_masses
from rmdrake.kinematics.forward import robot_reach
from rmdrake.kinematics.rotations import rotation_from_rpy
from rmdrake.model.loading import controller_model_for, load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.model.same_robot import check_same_robot

__all__ = ["REACH_FACTOR", "correct_file", "correction_bounds"]

Echo = Callable[[str], None]

REACH_FACTOR = 10.0
"""A tool target farther from the base than this times the robot's reach
(:func:`~rmdrake.kinematics.forward.robot_reach`, the larger of the calibrated
and nominal robots') is refused before any IK, whatever
``--allow-unreachable`` says: a target in mm is 1000 times, one in cm 100
times too far, not merely out of reach. One within it but unreachable is
reported with its residual (and dropped by ``--allow-unreachable``)."""


def correct_file(
    robot: str,
    targets: str | os.PathLike,
    out: str | os.PathLike,
    *,
    nominal: str | None = None,
    allow_unreachable: bool = False,
    payload: float | None = None,
    echo: Echo = print,
) -> Path:
    """Corrects a program for a calibrated robot; writes the joint program CSV.

    ``targets`` is either tool targets (``x,y,z`` in m, optionally
    ``roll,pitch,yaw`` in rad and ``t`` in s: solved on the calibrated model,
    seeded by the nominal model's multi-start IK) or a
    nominal joint program (``q1..qn``, optionally ``t``: filtered, i.e. the
    nominal tool poses at those joints become the targets), told apart by the
    header. The nominal model is ``nominal``, by default the shipped robot whose
    name the calibrated one carries (else the calibrated one itself).

    When the calibrated robot has elastic joints (``compliance``), the solved
    (link-side) joints are pre-deflected for ``payload`` kg at the tool (None:
    its payload entry's mass, 0 without one):
    :func:`rmdrake.dynamics.compliance.motor_angles`, the motor-side targets that hold
    the link side there at rest; those are written, and the largest
    pre-deflection per joint is echoed. On a rigid robot a payload > 0 only
    earns a note (nothing changes).

    Refused as well (ValueError, one line): a nominal robot that is not the
    calibrated one (:func:`~rmdrake.model.same_robot.check_same_robot`),
    target angles beyond +-2 pi rad (degrees), a target farther from the
    base than :data:`REACH_FACTOR` times the robot's reach (mm, whatever
    ``allow_unreachable`` says), a correction over
    :func:`correction_bounds`, and a pre-deflection over what a joint bends
    at its effort limit (a payload the robot cannot hold).

    Raises:
      ValueError: a bad file, robots with different joint counts, a negative
        payload or one > 0 on a robot without a payload entry, or targets out
        of reach (each named with its residual) unless ``allow_unreachable``,
        when the reachable rows alone are written.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_points
    >>> from rmdrake.compensation.programs import ToolTargets, write_tool_targets
    >>> from rmdrake.pipelines import correct_file
    >>> robot = load_robot("rv3sb")
    >>> p_BE = tool_points(robot.table, np.array([[0.0, 0.3, 1.2, 0.0, 0.5, 0.0]]))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     targets = write_tool_targets(Path(tmp, "targets.csv"), ToolTargets(p_BE))
    ...     lines = []
    ...     program = Path(tmp, "program.csv")
    ...     out = correct_file("rv3sb", targets, program, echo=lines.append)
    ...     print(out.read_text().splitlines()[0])
    ...
    q1,q2,q3,q4,q5,q6
    """
    calibrated = load_robot(robot)
    model = load_robot(nominal) if nominal else None
    model = model or controller_model_for(calibrated, str(robot))
    if model.n_joints != calibrated.n_joints:
        raise ValueError(
            f"nominal robot '{model.name}' has {model.n_joints} joints, the "
            f"calibrated '{calibrated.name}' {calibrated.n_joints}"
        )
    check_same_robot(
        calibrated,
        model,
        what="nominal",
        remedy="give the robot the calibration started from with --nominal",
    )
    mass = float(payload_masses(calibrated, payload, 1)[0])  # checks the value
    elastic = bool(joint_compliances(calibrated).any())
    if not elastic and mass > 0 and payload is not None:
        echo(
            f"note: robot '{calibrated.name}' has no compliance (rigid joints): "
            f"--payload {mass:g} kg changes nothing"
        )
    header = Path(targets).read_text(encoding="utf-8-sig").split("\n", 1)[0]
    if "x" in [c.strip() for c in header.split(",")]:
        given = read_tool_targets(targets)
        _check_angles(given.rpy, targets)
        _check_reach(given.p_BE, max(robot_reach(calibrated), robot_reach(model)),
                     targets)  # fmt: skip
        R = None if given.rpy is None else rotation_from_rpy(given.rpy)
        seed = inverse_kinematics(model, given.p_BE, orientation=R).q
        fix = correct_targets(
            calibrated, given.p_BE, q_seed=seed, orientation=R, payload=mass
        )
        q_from, t = seed, given.t
    else:
        program = read_joint_program(targets, model.n_joints)
        fix = filter_program(model, calibrated, program.q, payload=mass).correction
        q_from, t = program.q, program.t
    echo(f"robot '{calibrated.name}' (nominal '{model.name}'): {fix.summary()}")
    keep = fix.reachable
    if not keep.all() and not allow_unreachable:
        k = int(fix.unreachable[0])
        raise ValueError(
            f"{targets}: {fix.unreachable.size} target(s) out of reach, first "
            f"row {k + 1} (position residual {fix.position_residual[k]:.3g} m); "
            "--allow-unreachable writes the others"
        )
    dq = np.abs(fix.q[keep] - q_from[keep]).max(axis=0, initial=0.0)
    echo(f"largest correction per joint: {_per_joint(dq, calibrated.sigma)}")
    _check_corrections(dq, calibrated)
    q = fix.q
    if fix.q_motor is not None:
        q = fix.q_motor
        bend = np.abs(q[keep] - fix.q[keep]).max(axis=0, initial=0.0)
        echo(
            f"largest pre-deflection per joint (payload {mass:g} kg): "
            + _per_joint(bend, calibrated.sigma)
        )
        _check_deflections(bend, calibrated, mass)
    program = JointProgram(q[keep], None if t is None else t[keep])
    return write_joint_program(out, program)


def correction_bounds(model: RobotModel) -> np.ndarray:
    """(n,) the largest joint correction a calibration of ``model`` can call
    for, rad or m: a calibration moves each of the 3 n MDH angles by at most
    ``CalibrationBounds.angle`` (5 deg) and each of the 2 n lengths by at most
    ``length + length_fraction x reach`` (44 mm on the RV-3SB); a revolute
    joint compensates at most the sum of the angle bounds (3 n x 5 deg: 90
    deg on a 6-joint arm), a prismatic one the sum of the length bounds plus
    the reach times that angle sum."""
    b = CalibrationBounds()
    n = model.n_joints
    angle = 3 * n * b.angle
    reach = robot_reach(model)
    length = 2 * n * (b.length + b.length_fraction * reach) + reach * angle
    return np.where(np.asarray(model.sigma) == 1, length, angle)


def _check_corrections(dq: np.ndarray, model: RobotModel) -> None:
    """Refuses corrections over :func:`correction_bounds` (one line)."""
    bound = correction_bounds(model)
    over = np.flatnonzero(dq > bound)
    if over.size:
        j = int(over[0])
        v, lim = (
            _per_joint(dq[j : j + 1], model.sigma[j : j + 1]),
            _per_joint(bound[j : j + 1], model.sigma[j : j + 1]),
        )
        raise ValueError(
            f"correction of joint {j + 1} is {v}, beyond the {lim} a calibration "
            "of this robot can call for (its bounds: +-5 deg per MDH angle, "
            "20 mm + 2 % of the reach per length): the calibrated and nominal "
            "robots are not one robot, or a target changed IK branch; check "
            "--robot and --nominal"
        )


def _check_deflections(bend: np.ndarray, model: RobotModel, mass: float) -> None:
    """Refuses pre-deflections over what each joint bends at its effort limit
    (c_j x effort_j): the joint cannot hold that payload (one line). Nothing
    to check against where the effort limits are unknown (a kinematic-only
    model)."""
    if not model.has_effort_limits:
        return
    most = joint_compliances(model) * np.asarray(model.limits.effort)
    over = np.flatnonzero(bend > most * (1 + 1e-9))
    if over.size:
        j = int(over[0])
        sigma = model.sigma[j : j + 1]
        raise ValueError(
            f"payload {mass:g} kg: pre-deflection of joint {j + 1} is "
            f"{_per_joint(bend[j : j + 1], sigma)}, over the "
            f"{_per_joint(most[j : j + 1], sigma)} it bends at its effort limit "
            f"{model.limits.effort[j]:g} N m: robot '{model.name}' cannot hold "
            "this payload; give the payload in kg, within the robot's rating"
        )


def _check_reach(p_BE: np.ndarray, reach: float, targets: object) -> None:
    """Refuses a target farther than :data:`REACH_FACTOR` x ``reach`` (m) from
    the base frame's origin (one line naming the row and the unit)."""
    dist = np.linalg.norm(np.asarray(p_BE, dtype=np.float64), axis=1)
    far = np.flatnonzero(dist > REACH_FACTOR * reach)
    if far.size:
        k = int(far[0])
        raise ValueError(
            f"{targets}: target row {k + 1} is {dist[k]:.4g} m from the base, "
            f"beyond {REACH_FACTOR:g} x the reach {reach:.3g} m ({far.size} such "
            "row(s)): targets are in m in the robot's base frame, not mm?"
        )


def _check_angles(rpy: np.ndarray | None, targets: object) -> None:
    """Refuses target angles (roll, pitch, yaw) beyond +-2 pi rad."""
    if rpy is None:
        return
    big = np.argwhere(np.abs(rpy) > 2 * np.pi)
    if big.size:
        k, c = map(int, big[0])
        name = ("roll", "pitch", "yaw")[c]
        raise ValueError(
            f"{targets}: row {k + 1} {name} = {rpy[k, c]:g} is beyond +-2 pi rad: "
            "angles are in rad, not degrees (convert with deg x pi / 180)"
        )


def _per_joint(values: np.ndarray, sigma: np.ndarray) -> str:
    """(n,) rad or m as "a deg, b mm, ..." by joint type."""
    return ", ".join(
        f"{v * 1e3:.4g} mm" if s else f"{np.rad2deg(v):.4g} deg"
        for v, s in zip(values, sigma, strict=True)
    )
