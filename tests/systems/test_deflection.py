"""Deflection compensation of elastic joints: the pre-deflected command puts the
link side where it was asked (the inverse of compliance.link_angles), its rates
are the time derivatives of the pre-deflection, and the controllers wire it in
(or refuse an elastic model when they assume rigid joints)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from rmdrake.compensation.correction import filter_program
from rmdrake.dynamics.compliance import gravity_torques, link_angles, motor_angles
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Compliance
from rmdrake.systems.controllers import (
    CalibratedCompensationController,
    NominalController,
)
from rmdrake.systems.deflection import DeflectionCompensation, motor_motion
from rmdrake.systems.station_config import (
    AddController,
    CompensationControllerConfig,
    ControllerInputs,
    InverseDynamicsControllerConfig,
    PidControllerConfig,
)

# demo_rh poses away from its singularities (rad).
Q = np.array(
    [[0.1, 0.3, 0.6, 0.2, 0.7, 0.1], [-0.4, 0.6, 0.3, -0.5, 1.0, 0.4],
     [0.8, 0.1, 1.0, 0.3, -0.6, -0.2]]
)  # fmt: skip
STIFFNESS = np.array([3e8, 1e8, 1.5e8, 5e7, 4e7, 2e7])  # N m/rad


@pytest.fixture(scope="module")
def nominal():
    return load_robot("demo_rh")


@pytest.fixture(scope="module")
def elastic(nominal):
    """demo_rh with geometric errors (mm, mrad) and elastic joints: the
    elastostatic calibration's kind of result."""
    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(3).standard_normal(len(names))
    calibrated = apply_deltas(nominal, names, deltas)
    return dataclasses.replace(calibrated, compliance=Compliance(STIFFNESS))


def _evaluate(system, context, q, v, a, mass):
    n = q.size
    system.GetInputPort("desired_state").FixValue(context, np.r_[q, v])
    system.GetInputPort("desired_acceleration").FixValue(context, a)
    system.GetInputPort("payload_mass").FixValue(context, [mass])
    x = system.GetOutputPort("commanded_state").Eval(context)
    return x[:n], x[n:], system.GetOutputPort("commanded_acceleration").Eval(context)


@pytest.mark.parametrize("mass", [0.0, 2250.0, 4500.0])
def test_pre_deflection_is_the_inverse_of_link_angles(elastic, mass):
    """The system's q_m, left to sag under gravity and the payload
    (compliance.link_angles), comes back to the commanded link side."""
    system = DeflectionCompensation(model=elastic)
    context = system.CreateDefaultContext()
    for q in Q:
        q_m, _, _ = _evaluate(system, context, q, 0 * q, 0 * q, mass)
        assert np.abs(link_angles(elastic, q_m, mass) - q).max() < 1e-12
        assert np.abs(q_m - q).max() > 1e-4  # a real pre-deflection (0.1 mrad+)


def test_rates_are_the_time_derivatives_of_the_pre_deflection(elastic):
    """v_m - v_l, a_m - a_l along a smooth link-side motion = central
    differences in time (step 1e-3 s) of the pre-deflection
    q_m(t) - q_l(t) = motor_angles(q_l(t)) - q_l(t)."""
    w = np.array([0.7, 0.5, 0.9, 1.3, 1.1, 1.7])  # rad/s
    amp = np.array([0.4, 0.3, 0.3, 0.5, 0.4, 0.6])  # rad

    def q_l(t):
        return Q[0] + amp * np.sin(w * t)

    ts = np.linspace(0.0, 3.0, 7)[:, None]
    v = amp * w * np.cos(w * ts)
    a = -amp * w * w * np.sin(w * ts)
    q_m, v_m, a_m = motor_motion(elastic, q_l(ts), v, a, 4500.0)
    h = 1e-3
    d = [motor_angles(elastic, q_l(ts + s), 4500.0) - q_l(ts + s) for s in (-h, 0, h)]
    dv = (d[2] - d[0]) / (2 * h)
    da = (d[2] - 2 * d[1] + d[0]) / h**2
    # Two computations of the same pre-deflection: a few ulp of the 1 rad scale.
    np.testing.assert_allclose(q_m - q_l(ts), d[1], rtol=0, atol=1e-14)
    # The pre-deflection rates (up to mrad/s): to 1e-5 of their size (2e-7 seen).
    assert np.abs(dv).max() > 1e-4 and np.abs(da).max() > 1e-4
    assert np.abs(v_m - v - dv).max() < 1e-5 * np.abs(dv).max()
    assert np.abs(a_m - a - da).max() < 1e-5 * np.abs(da).max()


