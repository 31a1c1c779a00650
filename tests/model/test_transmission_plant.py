"""The Drake plant of a geared arm with a coupled wrist (issue 41).

Oracle: Drake's own inverse dynamics and mass matrix of the plant with the
coupled motor's chain, restricted to the arm's joints by the coupler
constraints (stage (m, j) at c_mj q_j, so tau = G^T ID(G q, G qd, G qdd)),
against the regressor with the coupled motor's Iam (round-off): the two share
no code (the regressor's columns are numpy, the plant's are Drake's bodies,
reflected inertias and joints).
"""

from __future__ import annotations

import re

import numpy as np
from pydrake.multibody.tree import JointIndex, MultibodyForces

from rmdrake.dynamics import regressor
from rmdrake.model.dynamic_parameters import extended_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import (
    MakePlant,
    coupled_rotors_on_diagonal,
    set_coupled_motor_state,
)


def _lift(plant, model) -> np.ndarray:
    """(nq, n) G with q_plant = G q: joint j at q_j, stage motor<m>_joint<j>
    at c_mj q_j (named by the plant's joints, not by its construction)."""
    C = model.transmission.coupling
    G = np.zeros((plant.num_positions(), model.n_joints))
    for i in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(i))
        k = joint.position_start()
        if m := re.fullmatch(r"joint(\d+)", joint.name()):
            G[k, int(m[1]) - 1] = 1.0
        elif m := re.fullmatch(r"motor(\d+)_joint(\d+)", joint.name()):
            motor, j = int(m[1]) - 1, int(m[2]) - 1
            G[k, j] = C[motor, j]
    return G


def test_coupled_wrist_plant_matches_the_regressor():
    """G^T ID(G q, G qd, G qdd) of the discrete plant == Y @ chi with the
    coupled motor's Iam, friction off (the plant has no joint damping),
    to 1e-12 relative; its mass matrix has Iam off the diagonal of joints 5
    and 6; the actuators carry the gear ratios with Ia / n^2."""
    model = load_robot("rv3sb_geared")
    plant, _ = MakePlant(model, time_step=1e-3, visual=False)
    assert plant.num_positions() == 8 and plant.num_actuators() == 6
    G = _lift(plant, model)
    np.testing.assert_array_equal(G[6:], [[0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]])
    ctx = plant.CreateDefaultContext()
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.uniform(-2, 2, (3, 8, 6))
    ref = []
    for a, v, acc in zip(q, qd, qdd, strict=True):
        plant.SetPositions(ctx, G @ a)
        plant.SetVelocities(ctx, G @ v)
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, forces)
        ref.append(G.T @ plant.CalcInverseDynamics(ctx, G @ acc, forces))
    ref = np.array(ref)
    chi = extended_parameters(model)
    n = 6
    chi[11 : 13 * n : 13] = chi[12 : 13 * n : 13] = 0.0  # fv, fc
    chi[13 * n : 15 * n] = 0.0  # fcn, tau0
    chi[-2:] = 0.0  # fvm6, fcm6
    tau = regressor(model, q, qd, qdd, np.arange(chi.size)) @ chi
    err = np.abs(tau - ref).max() / np.abs(ref).max()
    assert err < 1e-12, f"relative error {err:.3g}"
    M = G.T @ plant.CalcMassMatrix(ctx) @ G
    Iam = model.motor_terms[0, 0]
    plant_no_motor, _ = MakePlant(
        coupled_rotors_on_diagonal(model), time_step=0.0, visual=False
    )
    for j, ratio in enumerate(model.transmission.ratio, start=1):
        actuator = plant.GetJointActuatorByName(f"joint{j}")
        assert actuator.default_gear_ratio() == ratio
    # The continuous plant of coupled_rotors_on_diagonal has no coupled motor:
    # the off-diagonal Iam is the difference (the diagonal Iam c^2 is on its
    # joints' reflected inertia).
    ctx2 = plant_no_motor.CreateDefaultContext()
    plant_no_motor.SetPositions(ctx2, q[-1])
    M2 = plant_no_motor.CalcMassMatrix(ctx2)
    expected = np.zeros((6, 6))
    expected[4, 5] = expected[5, 4] = Iam
    np.testing.assert_allclose(M - M2, expected, rtol=0, atol=1e-13)


def test_coupled_motor_state_holds_the_constraints():
    """set_coupled_motor_state puts the stages at c_mj q_j, c_mj qd_j."""
    model = load_robot("rv3sb_geared")
    plant, _ = MakePlant(model, time_step=1e-3, visual=False)
    ctx = plant.CreateDefaultContext()
    q, v = np.zeros(8), np.zeros(8)
    q[:6], v[:6] = np.arange(1, 7) * 0.1, np.arange(1, 7) * -0.2
    plant.SetPositions(ctx, q)
    plant.SetVelocities(ctx, v)
    set_coupled_motor_state(plant, ctx, model)
    G = _lift(plant, model)
    np.testing.assert_allclose(plant.GetPositions(ctx), G @ q[:6], atol=1e-15)
    np.testing.assert_allclose(plant.GetVelocities(ctx), G @ v[:6], atol=1e-15)
