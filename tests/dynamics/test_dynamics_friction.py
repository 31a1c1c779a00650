"""One friction law: the simulator's JointFriction and the regressor's friction
columns both equal rmdrake.dynamics.friction.friction_torque."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from rmdrake.dynamics import SerialChain, regressor, standard_parameters
from rmdrake.dynamics.friction import DEFAULT_V_EPS, coulomb_sign, friction_torque
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.systems.friction import JointFriction

FV = np.array([2.0, 0.5, 1.0])  # N m s/rad
FC = np.array([3.0, 1.0, 0.7])  # N m
# Velocities near and far from the reversal, where tanh and sign differ.
V = np.array([[0.3, -2e-3, 0.0], [-1.5, 4e-4, 1e-5], [0.0, 0.0, -0.2]])


def test_law():
    assert DEFAULT_V_EPS == 1e-3
    np.testing.assert_array_equal(coulomb_sign(V), np.sign(V))
    np.testing.assert_array_equal(coulomb_sign(V, 1e-3), np.tanh(V / 1e-3))
    np.testing.assert_array_equal(
        friction_torque(V, FV, FC, 2e-3), FV * V + FC * np.tanh(V / 2e-3)
    )
    assert friction_torque(0.0, 1.0, 1.0) == 0.0  # sign(0) = 0: at rest
    for bad in (-1e-3, np.nan, np.inf):
        with pytest.raises(ValueError, match="width >= 0 in rad/s"):
            coulomb_sign(V, bad)


@pytest.mark.parametrize("exact_sign", [False, True])
@pytest.mark.parametrize("input", ["state", "v"])
def test_joint_friction_equals_friction_torque(exact_sign, input):
    v_eps = 2e-3
    width = 0.0 if exact_sign else v_eps
    friction = JointFriction(
        fv=FV, fc=FC, v_eps=v_eps, exact_sign=exact_sign, input=input
    )
    assert friction.get_input_port().get_name() == input
    ctx = friction.CreateDefaultContext()
    for v in V:
        u = np.r_[np.ones(3), v] if input == "state" else v
        friction.get_input_port().FixValue(ctx, u)
        np.testing.assert_array_equal(
            friction.get_output_port().Eval(ctx), -friction_torque(v, FV, FC, width)
        )


@pytest.mark.parametrize("width", [0.0, DEFAULT_V_EPS])
def test_regressor_friction_columns_equal_friction_torque(width):
    model = load_robot("rv3sb")
    chain = SerialChain.from_model(model)
    rng = np.random.default_rng(4)
    q, qd, qdd = (rng.uniform(-2, 2, (50, 6)) for _ in range(3))
    qd[:10] *= 1e-3  # near the reversal
    qd[10, 2] = 0.0
    chi = standard_parameters(model)
    Y = regressor(chain, q, qd, qdd, coulomb_width=width)
    friction_only = np.zeros_like(chi)
    friction_only[11::13], friction_only[12::13] = chi[11::13], chi[12::13]
    expected = friction_torque(qd, chi[11::13], chi[12::13], width)
    # A BLAS product against the law evaluated directly: a few ulp.
    np.testing.assert_allclose(Y @ friction_only, expected, rtol=1e-13, atol=1e-15)
    assert np.abs(expected).max() > 0.1  # the check is not vacuous


def test_add_to_builder_wires_the_plant():
    """AddToBuilder: plant.state -> friction -> plant.applied_generalized_force,
    the joint velocities found by index in the plant's state."""
    model = load_robot("rv3sb")
    fv, fc = model.dynamics[:, 11], model.dynamics[:, 12]
    builder = DiagramBuilder()
    plant, _ = MakePlant(model, builder=builder, time_step=0.0, visual=False)
    friction = JointFriction.AddToBuilder(builder, plant, fv=fv, fc=fc)
    assert friction.get_name() == "friction"
    np.testing.assert_array_equal(friction.velocity_indices, np.arange(6))
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    v = np.linspace(-0.5, 0.5, 6) * 1e-2
    plant.SetVelocities(plant.GetMyMutableContextFromRoot(ctx), v)
    out = friction.get_output_port().Eval(friction.GetMyContextFromRoot(ctx))
    np.testing.assert_array_equal(out, -friction_torque(v, fv, fc, DEFAULT_V_EPS))
    # The plant's force input is driven by the friction system.
    port = plant.get_applied_generalized_force_input_port()
    assert diagram.connection_map()[(plant, port.get_index())] == (
        friction,
        friction.get_output_port().get_index(),
    )
    with pytest.raises(ValueError, match="expected 2 friction joints"):
        JointFriction.AddToBuilder(DiagramBuilder(), plant, fv=fv[:2], fc=fc[:2])

    # Named joints: friction on joints 2 and 5 only, zero force elsewhere.
    builder = DiagramBuilder()
    plant, _ = MakePlant(model, builder=builder, time_step=0.0, visual=False)
    friction = JointFriction.AddToBuilder(
        builder, plant, fv=fv[[1, 4]], fc=fc[[1, 4]], joints=["joint2", "joint5"]
    )
    np.testing.assert_array_equal(friction.velocity_indices, [1, 4])
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    plant.SetVelocities(plant.GetMyMutableContextFromRoot(ctx), v)
    out = friction.get_output_port().Eval(friction.GetMyContextFromRoot(ctx))
    want = np.zeros(6)
    want[[1, 4]] = -friction_torque(v[[1, 4]], fv[[1, 4]], fc[[1, 4]], 1e-3)
    np.testing.assert_array_equal(out, want)


def test_index_map_on_a_larger_state():
    """Friction joints at velocities 1 and 3 of nq = 5, nv = 4 (e.g. elastic
    joints or a quaternion): force only there, zero elsewhere."""
    friction = JointFriction(
        fv=FV[:2], fc=FC[:2], velocity_indices=[1, 3], num_positions=5,
        num_velocities=4, exact_sign=True,
    )  # fmt: skip
    ctx = friction.CreateDefaultContext()
    v = np.array([9.0, -0.2, 9.0, 0.4])
    friction.get_input_port().FixValue(ctx, np.r_[np.full(5, 7.0), v])
    want = np.zeros(4)
    want[[1, 3]] = -friction_torque(v[[1, 3]], FV[:2], FC[:2])
    np.testing.assert_array_equal(friction.get_output_port().Eval(ctx), want)
    with pytest.raises(ValueError, match="velocity_indices: expected 2 distinct"):
        JointFriction(fv=FV[:2], fc=FC[:2], velocity_indices=[1, 1])
    with pytest.raises(TypeError):
        JointFriction(FV, FC)  # keyword-only
