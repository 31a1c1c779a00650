"""URDF import and export against Drake's (and Pinocchio's) own parse of the file.

Oracles: forward kinematics of the imported table (composed with X_LB) ==
Drake's CalcRelativeTransform(base link, tip link) on the URDF plant to 1e-12;
inverse dynamics of MakePlant(imported) == the URDF plant's (base link fixed,
other joints at rest at q = 0) to 1e-9 relative; the exported file parsed by
Drake and by Pinocchio == the robot YAML's kinematics and dynamics.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import MultibodyForces

from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import BaseFrame
from rmdrake.model.urdf.importer import robot_from_urdf, robot_to_urdf
from rmdrake.model.urdf.parse import urdf_plant

TIAGO = SHARED_DATA / "tiago_figaroh/tiago.urdf"
TIAGO_CHAIN = ["torso_lift_joint"] + [f"arm_{i}_joint" for i in range(1, 8)]
MUKCA = SHARED_DATA / "mukca_panda/panda.urdf"
MUKCA_CHAIN = [f"panda_joint{j}" for j in range(1, 8)]


# ---- test URDFs -------------------------------------------------------------------
def _inertial(rng: np.random.Generator) -> str:
    """A random physically valid inertial: a box of random size and mass at a
    random pose."""
    m = rng.uniform(0.5, 4.0)
    a, b, c = rng.uniform(0.02, 0.3, 3)
    I = m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    xyz, rpy = rng.uniform(-0.1, 0.1, 3), rng.uniform(-np.pi, np.pi, 3)
    R = RollPitchYaw(rpy).ToRotationMatrix().matrix()
    T = R @ np.diag(I) @ R.T
    return (
        f'<inertial><origin xyz="{_f(xyz)}" rpy="0 0 0"/><mass value="{_f([m])}"/>'
        f'<inertia ixx="{_f([T[0, 0]])}" ixy="{_f([T[0, 1]])}" ixz="{_f([T[0, 2]])}" '
        f'iyy="{_f([T[1, 1]])}" iyz="{_f([T[1, 2]])}" izz="{_f([T[2, 2]])}"/>'
        "</inertial>"
    )


def _f(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _urdf(joints: list[tuple], seed: int, extra: str = "") -> str:
    """URDF text: one link per name met, each with a random inertial (the root
    too), and joints ``(name, type, parent, child, xyz, rpy, axis)``."""
    rng = np.random.default_rng(seed)
    links = []
    for j in joints:
        links += [k for k in j[2:4] if k not in links]
    out = ['<robot name="test">']
    out += [f'<link name="{k}">{_inertial(rng)}</link>' for k in links]
    for name, kind, parent, child, xyz, rpy, axis in joints:
        out.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{_f(xyz)}" rpy="{_f(rpy)}"/>'
            f'<axis xyz="{_f(axis)}"/><limit lower="-2" upper="2" velocity="1.5" '
            f'effort="30"/><dynamics damping="0.7" friction="0.3"/></joint>'
        )
    return "\n".join([*out, extra, "</robot>"])


def _tilt(axis, angle, rng):
    """``axis`` turned by ``angle`` about a random normal."""
    axis = np.asarray(axis, float)
    w = np.cross(axis, rng.normal(size=3))
    return RotationMatrixAA(w / np.linalg.norm(w), angle) @ axis


def RotationMatrixAA(w, angle):
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _skew_arm() -> tuple[str, str, str, list[str]]:
    """Arbitrary axes, origins and rpy; a prismatic joint; a fixed joint inside
    the chain; nearly parallel (0.03 rad) then exactly parallel axes; a side
    chain off the middle; welded and moving bodies beyond the tip; a first axis
    one MDH row cannot reach from the base link; a transmission (rotor inertia)."""
    rng = np.random.default_rng(3)
    r = lambda s=0.3: rng.uniform(-s, s, 3)  # noqa: E731
    ax = lambda: rng.normal(size=3)  # noqa: E731
    a3 = ax() / np.linalg.norm(ax())
    a4 = _tilt(a3, 0.03, rng)
    joints = [
        ("j1", "revolute", "base", "l1", [0.3, 0.2, 0.4], r(3), ax()),
        ("j2", "prismatic", "l1", "l2", r(), r(3), ax()),
        ("f23", "fixed", "l2", "l2b", r(), r(3), [1, 0, 0]),
        ("j3", "revolute", "l2b", "l3", r(), r(3), a3),
        ("j4", "revolute", "l3", "l4", r(), [0, 0, 0], a4),
        ("j5", "revolute", "l4", "l5", r(), [0, 0, 0], a4),
        ("side1", "revolute", "l3", "s1", r(), r(3), ax()),
        ("side2", "fixed", "s1", "s2", r(), r(3), [1, 0, 0]),
        ("j6", "continuous", "l5", "l6", r(), r(3), ax()),
        ("ftip", "fixed", "l6", "tip", r(), r(3), [1, 0, 0]),
        ("beyond1", "fixed", "tip", "b1", r(), r(3), [1, 0, 0]),
        ("beyond2", "prismatic", "b1", "b2", r(), r(3), ax()),
    ]
    extra = (
        '<transmission name="t3"><type>SimpleTransmission</type><joint name="j3"/>'
        '<actuator name="m3"><drake:rotor_inertia value="0.02"/>'
        '<drake:gear_ratio value="3"/></actuator></transmission>'
    )
    names = ["j1", "j2", "j3", "j4", "j5", "j6"]
    return _urdf(joints, 11, extra), "base", "tip", names


def _mid_arm() -> tuple[str, str, str, list[str]]:
    """The chain starts below the root (base = a moving link of a side chain),
    axes along x, y and z, anti-parallel and coincident axes (a prismatic joint
    on the line of a revolute one)."""
    joints = [
        ("r0", "revolute", "root", "mount", [0.1, 0, 0.2], [0.3, 0.1, 0.5], [0, 1, 0]),
        ("a1", "revolute", "mount", "k1", [0, 0, 0.3], [0, 0, 0], [0, 0, 1]),
        ("a2", "revolute", "k1", "k2", [0, 0.1, 0.2], [0, 0, 0], [0, 0, -1]),
        ("a3", "prismatic", "k2", "k3", [0, 0, 0.1], [0, 0, 0], [0, 0, 1]),
        ("a4", "revolute", "k3", "k4", [0.2, 0, 0], [0.2, 0, 0], [1, 0, 0]),
        ("a5", "revolute", "k4", "k5", [0, 0.2, 0], [0, 0, 0], [0, 1, 0]),
        ("a6", "revolute", "k5", "k6", [0.1, 0, 0.05], [0, 0.4, 0], [0, 1, 0]),
    ]
    return _urdf(joints, 12), "mount", "k6", ["a1", "a2", "a3", "a4", "a5", "a6"]


def _write(tmp_path: Path, case) -> tuple[Path, str, str, list[str]]:
    text, base, tip, names = case
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    return path, base, tip, names


def _import(path, base, tip):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return robot_from_urdf(path, base=base, tip=tip)


def _X_LB(model) -> np.ndarray:
    if model.base_frame is None:
        return np.eye(4)
    bf = model.base_frame
    return RigidTransform(RollPitchYaw(bf.rpy), bf.xyz).GetAsMatrix4()


def _set(plant, ctx, names, q, v=None):
    """Chain joints at q (and v); every other joint at q = v = 0."""
    qq, vv = np.zeros(plant.num_positions()), np.zeros(plant.num_velocities())
    idx = [plant.GetJointByName(n).velocity_start() for n in names]
    for k, name in enumerate(names):
        qq[plant.GetJointByName(name).position_start()] = q[k]
        vv[idx[k]] = 0.0 if v is None else v[k]
    plant.SetPositions(ctx, qq)
    plant.SetVelocities(ctx, vv)
    return idx


def _fk_error(path, base, tip, names, model, rng, samples=12) -> float:
    plant = urdf_plant(path)
    ctx = plant.CreateDefaultContext()
    F_base, F_tip = plant.GetFrameByName(base), plant.GetFrameByName(tip)
    q = rng.uniform(-1.5, 1.5, (samples, len(names)))
    X = _X_LB(model) @ tool_poses(model.table, q, sigma=model.sigma)
    worst = 0.0
    for k in range(samples):
        _set(plant, ctx, names, q[k])
        X_ref = plant.CalcRelativeTransform(ctx, F_base, F_tip).GetAsMatrix4()
        worst = max(worst, np.abs(X_ref - X[k]).max())
    return worst


def _id_error(path, base, names, model, rng, samples=6) -> float:
    """Max |tau_urdf - tau_imported| / max |tau_urdf| on the chain joints."""
    plant = urdf_plant(path)
    ctx = plant.CreateDefaultContext()
    _set(plant, ctx, names, np.zeros(len(names)))
    R_WL = plant.GetFrameByName(base).CalcPoseInWorld(ctx).rotation().matrix()
    plant = urdf_plant(path, gravity=R_WL @ [0.0, 0.0, -9.81])  # g_L upright
    ctx = plant.CreateDefaultContext()
    mine, _ = MakePlant(model, visual=False, skip_validity_check=True)
    mctx = mine.CreateDefaultContext()
    worst = 0.0
    for _ in range(samples):
        q, v, a = rng.normal(size=(3, len(names)))
        idx = _set(plant, ctx, names, q, v)
        vd = np.zeros(plant.num_velocities())
        vd[idx] = a
        ref = plant.CalcInverseDynamics(ctx, vd, MultibodyForces(plant))
        ref = (ref - plant.CalcGravityGeneralizedForces(ctx))[idx]
        mine.SetPositions(mctx, q)
        mine.SetVelocities(mctx, v)
        tau = mine.CalcInverseDynamics(mctx, a, MultibodyForces(mine))
        tau = tau - mine.CalcGravityGeneralizedForces(mctx)
        worst = max(worst, np.abs(ref - tau).max() / np.abs(ref).max())
    return worst


# ---- import -----------------------------------------------------------------
@pytest.mark.parametrize("case", [_skew_arm, _mid_arm])
def test_import_matches_drake_kinematics_and_dynamics(case, tmp_path, rng):
    path, base, tip, names = _write(tmp_path, case())
    model = _import(path, base, tip)
    assert model.n_joints == len(names)
    fk = _fk_error(path, base, tip, names, model, rng)
    assert fk < 1e-12, fk
    err = _id_error(path, base, names, model, rng)
    assert err < 1e-9, err
    # a model with a base_frame round-trips it through its YAML
    again = load_robot(model.save(tmp_path / "arm.yaml"))
    np.testing.assert_array_equal(_X_LB(again), _X_LB(model))


def test_skew_arm_rules_and_warnings(tmp_path):
    """The documented choices are visible in the table: Hayati's beta for the
    nearly parallel pair (|beta| < 0.1, r = 0), beta = 0 elsewhere but the base
    and tool; the base frame moved; warnings for the base, the lumped moving
    joints and the continuous joint; URDF damping, friction and rotor inertia."""
    path, base, tip, _ = _write(tmp_path, _skew_arm())
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(path, base=base, tip=tip)
    text = " | ".join(str(w.message) for w in record)
    assert "base frame B" in text and "targets are in B" in text
    assert "beyond2" in text and "side1" in text
    assert "continuous joint(s) j6" in text
    assert model.base_frame is not None and model.base_frame.link == "base"
    np.testing.assert_array_equal(model.base_frame.rpy, 0.0)
    assert model.limits.upper[5] == pytest.approx(2 * np.pi)
    t = model.table  # row k (0-based) places frame k+1 in frame k
    np.testing.assert_allclose(t[2:4, 3], 0.0, atol=1e-12)  # r3 = r4 = 0
    assert 1e-4 < abs(t[3, 4]) < 0.1  # frame 3 -> 4: 0.03 rad apart
    assert t[4, 4] == pytest.approx(0.0, abs=1e-12)  # 4 -> 5 exactly parallel
    np.testing.assert_allclose(t[[1, 2, 5], 4], 0.0, atol=1e-15)  # Khalil
    np.testing.assert_array_equal(model.sigma, [0, 1, 0, 0, 0, 0])
    np.testing.assert_allclose(model.dynamics[:, 11:], [[0.7, 0.3]] * 6)
    np.testing.assert_allclose(model.dynamics[:, 10], [0, 0, 0.18, 0, 0, 0])
    np.testing.assert_allclose(model.limits.acceleration, 1.5 / 0.5)


@pytest.mark.skipif(not TIAGO.is_file(), reason="the TIAGo URDF is not in shared/")
def test_tiago(rng):
    """The TIAGo's torso and arm: B is base_footprint itself (the torso axis meets
    its x axis), FK and ID equal Drake's parse of the file."""
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(TIAGO, base="base_footprint", tip="wrist_ft_tool_link")
    assert any("head_1_joint" in str(w.message) for w in record)
    assert model.base_frame is None and model.n_joints == 8
    np.testing.assert_array_equal(model.sigma, [1, 0, 0, 0, 0, 0, 0, 0])
    base, tip = "base_footprint", "wrist_ft_tool_link"
    assert _fk_error(TIAGO, base, tip, TIAGO_CHAIN, model, rng) < 1e-12
    assert _id_error(TIAGO, base, TIAGO_CHAIN, model, rng) < 1e-9
    np.testing.assert_allclose(model.dynamics[:, 11:], [[1000, 0]] + [[1, 1]] * 7)