def test_payload_port_and_bad_models(elastic, nominal):
    system = DeflectionCompensation(model=elastic)
    context = system.CreateDefaultContext()
    q = Q[1]
    q0, _, _ = _evaluate(system, context, q, 0 * q, 0 * q, 0.0)
    q1, _, _ = _evaluate(system, context, q, 0 * q, 0 * q, 4500.0)
    c = elastic.compliance.compliances
    payload_only = gravity_torques(elastic, q, 4500.0) - gravity_torques(elastic, q, 0)
    np.testing.assert_allclose(q0 - q1, c * payload_only, rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="robot 'demo_rh' has no elastic joint"):
        DeflectionCompensation(model=nominal)
    with pytest.raises(ValueError, match="no 'dynamics' section"):
        DeflectionCompensation(model=dataclasses.replace(elastic, dynamics=None))


def test_compensation_controller_commands_the_pre_deflected_correction(
    nominal, elastic
):
    """The controller diagram alone: commanded_state = motor_angles(calibrated,
    the kinematically corrected q, payload), its rates the pre-deflected
    corrected rates; with deflection_compensation=False an elastic calibrated
    model is refused."""
    ctrl = CalibratedCompensationController(
        nominal=nominal, identified=nominal, calibrated=elastic
    )
    context = ctrl.CreateDefaultContext()
    q, v = Q[2], np.zeros(6)
    ctrl.GetInputPort("desired_state").FixValue(context, np.r_[q, v])
    ctrl.GetInputPort("desired_acceleration").FixValue(context, v)
    ctrl.GetInputPort("estimated_state").FixValue(context, np.r_[q, v])
    ctrl.GetInputPort("payload_mass").FixValue(context, [4500.0])
    Simulator(ctrl, context).Initialize()  # the correction's first solve
    x = ctrl.GetOutputPort("commanded_state").Eval(context)
    q_k = filter_program(nominal, elastic, q[None]).q[0]
    want = motor_angles(elastic, q_k, 4500.0)
    assert np.abs(x[:6] - want).max() < 1e-9
    assert np.abs(want - q_k).max() > 1e-3 and np.abs(q_k - q).max() > 1e-4
    with pytest.raises(ValueError, match="elastic") as info:
        CalibratedCompensationController(
            nominal=nominal,
            identified=nominal,
            calibrated=elastic,
            deflection_compensation=False,
        )
    assert "set deflection_compensation=True" in str(info.value)
    assert "\n" not in str(info.value)


def _inputs(model, **models):
    builder = DiagramBuilder()
    n = model.n_joints
    state = builder.AddSystem(ConstantVectorSource(np.r_[Q[0], np.zeros(n)]))
    accel = builder.AddSystem(ConstantVectorSource(np.zeros(n)))
    inputs = ControllerInputs(
        model=model,
        trajectory=None,
        joint_state=state.get_output_port(),
        desired_state=state.get_output_port(),
        desired_acceleration=accel.get_output_port(),
        v_eps=1e-3,
        **models,
    )
    return builder, inputs


