"""MakePlant with elastic joints: motor side, spring, link side, against the
static deflection model (rmdrake.dynamics.compliance) and the MDH forward kinematics."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.tree import ForceElementIndex, PrismaticSpring, RevoluteSpring

from rmdrake.dynamics.compliance import gravity_torques, link_angles
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import (
    TOOL_FRAME,
    MakePlant,
    joint_name,
    link_joint_name,
    link_name,
    rotor_name,
)
from rmdrake.model.robot import DYNAMIC_KEYS, Compliance, RobotModel

# demo_rh's elastic variant (N m/rad): tool deflection of tens of mm under 4.5 t.
DEMO_K = np.array([1e8, 5e7, 2.5e7, 1e7, 1e7, 5e6])


def elastic(model: RobotModel, stiffness, damping=None) -> RobotModel:
    return dataclasses.replace(model, compliance=Compliance(stiffness, damping))


@pytest.fixture
def demo() -> RobotModel:
    return elastic(load_robot("demo_rh"), DEMO_K)


def _boom(boom: RobotModel) -> RobotModel:
    """The prismatic test arm, joints 1 (slide, N/m) and 3, 4 (slide) elastic."""
    return elastic(boom, [2e5, 0.0, 3e3, 1e5, 0.0, 0.0])


def _set(plant, context, model, q_m, q_l) -> None:
    """Motor side q_m, link side q_l (deflection q_l - q_m on elastic joints)."""
    q = np.zeros(plant.num_positions())
    for j in range(1, model.n_joints + 1):
        q[plant.GetJointByName(joint_name(j)).position_start()] = q_m[j - 1]
        if plant.HasJointNamed(link_joint_name(j)):
            link = plant.GetJointByName(link_joint_name(j))
            q[link.position_start()] = q_l[j - 1] - q_m[j - 1]
    plant.SetPositions(context, q)


def _poses(model: RobotModel, rng, count: int) -> np.ndarray:
    lo, hi = model.limits.lower, model.limits.upper
    return rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (count, len(lo)))


@pytest.mark.parametrize("which", ["demo", "boom"])
def test_rest_state_is_an_equilibrium(which, demo, boom, rng) -> None:
    """(a) at q_l = link_angles(q_m), zero speed, actuation -tau(q_l): the
    accelerations are zero; with the link side undeflected they are not."""
    model = demo if which == "demo" else _boom(boom)
    plant, _ = MakePlant(model, visual=False)
    context = plant.CreateDefaultContext()
    acc = plant.get_generalized_acceleration_output_port()
    for q_m in _poses(model, rng, 3):
        q_l = link_angles(model, q_m)
        tau = gravity_torques(model, q_l)
        _set(plant, context, model, q_m, q_l)
        plant.get_actuation_input_port().FixValue(context, -tau)
        scale = np.max(np.abs(tau) / model.dynamics[:, DYNAMIC_KEYS.index("Ia")])
        assert np.max(np.abs(acc.Eval(context))) < 1e-7 * scale
        _set(plant, context, model, q_m, q_m)  # undeflected: the spring is slack
        assert np.max(np.abs(acc.Eval(context))) > 1e-3 * scale


def test_link_frames_follow_the_link_side(demo, rng) -> None:
    """(b) the tool (and link j) frames at rest are the MDH kinematics at q_l."""
    plant, _ = MakePlant(demo, visual=False)
    context = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    for q_m in _poses(demo, rng, 3):
        q_l = link_angles(demo, q_m)
        _set(plant, context, demo, q_m, q_l)
        X = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
        T = tool_poses(demo.table, q_l, sigma=demo.sigma)[0]
        np.testing.assert_allclose(X.GetAsMatrix4(), T, atol=1e-12)
        assert np.linalg.norm(T[:3, 3] - tool_poses(demo.table, q_m)[0, :3, 3]) > 1e-3


def test_structure_springs_and_damping(boom) -> None:
    model = _boom(boom)
    plant, _ = MakePlant(model, visual=False)
    elastic_joints = np.flatnonzero(model.compliance.elastic) + 1
    assert plant.num_positions() == model.n_joints + elastic_joints.size
    assert plant.num_actuators() == model.n_joints
    springs = {
        plant.get_force_element(ForceElementIndex(i))
        .joint()
        .name(): plant.get_force_element(ForceElementIndex(i))
        for i in range(plant.num_force_elements())
        if isinstance(
            plant.get_force_element(ForceElementIndex(i)),
            PrismaticSpring | RevoluteSpring,
        )
    }
    assert set(springs) == {link_joint_name(j) for j in elastic_joints}
    for j in elastic_joints:
        motor = plant.GetJointByName(joint_name(j))
        link = plant.GetJointByName(link_joint_name(j))
        assert motor.child_body().name() == rotor_name(j)
        assert link.parent_body().name() == rotor_name(j)
        assert link.child_body().name() == link_name(j)
        assert type(link) is type(motor)
        assert link.default_damping() == model.compliance.damping[j - 1]
        spring = springs[link.name()]
        if isinstance(spring, RevoluteSpring):
            k, q0 = spring.default_stiffness(), spring.default_nominal_angle()
        else:
            k, q0 = spring.stiffness(), spring.nominal_position()
        assert (k, q0) == (model.compliance.stiffness[j - 1], 0.0)
        assert (
            plant.GetJointActuatorByName(joint_name(j)).joint().name() == motor.name()
        )


def test_zero_stiffness_builds_the_rigid_plant(demo, rng) -> None:
    """(c) all-zero stiffness: the same plant as without compliance."""
    rigid = dataclasses.replace(demo, compliance=None)
    zero = elastic(rigid, np.zeros(6))
    plants = [MakePlant(m, visual=False)[0] for m in (rigid, zero)]
    assert [p.num_positions() for p in plants] == [6, 6]
    assert [p.num_bodies() for p in plants] == [plants[0].num_bodies()] * 2
    contexts = [p.CreateDefaultContext() for p in plants]
    for q in _poses(demo, rng, 2):
        M, g = [], []
        for p, c in zip(plants, contexts, strict=True):
            p.SetPositions(c, q)
            M.append(p.CalcMassMatrix(c))
            g.append(p.CalcGravityGeneralizedForces(c))
        np.testing.assert_array_equal(M[0], M[1])
        np.testing.assert_array_equal(g[0], g[1])


def test_elastic_joint_needs_rotor_inertia(demo) -> None:
    dyn = np.array(demo.dynamics)
    dyn[2, DYNAMIC_KEYS.index("Ia")] = 0.0
    with pytest.raises(ValueError, match="elastic joint 3 .* rotor inertia"):
        MakePlant(demo.with_dynamics(dyn), visual=False)
    dyn[2, DYNAMIC_KEYS.index("Ia")] = 1.0
    dyn[0, DYNAMIC_KEYS.index("Ia")] = 0.0  # rigid joints need none
    partly = elastic(demo.with_dynamics(dyn), [0.0, 5e7, 2.5e7, 0.0, 0.0, 0.0])
    plant, _ = MakePlant(partly, visual=False)
    assert plant.num_positions() == 8
