"""The static deflection model of elastic joints, against Drake's gravity."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.dynamics.compliance import (
    DRAKE_POSES,
    gravity_torques,
    link_angles,
    lowest_structural_mode,
    motor_angles,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import Compliance, Payload, RobotModel

STIFFNESS = np.array([2e8, 1e8, 5e7, 2e7, 2e7, 1e7])  # N m/rad


def _elastic(stiffness: np.ndarray = STIFFNESS) -> RobotModel:
    return dataclasses.replace(load_robot("demo_rh"), compliance=Compliance(stiffness))


def _poses(model: RobotModel, count: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(model.limits.lower, model.limits.upper, (count, model.n_joints))


@pytest.mark.parametrize("mass", [0.0, 1234.5, 4500.0])
def test_gravity_torques_are_drakes(mass):
    """tau(q, m) equals MultibodyPlant.CalcGravityGeneralizedForces of a plant
    whose payload has mass m at the model's payload centre of mass."""
    model = load_robot("demo_rh")
    pl = model.payload
    loaded = dataclasses.replace(model, payload=Payload(mass, pl.p_EPcm, pl.inertia))
    plant, _ = MakePlant(loaded, visual=False)
    context = plant.CreateDefaultContext()
    q = _poses(model, DRAKE_POSES + 1)  # more than Drake's path takes
    want = []
    for qi in q:
        plant.SetPositions(context, qi)
        want.append(plant.CalcGravityGeneralizedForces(context))
    got = gravity_torques(model, q, mass)  # the vectorised statics
    np.testing.assert_allclose(got, np.array(want), rtol=0, atol=1e-9 * 3e5)
    np.testing.assert_allclose(gravity_torques(model, q[0], mass), want[0], atol=3e-4)


def test_payload_mass_per_pose():
    model = load_robot("demo_rh")
    # A batch (the vectorised statics) against one pose at a time (Drake's plant).
    q = _poses(model, 4 * (DRAKE_POSES // 4 + 1))
    m = np.resize([0.0, 4500.0, 2250.0, 0.0], q.shape[0])
    got = gravity_torques(model, q, m)
    for i in range(q.shape[0]):
        np.testing.assert_allclose(
            got[i], gravity_torques(model, q[i], m[i]), rtol=1e-12, atol=1e-9
        )


def test_link_angles_balance_the_springs():
    """At rest k (q_m - q_l) = tau(q_l), and motor_angles inverts link_angles."""
    model = _elastic()
    q_m = _poses(model, 20, seed=1)
    q_l = link_angles(model, q_m, 4500.0)
    tau = gravity_torques(model, q_l, 4500.0)
    np.testing.assert_allclose(STIFFNESS * (q_l - q_m), tau, rtol=0, atol=1e-6)
    np.testing.assert_allclose(motor_angles(model, q_l, 4500.0), q_m, atol=1e-12)
    sag = np.abs(q_l - q_m).max(axis=0)
    assert sag[1] > 1e-3 and sag[0] < 1e-12  # joint 2 sags, joint 1 (vertical) not


def test_rigid_model_does_not_deflect():
    model = load_robot("demo_rh")
    q = _poses(model, 3)
    np.testing.assert_array_equal(link_angles(model, q), q)
    np.testing.assert_array_equal(motor_angles(model, q), q)
    with pytest.raises(ValueError, match="no elastic joint"):
        lowest_structural_mode(model, q[0])


def test_bad_input():
    model = _elastic()
    q = _poses(model, 2)
    with pytest.raises(ValueError, match="payload: expected masses >= 0"):
        gravity_torques(model, q, [-1.0, 0.0])
    with pytest.raises(ValueError, match="expected 2 masses"):
        gravity_torques(model, q, [1.0, 2.0, 3.0])
    bare = dataclasses.replace(model, payload=None)
    with pytest.raises(ValueError, match="has no payload entry"):
        gravity_torques(bare, q, 10.0)
    soft = _elastic(STIFFNESS * 1e-4)
    with pytest.raises(ValueError, match="did not converge|stiffness too low"):
        link_angles(soft, q, 4500.0)
    for bad in ([1.0, -1.0, 0, 0, 0, 0], [1.0, np.inf, 0, 0, 0, 0]):
        with pytest.raises(ValueError, match="compliance.stiffness"):
            Compliance(np.array(bad))


def test_yaml_round_trip_and_rigid_when_zero():
    model = _elastic()
    again = RobotModel.from_dict(model.to_dict())
    np.testing.assert_array_equal(again.compliance.stiffness, STIFFNESS)
    np.testing.assert_allclose(again.compliance.damping, 0.01 * STIFFNESS)
    data = model.to_dict()
    data["compliance"] = {"stiffness": [0.0] * 6}
    assert RobotModel.from_dict(data).compliance is None
    data["compliance"] = {"stiffness": [1.0] * 6, "dampin": [0.0] * 6}
    with pytest.raises(ValueError, match="compliance: expected a mapping"):
        RobotModel.from_dict(data)


def test_lowest_mode_is_a_single_joint_oscillator():
    """One elastic joint: w^2 = (k - d tau/dq) / M_jj, with M_jj from Drake
    (no rotor inertia) and the gravity stiffness by finite differences."""
    model = load_robot("demo_rh")
    k = np.zeros(6)
    k[1] = 1e8
    model = dataclasses.replace(model, compliance=Compliance(k))
    q_m = np.array([0.2, 0.4, 0.8, 0.1, 0.5, 0.0])
    w = lowest_structural_mode(model, q_m, 0.0)
    q_l = link_angles(model, q_m, 0.0)
    h = 1e-5
    e = np.eye(6)[1] * h
    dtau = (
        gravity_torques(model, q_l + e, 0.0)[1]
        - gravity_torques(model, q_l - e, 0.0)[1]
    ) / (2 * h)
    dyn = np.array(model.dynamics)
    dyn[:, 10] = 0.0
    rigid = dataclasses.replace(model, dynamics=dyn, compliance=None, payload=None)
    plant, _ = MakePlant(rigid, visual=False)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q_l)
    M22 = plant.CalcMassMatrix(context)[1, 1]
    assert w == pytest.approx(np.sqrt((1e8 - dtau) / M22), rel=1e-6)
    assert lowest_structural_mode(model, q_m, 4500.0) < w  # the payload lowers it


def test_shipped_elastic_arm_is_demo_rh_with_compliance():
    """demo_rh_elastic.yaml repeats demo_rh.yaml: everything but the name and the
    compliance section must stay equal, and the deflection under the 4.5 t
    payload is in the tens of millimetres the paper speaks of."""
    elastic, rigid = load_robot("demo_rh_elastic"), load_robot("demo_rh")
    a, b = elastic.to_dict(), rigid.to_dict()
    assert a.pop("name") == "demo_rh_elastic" and "compliance" in a
    a.pop("compliance"), b.pop("name")
    assert a == b
    q = _poses(elastic, 200, seed=3)
    from rmdrake.kinematics.forward import tool_points

    p0 = tool_points(elastic.table, q)
    p1 = tool_points(elastic.table, link_angles(elastic, q))
    mean = np.linalg.norm(p1 - p0, axis=1).mean()
    assert 0.01 < mean < 0.3  # m


def test_urdf_export_of_an_elastic_robot_warns():
    from rmdrake.model.urdf.importer import robot_to_urdf

    with pytest.warns(UserWarning, match="compliance is not written"):
        text = robot_to_urdf(load_robot("demo_rh_elastic"))
    assert "<robot" in text