def test_station_payload_mass_is_a_context_parameter(nominal, elastic):
    """CompensationControllerConfig wires a ConstantVectorSource 'payload_mass'
    (default: the calibrated model's 4.5 t); changing its value in the Context
    changes the pre-deflection to the new payload's."""
    builder, inputs = _inputs(nominal, calibrated=elastic, identified=nominal)
    config = CompensationControllerConfig(kinematic_correction=False)
    AddController(builder, config, inputs)
    ctrl = builder.GetSubsystemByName("controller")
    builder.ExportOutput(ctrl.GetOutputPort("commanded_state"), "commanded")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    source = diagram.GetSubsystemByName("payload_mass")
    mine = source.GetMyMutableContextFromRoot(context)
    assert source.get_source_value(mine).GetAtIndex(0) == 4500.0
    for mass in (4500.0, 1000.0, 0.0):
        source.get_mutable_source_value(mine).SetFromVector([mass])
        q_m = diagram.GetOutputPort("commanded").Eval(context)[:6]
        assert np.abs(q_m - motor_angles(elastic, Q[0], mass)).max() < 1e-14
    config = CompensationControllerConfig(kinematic_correction=False, payload_mass=-1)
    with pytest.raises(ValueError, match="controller.payload_mass: expected"):
        builder, inputs = _inputs(nominal, calibrated=elastic, identified=nominal)
        AddController(builder, config, inputs)


@pytest.mark.parametrize(
    "config", [InverseDynamicsControllerConfig(), PidControllerConfig()]
)
def test_rigid_joint_controllers_refuse_an_elastic_model(elastic, config):
    builder, inputs = _inputs(elastic)
    with pytest.raises(ValueError) as info:
        AddController(builder, config, inputs)
    message = str(info.value)
    assert message.startswith(f"controller: {type(config).__name__} model")
    assert "is elastic" in message and "CompensationControllerConfig" in message
    assert "\n" not in message
    with pytest.raises(ValueError, match="NominalController nominal: robot"):
        NominalController(nominal=elastic)


def test_offline_corrected_program_is_pre_deflected(nominal, elastic):
    """corrected_program on an elastic calibrated robot: the spline's knots are
    motor_angles of the kinematically corrected joints at the payload."""
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.systems.controllers import corrected_program

    program = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        [0.0, 1.0], Q[:2].T, np.zeros(6), np.zeros(6)
    )
    fixed = corrected_program(
        nominal, elastic, program, sample_period=0.5, payload_mass=2250.0
    )
    q = np.array([program.value(t).ravel() for t in (0.0, 0.5, 1.0)])
    want = motor_angles(elastic, filter_program(nominal, elastic, q).q, 2250.0)
    got = np.array([fixed.value(t).ravel() for t in (0.0, 0.5, 1.0)])
    assert np.abs(got - want).max() < 1e-9


@pytest.mark.parametrize("reference", [0.0, 1000.0])
def test_payload_effort_holds_the_mass_beyond_the_reference(elastic, reference):
    """Oracle: Drake's gravity forces of plants holding the two masses, at the
    link-side position (where the payload hangs)."""
    from rmdrake.model.plant import MakePlant

    system = DeflectionCompensation(model=elastic, reference_mass=reference)
    context = system.CreateDefaultContext()
    q = Q[1]
    forces = []
    for mass in (4500.0, reference):
        plant, _ = MakePlant(
            dataclasses.replace(
                elastic, compliance=None, payload=elastic.payload.with_mass(mass)
            ),
            visual=False,
        )
        plant_context = plant.CreateDefaultContext()
        plant.SetPositions(plant_context, q)
        forces.append(plant.CalcGravityGeneralizedForces(plant_context))
    _evaluate(system, context, q, np.zeros(6), np.zeros(6), 4500.0)
    effort = system.GetOutputPort("payload_effort").Eval(context)
    want = -(forces[0] - forces[1])  # holding = minus gravity's force
    np.testing.assert_allclose(effort, want, rtol=1e-9, atol=1e-6)
    _evaluate(system, context, q, np.zeros(6), np.zeros(6), reference)
    assert not system.GetOutputPort("payload_effort").Eval(context).any()
