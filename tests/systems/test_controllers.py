"""Controllers as Drake systems: the torque they output equals the regressor's
inverse dynamics of the model they know plus friction plus feedback, and they
compose into a user's diagram."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from rmdrake.dynamics import regressor, standard_parameters
from rmdrake.dynamics.friction import DEFAULT_V_EPS, friction_torque
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import DYNAMIC_KEYS
from rmdrake.systems.controllers import NominalController

FV, FC = DYNAMIC_KEYS.index("fv"), DYNAMIC_KEYS.index("fc")


def _expected(model, q, v, qd_d, v_d, a_d, kp, kd, friction=True):
    """Y(q, v, a_cmd) @ chi (no friction columns) + fv v_d + fc s(v_d)."""
    chi = standard_parameters(model).reshape(model.n_joints, -1).copy()
    chi[:, [FV, FC]] = 0.0
    a_cmd = a_d + kp * (qd_d - q) + kd * (v_d - v)
    tau = regressor(model, q, v, a_cmd) @ chi.ravel()
    if friction:
        dyn = model.dynamics
        tau = tau + friction_torque(v_d, dyn[:, FV], dyn[:, FC], DEFAULT_V_EPS)
    return tau


@pytest.mark.parametrize("friction", [True, False])
def test_nominal_controller_torque_is_inverse_dynamics_plus_feedback(rng, friction):
    model = load_robot("rv3sb")
    n = model.n_joints
    ctrl = NominalController(
        nominal=model, bandwidth=30.0, friction_feedforward=friction
    )
    context = ctrl.CreateDefaultContext()
    q, v = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    q_d, v_d, a_d = (
        q + 0.01 * rng.standard_normal(n),
        rng.uniform(-1, 1, n),
        rng.uniform(-2, 2, n),
    )
    ctrl.GetInputPort("estimated_state").FixValue(context, np.r_[q, v])
    ctrl.GetInputPort("desired_state").FixValue(context, np.r_[q_d, v_d])
    ctrl.GetInputPort("desired_acceleration").FixValue(context, a_d)
    tau = ctrl.GetOutputPort("actuation").Eval(context)
    w = 30.0
    want = _expected(model, q, v, q_d, v_d, a_d, 3 * w * w, 3 * w, friction)
    np.testing.assert_allclose(tau, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
    np.testing.assert_array_equal(
        ctrl.GetOutputPort("commanded_state").Eval(context), np.r_[q_d, v_d]
    )


def test_friction_feedforward_has_the_models_offsets_and_asymmetry(rng):
    """A model with fcn and tau0 (identified with offsets or asymmetric
    Coulomb friction): the feedforward is the friction law of
    friction_torque with both, so the station and validate use one model."""
    base = load_robot("rv3sb")
    n = base.n_joints
    fcn = base.dynamics[:, FC] * rng.uniform(0.5, 1.5, n)
    tau0 = rng.uniform(-0.5, 0.5, n)
    model = dataclasses.replace(base, fcn=fcn, tau0=tau0)
    ctrl = NominalController(nominal=model, bandwidth=30.0)
    context = ctrl.CreateDefaultContext()
    q, v = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    a_d = rng.uniform(-2, 2, n)
    for port, value in (
        ("estimated_state", np.r_[q, v]),
        ("desired_state", np.r_[q, v]),
    ):
        ctrl.GetInputPort(port).FixValue(context, value)
    ctrl.GetInputPort("desired_acceleration").FixValue(context, a_d)
    tau = ctrl.GetOutputPort("actuation").Eval(context)
    want = _expected(model, q, v, q, v, a_d, 0.0, 0.0, friction=False)
    dyn = model.dynamics
    want += friction_torque(
        v, dyn[:, FV], dyn[:, FC], DEFAULT_V_EPS, fcn=fcn, tau0=tau0
    )
    np.testing.assert_allclose(tau, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def test_nominal_controller_refuses_a_robot_without_dynamics():
    model = load_robot("rv3sb")
    import dataclasses

    bare = dataclasses.replace(model, dynamics=None)
    with pytest.raises(
        ValueError, match="nominal robot 'rv3sb': expected a 'dynamics'"
    ):
        NominalController(nominal=bare)


def test_add_to_builder_wires_the_given_ports():
    from pydrake.systems.primitives import ConstantVectorSource

    model = load_robot("rv3sb")
    n = model.n_joints
    builder = DiagramBuilder()
    x = builder.AddSystem(ConstantVectorSource(np.zeros(2 * n)))
    a = builder.AddSystem(ConstantVectorSource(np.zeros(n)))
    ctrl = NominalController.AddToBuilder(
        builder,
        desired_state=x.get_output_port(),
        desired_acceleration=a.get_output_port(),
        estimated_state=x.get_output_port(),
        nominal=model,
    )
    builder.ExportOutput(ctrl.GetOutputPort("actuation"), "tau")
    diagram = builder.Build()
    tau = diagram.GetOutputPort("tau").Eval(diagram.CreateDefaultContext())
    # At rest on the desired state: gravity compensation only.
    want = _expected(model, np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
                     np.zeros(n), 0.0, 0.0)  # fmt: skip
    np.testing.assert_allclose(tau, want, atol=1e-9)
    assert ctrl.get_name() == "controller"
    with pytest.raises(TypeError):
        NominalController(model)  # keyword-only


def _identified_like(model, rng):
    """A physically consistent 'identified' robot: the nominal with link masses
    and first moments scaled alike (same centres of mass) and friction changed."""
    from rmdrake.model.dynamic_parameters import perturb_standard_parameters

    chi = perturb_standard_parameters(standard_parameters(model), rng)
    return model.with_dynamics(chi.reshape(model.n_joints, -1))


@pytest.mark.parametrize("dynamics_layer", [True, False])
def test_compensation_controller_uses_the_identified_model(rng, dynamics_layer):
    from rmdrake.systems.controllers import CalibratedCompensationController

    nominal = load_robot("rv3sb")
    identified = _identified_like(nominal, rng)
    n = nominal.n_joints
    ctrl = CalibratedCompensationController(
        nominal=nominal, identified=identified, identified_dynamics=dynamics_layer
    )
    context = ctrl.CreateDefaultContext()
    q, v = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    q_d, v_d, a_d = q + 0.01, rng.uniform(-1, 1, n), rng.uniform(-2, 2, n)
    ctrl.GetInputPort("estimated_state").FixValue(context, np.r_[q, v])
    ctrl.GetInputPort("desired_state").FixValue(context, np.r_[q_d, v_d])
    ctrl.GetInputPort("desired_acceleration").FixValue(context, a_d)
    tau = ctrl.GetOutputPort("actuation").Eval(context)
    # Inertial part from the layer's model; friction always the identified one.
    inertial = identified if dynamics_layer else nominal
    want = _expected(inertial, q, v, q_d, v_d, a_d, 4800.0, 120.0, friction=False)
    dyn = identified.dynamics
    want = want + friction_torque(v_d, dyn[:, FV], dyn[:, FC], DEFAULT_V_EPS)
    np.testing.assert_allclose(tau, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def test_compensation_controller_refuses_unphysical_or_mismatched_robots(rng):
    from rmdrake.systems.controllers import CalibratedCompensationController

    nominal = load_robot("rv3sb")
    bad = nominal.dynamics.copy()
    bad[2, DYNAMIC_KEYS.index("M")] = -1.0
    with pytest.raises(ValueError, match="identified robot 'rv3sb'.*link 3"):
        CalibratedCompensationController(
            nominal=nominal, identified=nominal.with_dynamics(bad)
        )
    fewer = _first_joints(nominal, 3)
    with pytest.raises(ValueError, match="has 3 joints, the nominal 'rv3sb' 6"):
        CalibratedCompensationController(nominal=nominal, identified=fewer)


def _first_joints(model, k):
    """The robot cut after joint k (its k-th row's frame as the tool)."""
    import dataclasses

    from rmdrake.model.robot import JointLimits

    lim = model.limits
    fields = ("lower", "upper", "velocity", "acceleration", "effort")
    limits = JointLimits(*(getattr(lim, f)[:k] for f in fields))
    return dataclasses.replace(
        model,
        mdh=model.mdh[:k],
        limits=limits,
        dynamics=model.dynamics[:k],
        sigma=model.sigma[:k],
    )


def test_corrected_program_tracks_the_calibrated_tool():
    """The corrected program puts the calibrated model's tool where the nominal
    model's tool is on the nominal program, between the samples too (1e-6 m:
    the cubic Hermite spline at a 10 ms period)."""
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.kinematics.forward import tool_points
    from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
    from rmdrake.systems.controllers import corrected_program

    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(3).standard_normal(len(names))
    calibrated = apply_deltas(nominal, names, deltas)
    t = np.linspace(0.0, 2.0, 5)
    q = np.array([0.2, 0.3, 0.8, 0.4, 0.9, -0.3]) + 0.3 * np.outer(
        np.sin(t), np.ones(6)
    )
    program = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        t, q.T, np.zeros(6), np.zeros(6)
    )
    corrected = corrected_program(nominal, calibrated, program, sample_period=0.01)
    t_check = np.linspace(0.0, 2.0, 137)  # not on the samples
    q_n = np.array([program.value(ti).ravel() for ti in t_check])
    q_c = np.array([corrected.value(ti).ravel() for ti in t_check])
    gap = tool_points(calibrated.table, q_c) - tool_points(nominal.table, q_n)
    assert np.linalg.norm(gap, axis=1).max() < 1e-6
    uncorrected = tool_points(calibrated.table, q_n) - tool_points(nominal.table, q_n)
    assert np.linalg.norm(uncorrected, axis=1).max() > 1e-4  # the error it removes