BAD = {
    "parse": ("<robot name='x'><link name='a'>", None, None, "cannot parse URDF"),
    "base": (None, "nowhere", "tip", "no link 'nowhere' (--base); links: "),
    "tip": (None, "base", "nowhere", "no link 'nowhere' (--tip)"),
    "branch": (None, "l4", "s2", "the path branches at link 'l3'"),
    "above": (None, "l4", "l2", "tip link 'l2' is above base link 'l4'"),
    "one chain": (None, "base", None, "give --base and --tip"),
    "fixed only": (None, "l6", "tip", "fixed joints only"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_input_one_line(case, tmp_path):
    text, base, tip, message = BAD[case]
    path = tmp_path / "arm.urdf"
    path.write_text(text or _skew_arm()[0])
    with pytest.raises(ValueError, match=re.escape(message)) as e:
        _import(path, base, tip)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_joint_kind_refused(kind, tmp_path):
    joints = [
        ("j1", "revolute", "base", "l1", [0, 0, 0.1], [0, 0, 0], [0, 0, 1]),
        ("j2", kind, "l1", "l2", [0, 0, 0.1], [0, 0, 0], [0, 0, 1]),
    ]
    head, tail = _urdf(joints, 1).rsplit('damping="0.7"', 1)
    damping = 'damping="0.7 0.7 0.7"' if kind == "planar" else 'damping="0.7"'
    path = tmp_path / "arm.urdf"
    path.write_text(head + damping + tail)
    with pytest.raises(ValueError, match=f"joint 'j2' .*is {kind}: expected"):
        _import(path, "base", "l2")


def test_missing_effort_refused(tmp_path):
    """One joint without effort among joints with one: a typo, refused (a
    kinematic-only URDF has none on the chain)."""
    path = tmp_path / "arm.urdf"
    path.write_text(_skew_arm()[0].replace('effort="30"', 'effort="0"', 1))
    with pytest.raises(ValueError, match=r"joint 'j1': <limit effort>.* 'j2' has"):
        _import(path, "base", "tip")


# ---- kinematic-only URDFs: no masses, effort 0 or none -----------------------------
def _kinematic(text: str, massless: bool, effort: str | None) -> str:
    """``text`` (joints with ``effort="30"``) as a calibration tool writes it:
    ``massless``: no ``<inertial>``; every effort ``effort`` (None: no
    attribute); a ``<safety_controller>`` in every joint (Drake warns that it
    ignores it)."""
    if massless:
        text = re.sub(r"<inertial>.*?</inertial>", "", text, flags=re.S)
    text = text.replace(' effort="30"', "" if effort is None else f' effort="{effort}"')
    return text.replace("</joint>", '<safety_controller k_velocity="40"/></joint>')


@pytest.mark.parametrize(
    "massless, effort", [(True, "30"), (False, "0"), (True, "0"), (True, None)]
)
def test_kinematic_only_import(massless, effort, tmp_path, rng):
    """Every mass 0 and/or no effort limit: exactly one warning, naming only
    what is missing (Drake's safety_controller warnings dropped); no dynamics
    (not rows of zeros) or no effort limits, in the YAML too; the kinematics
    still == Drake's parse of the file."""
    path, base, tip, names = _write(tmp_path, _mid_arm())
    path.write_text(_kinematic(path.read_text(), massless, effort))
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(path, base=base, tip=tip)
    assert len(record) == 1, [str(w.message) for w in record]
    text = str(record[0].message)
    assert text.startswith("arm.urdf: kinematic-only model: ")
    no_effort = effort != "30"
    assert ("every link mass is 0" in text) == massless
    assert ("no joint has an effort limit" in text) == no_effort
    assert "export-urdf" in text and "simulate" in text and "refuse it" in text
    assert (model.dynamics is None) == massless and model.kinematic_only
    assert model.has_effort_limits != no_effort
    assert _fk_error(path, base, tip, names, model, rng) < 1e-12
    written = model.save(tmp_path / "k.yaml").read_text()
    assert ("dynamics:" in written) != massless and ("effort:" in written) != no_effort
    again = load_robot(tmp_path / "k.yaml")
    assert again.kinematic_only and again.to_yaml() == model.to_yaml()


def test_some_massless_links_keep_the_inertials(tmp_path):
    """One massless link among massive ones: the inertials are kept and the
    warning says they are not physically valid (not a kinematic-only model)."""
    path, base, tip, _ = _write(tmp_path, _mid_arm())
    text = path.read_text()
    k3 = re.search(r'<link name="k3"><inertial>.*?</inertial>', text, flags=re.S)
    path.write_text(text.replace(k3.group(0), '<link name="k3">'))
    with pytest.warns(UserWarning, match="link 3: mass > 0 fails") as record:
        model = robot_from_urdf(path, base=base, tip=tip)
    assert not any("kinematic-only" in str(w.message) for w in record)
    assert model.dynamics is not None and model.dynamics[2, 9] == 0.0
    assert np.all(np.delete(model.dynamics[:, 9], 2) > 0)


def test_real_parser_warnings_kept(tmp_path):
    """Effort 0 on a joint with a transmission: Drake's parser skips the
    transmission (its rotor inertia is lost); that warning is kept beside the
    kinematic-only one."""
    path = tmp_path / "arm.urdf"
    path.write_text(_kinematic(_skew_arm()[0], False, "0"))
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(path, base="base", tip="tip")
    text = " | ".join(str(w.message) for w in record)
    assert "no joint has an effort limit" in text
    assert "Drake's URDF parser: 1 warning(s)" in text and "transmission" in text
    assert "safety_controller" not in text
    assert model.limits.effort is None and not np.any(model.dynamics[:, 10])


def test_kinematic_only_export_round_trip(tmp_path, rng):
    """export(import(kinematic-only URDF)): effort="0" on every joint, no
    inertials; its re-import is kinematic-only again with the same MDH table
    and kinematics."""
    path, base, tip, names = _write(tmp_path, _mid_arm())
    path.write_text(_kinematic(path.read_text(), True, "0"))
    model = _import(path, base, tip)
    out = tmp_path / "export.urdf"
    out.write_text(robot_to_urdf(model))
    text = out.read_text()
    assert text.count('effort="0.0"') == model.n_joints and "<inertial>" not in text
    with pytest.warns(UserWarning, match="kinematic-only model: every link mass"):
        again = robot_from_urdf(out, base="base", tip="tool")
    assert again.dynamics is None and again.limits.effort is None
    np.testing.assert_allclose(again.table, model.table, rtol=0, atol=1e-12)
    q = rng.uniform(-1.5, 1.5, (8, model.n_joints))
    X, X_again = (_X_LB(m) @ tool_poses(m.table, q, sigma=m.sigma)
                  for m in (model, again))  # fmt: skip
    assert np.abs(X_again - X).max() < 1e-12


def test_export_without_effort_warns_of_lost_rotor_inertia(rv3sb):
    """Effort limits unknown but rotor inertias given: the URDF says effort 0,
    on which Drake's parser skips their transmissions; a warning says so."""
    assert np.all(rv3sb.dynamics[:, 10] > 0)
    limits = dataclasses.replace(rv3sb.limits, effort=None)
    model = dataclasses.replace(rv3sb, limits=limits)
    with pytest.warns(UserWarning, match="skips the transmissions"):
        text = robot_to_urdf(model)
    assert text.count('effort="0.0"') == 6


@pytest.mark.skipif(not MUKCA.is_file(), reason="the MUKCa Panda is not in shared/")
def test_mukca_panda(rng):
    """The MUKCa calibration Panda (no inertials, effort limits, safety
    controllers): one warning, no dynamics; its MDH kinematics == Drake's parse
    of the file at random q."""
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(
            MUKCA, base="panda_link0", tip="ball_link",
            exclude=["panda_leftfinger", "panda_rightfinger"],
        )  # fmt: skip
    assert len(record) == 1, [str(w.message) for w in record]
    text = str(record[0].message)
    assert text.startswith("panda.urdf: kinematic-only model: every link mass is 0")
    assert "effort limit;" not in text
    assert model.dynamics is None and model.has_effort_limits
    assert model.n_joints == 7 and model.base_frame is None
    assert _fk_error(MUKCA, "panda_link0", "ball_link", MUKCA_CHAIN, model, rng) < 1e-9


# ---- export -----------------------------------------------------------------
def _calibrated(model, rng):
    """A calibrated-looking model: every table entry moved a little."""
    table = model.table + rng.normal(scale=[2e-3, 1e-3, 2e-3, 1e-3, 1e-3], size=(
        model.n_joints + 1, 5))  # fmt: skip
    return model.with_table(table)


def _exported(any_robot, rng, calibrated):
    model = _calibrated(any_robot, rng) if calibrated else any_robot
    if calibrated:  # and a base frame to apply
        frame = BaseFrame("mount", rng.uniform(-0.3, 0.3, 3), rng.uniform(-1, 1, 3))
        model = dataclasses.replace(model, base_frame=frame)
    return model


@pytest.mark.parametrize("calibrated", [False, True])
def test_export_drake_and_pinocchio(any_robot, calibrated, tmp_path, rng):
    pin = pytest.importorskip("pinocchio")
    model = _exported(any_robot, rng, calibrated)
    path = tmp_path / "robot.urdf"
    path.write_text(robot_to_urdf(model))
    if model.coupled_motors:  # a four-bar's joints carry no rotor in a URDF
        dyn = np.array(model.dynamics)
        for m in model.coupled_motors:
            dyn[np.flatnonzero(model.transmission.coupling[m]), 10] = 0.0
        model = dataclasses.replace(
            model, dynamics=dyn, transmission=None, motor_terms=None
        )
    n = model.n_joints
    names = [f"joint{j}" for j in range(1, n + 1)]
    q = rng.uniform(-1, 1, (8, n)) * np.where(model.sigma, 0.3, 1.0)
    X_ref = _X_LB(model) @ tool_poses(model.table, q, sigma=model.sigma)
    # Drake
    fk = _fk_error(path, "base", "tool", names, model, np.random.default_rng(1), 8)
    assert fk < 1e-12, fk
    # Pinocchio: FK, then ID (armature = Ia) against MakePlant's
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    R_LB = _X_LB(model)[:3, :3]
    pm.gravity.linear = R_LB @ model.gravity
    tool = pm.getFrameId("tool")
    worst = 0.0
    for k in range(len(q)):
        pin.framesForwardKinematics(pm, pd, q[k])
        worst = max(worst, np.abs(pd.oMf[tool].homogeneous - X_ref[k]).max())
    assert worst < 1e-12, worst
    mine, _ = MakePlant(model, visual=False, skip_validity_check=True)
    ctx = mine.CreateDefaultContext()
    pm.armature = model.dynamics[:, 10].copy()
    err = 0.0
    for _ in range(5):
        qk, v, a = rng.normal(size=(3, n))
        tau_pin = pin.rnea(pm, pd, qk, v, a)
        mine.SetPositions(ctx, qk)
        mine.SetVelocities(ctx, v)
        tau = mine.CalcInverseDynamics(ctx, a, MultibodyForces(mine))
        tau = tau - mine.CalcGravityGeneralizedForces(ctx)
        err = max(err, np.abs(tau - tau_pin).max() / np.abs(tau).max())
    assert err < 1e-9, err
    # Drake's parse of the export: inverse dynamics too
    plant = urdf_plant(path, gravity=R_LB @ model.gravity)
    pctx = plant.CreateDefaultContext()
    plant.SetPositions(pctx, qk)
    plant.SetVelocities(pctx, v)
    ref = plant.CalcInverseDynamics(pctx, a, MultibodyForces(plant))
    ref = ref - plant.CalcGravityGeneralizedForces(pctx)
    assert np.abs(ref - tau).max() / np.abs(tau).max() < 1e-9
    # import(export(model)) has the same kinematics
    again = _import(path, "base", "tool")
    X_again = _X_LB(again) @ tool_poses(again.table, q, sigma=again.sigma)
    assert np.abs(X_again - X_ref).max() < 1e-12
    np.testing.assert_array_equal(again.sigma, model.sigma)
    np.testing.assert_allclose(again.dynamics[:, 10:], model.dynamics[:, 10:])


# ---- masses: zero-mass links, links without <inertial>, --exclude ----------------
_I = 'ixx="0.01" ixy="0.001" ixz="0" iyy="0.02" iyz="0" izz="0.03"'
_MASSES = {  # link: (parent, joint origin xyz, inertial or "")
    "l1": (
        "base",
        "0 0 0.1",
        f'<origin xyz="0.1 0 0" rpy="0.3 0.2 0.1"/><mass value="2"/><inertia {_I}/>',
    ),  # fmt: skip
    "cover": ("l1", "0 0.1 0", None),  # no <inertial>
    "l2": (
        "l1",
        "0.3 0 0",
        f'<origin xyz="0 0.1 0.05"/><mass value="1.5"/><inertia {_I}/>',
    ),
    "flange": (
        "l2",
        "0 0 0.2",
        '<origin xyz="0 0 0.05"/><mass value="0"/>'
        '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>',
    ),
    "hand": (
        "flange",
        "0 0 0.1",
        f'<origin xyz="0.02 0 0.04" rpy="0 0.4 0"/><mass value="0.5"/><inertia {_I}/>',
    ),  # fmt: skip
    "marker": (
        "hand",
        "0 0 0.1",
        '<mass value="0.0"/><inertia ixx="0.1" ixy="0" '
        'ixz="0" iyy="0.1" iyz="0" izz="0.1"/>',
    ),  # fmt: skip
}


def _masses_urdf(path: Path, leave_out=(), massless=False) -> Path:
    """The test arm base -j1- l1 -j2- l2 - flange (tip) - hand - marker (cover
    on l1), without the links ``leave_out``; ``massless``: the mass-0 links'
    <inertial> removed (what the import should read)."""
    out = ['<robot name="m"><link name="base"/>']
    for k, (parent, xyz, inertial) in _MASSES.items():
        if k in leave_out:
            continue
        if inertial is not None and not (massless and k in ("flange", "marker")):
            out.append(f'<link name="{k}"><inertial>{inertial}</inertial></link>')
        else:
            out.append(f'<link name="{k}"/>')
        kind = "revolute" if k in ("l1", "l2") else "fixed"
        out.append(
            f'<joint name="j_{k}" type="{kind}"><parent link="{parent}"/><child '
            f'link="{k}"/><origin xyz="{xyz}"/><axis xyz="0 {int(k == "l2")} '
            f'{int(k == "l1")}"/><limit lower="-2" upper="2" velocity="1" effort="9"/>'
            "</joint>"
        )
    path.write_text("\n".join([*out, "</robot>"]))
    return path


def test_zero_mass_and_missing_inertials(tmp_path, rng):
    """Drake's parse makes a mass-0 link with an inertia a 1 kg body; the import
    counts it as massless (like a link without <inertial>): masses 2 and 1.5 +
    0.5 kg by hand, and inverse dynamics == Drake's plant of the file with those
    inertials removed; the warnings name the lumped and the ignored links."""
    path = _masses_urdf(tmp_path / "m.urdf")
    drake = urdf_plant(path)
    assert drake.GetBodyByName("marker").default_mass() == pytest.approx(1.0)
    assert drake.GetBodyByName("cover").default_mass() == 0.0
    with pytest.warns(UserWarning) as record:
        model = robot_from_urdf(path, base="base", tip="flange")
    text = " | ".join(str(w.message) for w in record)
    assert "beyond the tip 'flange' are lumped into link 2" in text
    assert "hand 0.5 kg" in text and "link(s) flange, marker: mass 0 with" in text
    np.testing.assert_allclose(model.dynamics[:, 9], [2.0, 2.0], rtol=1e-15)
    oracle = _masses_urdf(tmp_path / "oracle.urdf", massless=True)
    assert _id_error(oracle, "base", ["j_l1", "j_l2"], model, rng) < 1e-9
    path.write_text(path.read_text().replace('value="0.5"', 'value="-0.5"'))
    with pytest.raises(ValueError, match="link 'hand': <mass value> -0.5 is neg"):
        _import(path, "base", "flange")


def test_exclude_drops_the_subtree(tmp_path, rng):
    """--exclude hand drops hand and marker: == Drake's plant without them."""
    path = _masses_urdf(tmp_path / "m.urdf")
    model = _import_excluding(path, ["hand"])
    np.testing.assert_allclose(model.dynamics[:, 9], [2.0, 1.5], rtol=1e-15)
    oracle = _masses_urdf(tmp_path / "o.urdf", ("hand", "marker"), massless=True)
    assert _id_error(oracle, "base", ["j_l1", "j_l2"], model, rng) < 1e-9
    for links, message in ((["l2"], "link 'flange' is excluded"),
                           (["nope"], "no link 'nope' (--exclude)")):  # fmt: skip
        with pytest.raises(ValueError, match=re.escape(message)):
            _import_excluding(path, links)


def _import_excluding(path, links):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return robot_from_urdf(path, base="base", tip="flange", exclude=links)
