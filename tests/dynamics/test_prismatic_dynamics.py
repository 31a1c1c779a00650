"""Regressor oracle on chains mixing revolute and prismatic joints.

Y @ chi == Drake's CalcInverseDynamics (+ damping, reflected rotor inertia and
Coulomb friction) to 1e-9 relative to the largest effort of the batch, as for the
revolute arms in test_dynamics_regressor.py: both sides are exact rigid-body
dynamics in float64, so anything above round-off is a modelling difference (a
wrong twist, a missing Coriolis term 2 qd w x z, a rotor inertia on the wrong
coordinate). Chains come from the ``boom`` arm through MakePlant and from Drake
plants with prismatic joints on arbitrary axes between arbitrary joint frames,
built from Drake joints directly and from a URDF.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    PrismaticJoint,
    RevoluteJoint,
    RotationalInertia,
    SpatialInertia,
)
from test_dynamics_regressor import (
    assert_close,
    drake_inverse_dynamics,
    friction,
    random_states,
    write_urdf,
)

from rmdrake.dynamics import (
    SerialChain,
    plant_standard_parameters,
    random_standard_parameters,
    regressor,
    standard_parameters,
    torques,
    urdf_plant,
)
from rmdrake.model.plant import MakePlant


def test_boom_matches_drake(boom, rng):
    """MakePlant builds PrismaticJoints for joints 1 and 4; Ia on their
    actuators is a reflected mass, fv and fc act on m/s."""
    chain = SerialChain.from_model(boom)
    np.testing.assert_array_equal(chain.prismatic, [1, 0, 0, 1, 0, 0])
    q, qd, qdd = random_states(rng, 12, 6)
    chi = standard_parameters(boom)
    plant, _ = MakePlant(boom, visual=False)
    ref = drake_inverse_dynamics(plant, q, qd, qdd) + friction(chi, qd)
    assert_close(regressor(boom, q, qd, qdd) @ chi, ref)


def test_boom_random_parameters_match_drake(boom, rng):
    for _ in range(3):
        chi = random_standard_parameters(6, rng)
        m = dataclasses.replace(boom.with_dynamics(chi.reshape(6, 13)), payload=None)
        q, qd, qdd = random_states(rng, 6, 6, scale=3.0)
        plant, _ = MakePlant(m, visual=False)
        ref = drake_inverse_dynamics(plant, q, qd, qdd) + friction(chi, qd)
        assert_close(torques(m, q, qd, qdd, chi), ref)


def test_boom_from_plant_equals_from_model(boom, rng):
    plant, _ = MakePlant(boom, visual=False)
    chain = SerialChain.from_plant(plant)
    np.testing.assert_array_equal(chain.prismatic, boom.sigma == 1)
    q, qd, qdd = random_states(rng, 5, 6)
    np.testing.assert_allclose(
        regressor(chain, q, qd, qdd), regressor(boom, q, qd, qdd), atol=1e-12
    )
    # MakePlant: Ia on the actuator (gear ratio 1), no damping, no Coulomb.
    want = standard_parameters(boom).reshape(6, 13).copy()
    want[:, 11:] = 0.0
    np.testing.assert_allclose(
        plant_standard_parameters(plant), want.ravel(), rtol=1e-12, atol=1e-14
    )


def _random_inertia(rng) -> SpatialInertia:
    m = rng.uniform(0.5, 5.0)
    s = m * rng.uniform(0.005, 0.05, 3)
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    I = Q @ np.diag([s[1] + s[2], s[0] + s[2], s[0] + s[1]]) @ Q.T  # noqa: E741
    central = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    return SpatialInertia.MakeFromCentralInertia(m, rng.uniform(-0.3, 0.3, 3), central)


def _pose(rng) -> RigidTransform:
    return RigidTransform(
        RollPitchYaw(rng.uniform(-np.pi, np.pi, 3)), rng.uniform(-0.3, 0.3, 3)
    )


def drake_arm(rng, kinds: str) -> MultibodyPlant:
    """A serial arm built from Drake joints: ``kinds`` one letter per joint (R
    revolute, P prismatic), each on a random unit axis between random frames F
    (on the parent body) and M (on the child body), with damping, an actuator
    with rotor inertia and gear ratio, a body welded to link 2, and gravity in
    a random direction."""
    plant = MultibodyPlant(0.0)
    parent = plant.world_body()
    for j, kind in enumerate(kinds, start=1):
        body = plant.AddRigidBody(f"l{j}", _random_inertia(rng))
        F = plant.AddFrame(FixedOffsetFrame(f"F{j}", parent.body_frame(), _pose(rng)))
        M = plant.AddFrame(FixedOffsetFrame(f"M{j}", body.body_frame(), _pose(rng)))
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        damping = rng.uniform(0.1, 2.0)
        if kind == "P":
            joint = PrismaticJoint(f"j{j}", F, M, axis, damping=damping)
        else:
            joint = RevoluteJoint(f"j{j}", F, M, axis, damping)
        joint = plant.AddJoint(joint)
        act = plant.AddJointActuator(f"a{j}", joint)
        act.set_default_rotor_inertia(rng.uniform(1e-4, 1e-3))
        act.set_default_gear_ratio(rng.uniform(5.0, 50.0))
        if j == 2:
            extra = plant.AddRigidBody("extra", _random_inertia(rng))
            plant.WeldFrames(body.body_frame(), extra.body_frame(), _pose(rng))
        parent = body
    g = rng.standard_normal(3)
    plant.mutable_gravity_field().set_gravity_vector(9.81 * g / np.linalg.norm(g))
    plant.Finalize()
    return plant


@pytest.mark.parametrize("kinds", ["PRRPRR", "RPPR", "PPP", "RPRPRP"])
def test_drake_arm_with_prismatic_joints_on_any_axis(kinds, rng):
    plant = drake_arm(rng, kinds)
    chain = SerialChain.from_plant(plant)
    np.testing.assert_array_equal(chain.prismatic, [k == "P" for k in kinds])
    chi = plant_standard_parameters(plant)  # reflected Ia, fv = damping, fc = 0
    n = len(kinds)
    assert chi[10::13].min() > 1e-3 and chi[12::13].max() == 0.0
    q, qd, qdd = random_states(rng, 8, n)
    ref = drake_inverse_dynamics(plant, q, qd, qdd)
    idx = list(chain.q_indices)
    tau = regressor(chain, q[:, idx], qd[:, idx], qdd[:, idx]) @ chi
    assert_close(tau, ref[:, idx])


def test_urdf_arm_with_prismatic_joints_matches_drake(tmp_path, rng):
    path = tmp_path / "arm.urdf"
    write_urdf(path, rng, 5, joint_type=["prismatic", "revolute", "prismatic",
                                         "revolute", "prismatic"])  # fmt: skip
    plant = urdf_plant(path, gravity=np.array([0.3, -2.0, -9.5]))
    chain = SerialChain.from_plant(plant)
    assert SerialChain.from_urdf(path).prismatic.tolist() == chain.prismatic.tolist()
    np.testing.assert_array_equal(chain.prismatic, [1, 0, 1, 0, 1])
    chi = plant_standard_parameters(plant)
    q, qd, qdd = random_states(rng, 8, 5)
    ref = drake_inverse_dynamics(plant, q, qd, qdd)
    idx = list(chain.q_indices)
    assert_close(regressor(chain, q[:, idx], qd[:, idx], qdd[:, idx]) @ chi,
                 ref[:, idx])  # fmt: skip


def test_prismatic_flags_are_checked(boom):
    chain = SerialChain.from_model(boom)
    with pytest.raises(ValueError, match="prismatic: expected 6 flags"):
        dataclasses.replace(chain, prismatic=[0, 1, 2, 0, 0, 0])
    with pytest.raises(ValueError, match="prismatic: expected 6 flags"):
        dataclasses.replace(chain, prismatic=[0, 1])
    assert not SerialChain(
        chain.X_PF, chain.axis, chain.X_CM, chain.gravity,
        chain.joint_names, chain.link_names,
    ).prismatic.any()  # fmt: skip