def test_online_correction_equals_the_offline_map():
    """JointTargetCorrection in a diagram (exact solve every 10 ms, first-order
    model between) == correct_joint_motion at off-grid times, to the first-order
    model's error over one period."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.primitives import (
        Demultiplexer,
        LogVectorOutput,
        TrajectorySource,
    )
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.compensation.correction import correct_joint_motion
    from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
    from rmdrake.systems.correction import JointTargetCorrection

    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    deltas = 1e-3 * np.random.default_rng(4).standard_normal(len(names))
    calibrated = apply_deltas(nominal, names, deltas)
    t = np.array([0.0, 1.0, 2.0])
    q = np.array([[0.2, 0.3, 0.8, 0.4, 0.9, -0.3], [0.6, 0.5, 1.1, 0.1, 1.1, 0.2],
                  [0.3, 0.2, 0.9, 0.5, 0.8, -0.1]])  # fmt: skip
    program = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        t, q.T, np.zeros(6), np.zeros(6)
    )
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(program, 2))
    split = builder.AddSystem(Demultiplexer([12, 6]))
    fix = builder.AddSystem(
        JointTargetCorrection(nominal=nominal, calibrated=calibrated)
    )
    builder.Connect(source.get_output_port(), split.get_input_port())
    builder.Connect(split.get_output_port(0), fix.GetInputPort("desired_state"))
    builder.Connect(split.get_output_port(1), fix.GetInputPort("desired_acceleration"))
    logs = [
        LogVectorOutput(fix.GetOutputPort(name), builder, 0.0137)
        for name in ("corrected_state", "corrected_acceleration")
    ]
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(2.0)
    context = simulator.get_context()
    ts = logs[0].FindLog(context).sample_times()
    x = logs[0].FindLog(context).data().T
    a = logs[1].FindLog(context).data().T
    d = [np.array([program.EvalDerivative(s, k).ravel() for s in ts]) for k in range(3)]
    filtered, qd_c, qdd_c = correct_joint_motion(nominal, calibrated, *d)
    # The model around the last solve is held for up to 10 ms of motion (here
    # |qd| <= 0.71 rad/s): measured 4.5e-7 rad, 9.1e-5 rad/s, 1.7e-4 rad/s^2.
    assert np.abs(x[:, :6] - filtered.q).max() < 1e-6
    assert np.abs(x[:, 6:] - qd_c).max() < 2e-4
    assert np.abs(a - qdd_c).max() < 5e-4
    assert np.abs(filtered.q - d[0]).max() > 1e-4  # a real correction


def _actuation(ctrl, q, v, q_d, v_d, a_d):
    """The actuation at the joint state [q; v], the desired [q_d; v_d] and a_d
    and an integral of the position error 0.01 rad s per joint."""
    context = ctrl.CreateDefaultContext()
    integral = context.get_mutable_continuous_state_vector()
    integral.SetFromVector(np.full(integral.size(), 0.01))
    ctrl.GetInputPort("estimated_state").FixValue(context, np.r_[q, v])
    ctrl.GetInputPort("desired_state").FixValue(context, np.r_[q_d, v_d])
    ctrl.GetInputPort("desired_acceleration").FixValue(context, a_d)
    return ctrl.GetOutputPort("actuation").Eval(context).copy()


_CHANGED = {  # a field of the controllers' configs -> a value off its default
    "bandwidth": 10.0,
    "kp": 50.0,
    "kd": 5.0,
    "ki": 20.0,
    "friction_feedforward": False,
    "identified_dynamics": False,
    "identified_friction": False,
}
"""The fields that change the torque at a fixed state."""
_STRUCTURAL = {"kinematic_correction", "correction_period", "correction_ahead"}
"""The fields that choose the kinematic correction (checked by its system)."""
_STATION = {"payload_mass", "payload_mass_input", "deflection_compensation"}
"""What feeds the payload_mass input, and the deflection layer (an elastic
model's: tests/systems/test_deflection.py)."""


def test_every_config_field_reaches_the_controller_built_from_it(rng):
    """from_config builds what the constructor builds with the same keywords,
    and each field of the config changes the controller it builds."""
    from pydrake.trajectories import PiecewisePolynomial

    from rmdrake.systems.controllers import (
        CalibratedCompensationController,
        CompensationSettings,
        ComputedTorqueSettings,
    )
    from rmdrake.systems.correction import (
        JointTargetCorrection,
        PresolvedTargetCorrection,
    )
    from rmdrake.systems.station_config import (
        CompensationControllerConfig,
        InverseDynamicsControllerConfig,
    )

    nominal = load_robot("rv3sb")
    identified = _identified_like(nominal, rng)
    n = nominal.n_joints
    fields = {f.name for f in dataclasses.fields(CompensationControllerConfig)}
    assert fields == set(_CHANGED) | _STRUCTURAL | _STATION  # a new field: test it
    read = set(CompensationSettings.__annotations__)
    read |= set(ComputedTorqueSettings.__annotations__)
    assert read == set(_CHANGED) | _STRUCTURAL | {"deflection_compensation"}
    signals = (rng.uniform(-1, 1, n), rng.uniform(-1, 1, n))
    signals += (signals[0] + 0.01, rng.uniform(-1, 1, n), rng.uniform(-2, 2, n))
    models = {"nominal": nominal, "identified": identified}
    base = _actuation(
        CalibratedCompensationController.from_config(
            CompensationControllerConfig(), **models
        ),
        *signals,
    )
    for field, value in _CHANGED.items():
        built = CalibratedCompensationController.from_config(
            CompensationControllerConfig(**{field: value}), **models
        )
        keywords = CalibratedCompensationController(**models, **{field: value})
        tau = _actuation(built, *signals)
        np.testing.assert_array_equal(tau, _actuation(keywords, *signals))
        assert np.abs(tau - base).max() > 1e-6, field
        if field in ("bandwidth", "kp", "kd", "friction_feedforward"):
            nominal_built = NominalController.from_config(
                InverseDynamicsControllerConfig(**{field: value}), nominal=nominal
            )
            np.testing.assert_array_equal(
                _actuation(nominal_built, *signals),
                _actuation(
                    NominalController(nominal=nominal, **{field: value}), *signals
                ),
            )
    program = PiecewisePolynomial.FirstOrderHold(
        [0.0, 1.0], np.column_stack([np.zeros(n), np.full(n, 0.1)])
    )
    calibrated = dict(models, calibrated=nominal, program=program)
    for config, kind, period in (
        (CompensationControllerConfig(), PresolvedTargetCorrection, None),
        (
            CompensationControllerConfig(correction_ahead=False),
            JointTargetCorrection,
            0.01,
        ),
        (
            CompensationControllerConfig(
                correction_ahead=False, correction_period=0.02
            ),
            JointTargetCorrection,
            0.02,
        ),
    ):
        built = CalibratedCompensationController.from_config(config, **calibrated)
        correction = built.GetSubsystemByName("kinematic_correction")
        assert type(correction) is kind, config
        if period is not None:
            event = correction.GetUniquePeriodicDiscreteUpdateAttribute()
            assert event.period_sec() == period
    off = CalibratedCompensationController.from_config(
        CompensationControllerConfig(kinematic_correction=False), **calibrated
    )
    assert not off.HasSubsystemNamed("kinematic_correction")
