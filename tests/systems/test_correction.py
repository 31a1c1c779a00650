"""JointTargetCorrection on a robot with prismatic joints (the boom arm: joints
1 and 4 in m): at an update its corrected state moves the calibrated robot's
Drake plant tool as the nominal plant's tool moves (pose and spatial
velocity), and between updates its first-order model follows the exact map;
PresolvedTargetCorrection, the same rule solved ahead, equals it."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (
    Demultiplexer,
    LogVectorOutput,
    Multiplexer,
    TrajectorySource,
)
from pydrake.trajectories import PiecewisePolynomial

from rmdrake.compensation.correction import correct_joint_motion
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.plant import TOOL_FRAME, MakePlant
from rmdrake.systems.correction import (
    MAX_PRESOLVED_UPDATES,
    JointTargetCorrection,
    PresolvedTargetCorrection,
    presolvable,
    presolve_times,
)

Q = np.array([0.4, 0.3, -1.0, 0.3, 0.8, 0.2])  # well conditioned, slides mid-range
V = np.array([0.1, 0.3, -0.2, 0.15, 0.4, -0.3])  # m/s for joints 1 and 4
A = np.array([0.5, -1.0, 0.7, -0.4, 1.5, 2.0])


class Tool:
    """The tool frame's pose and spatial velocity [w; v] in the world from a
    model's MultibodyPlant (the oracle)."""

    def __init__(self, model) -> None:
        self.plant, _ = MakePlant(model, visual=False)
        self.context = self.plant.CreateDefaultContext()
        self.frame = self.plant.GetFrameByName(TOOL_FRAME)

    def __call__(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
        plant, world = self.plant, self.plant.world_frame()
        plant.SetPositions(self.context, q)
        X = plant.CalcRelativeTransform(self.context, world, self.frame)
        J = plant.CalcJacobianSpatialVelocity(
            self.context, JacobianWrtVariable.kV, self.frame, [0, 0, 0], world, world
        )
        return X.GetAsMatrix4(), J @ v


@pytest.fixture
def corrector(boom):
    names = error_parameter_names(boom, "full")
    deltas = 1e-3 * np.random.default_rng(3).standard_normal(len(names))
    calibrated = apply_deltas(boom, names, deltas)
    fix = JointTargetCorrection(nominal=boom, calibrated=calibrated, period=0.01)
    context = fix.CreateDefaultContext()
    return boom, calibrated, fix, context


def _outputs(fix, context, q, v, a) -> tuple[np.ndarray, np.ndarray]:
    fix.GetInputPort("desired_state").FixValue(context, np.r_[q, v])
    fix.GetInputPort("desired_acceleration").FixValue(context, a)
    x = fix.GetOutputPort("corrected_state").Eval(context)
    return x, fix.GetOutputPort("corrected_acceleration").Eval(context)


def test_update_moves_the_calibrated_plant_tool_as_the_nominal_one(corrector):
    """After an update at (Q, V): the calibrated plant's tool pose at q_c ==
    the nominal plant's at Q (1e-9 m and rad) and its spatial velocity at
    (q_c, v_c) == the nominal one at (Q, V) (1e-9), with mm-sized corrections
    of the slides; a_c == correct_joint_motion's."""
    nominal, calibrated, fix, context = corrector
    _outputs(fix, context, Q, V, A)
    values = fix.AllocateDiscreteVariables()
    fix.CalcForcedDiscreteVariableUpdate(context, values)
    context.SetDiscreteState(values)
    x, a_c = _outputs(fix, context, Q, V, A)
    q_c, v_c = x[:6], x[6:]
    X_n, twist_n = Tool(nominal)(Q, V)
    X_c, twist_c = Tool(calibrated)(q_c, v_c)
    assert np.abs(X_c[:3] - X_n[:3]).max() < 1e-9
    assert np.abs(twist_c - twist_n).max() < 1e-9
    assert 1e-4 < np.abs(q_c - Q)[[0, 3]].max() < 1e-2  # m: the slides correct
    _, _, qdd_c = correct_joint_motion(nominal, calibrated, Q[None], V[None], A[None])
    np.testing.assert_allclose(a_c, qdd_c[0], rtol=0, atol=1e-9)


def test_first_order_model_between_updates(corrector):
    """Program motion of h = 5 and 2.5 (mm or mrad) per joint after the
    update: the held model's q_c is within 2e-6 (m or rad) of the exact map
    and its error is second order in h (quartered when h is halved); v_c
    (|V| <= 0.4) is within 3e-4 (m/s or rad/s), an error of first order."""
    nominal, calibrated, fix, context = corrector
    _outputs(fix, context, Q, V, A)
    values = fix.AllocateDiscreteVariables()
    fix.CalcForcedDiscreteVariableUpdate(context, values)
    context.SetDiscreteState(values)
    errors, rate_errors = [], []
    for h in (5e-3, 2.5e-3):
        q = Q + h * np.sign(V)
        x, _ = _outputs(fix, context, q, V, A)
        exact, qd_c, _ = correct_joint_motion(
            nominal, calibrated, q[None], V[None], A[None]
        )
        errors.append(np.abs(x[:6] - exact.q[0]).max())
        rate_errors.append(np.abs(x[6:] - qd_c[0]).max())
        assert np.abs(exact.q[0] - q).max() > 1e-4  # a real correction to follow
    assert errors[0] < 2e-6 and 3.0 < errors[0] / errors[1] < 5.0
    assert rate_errors[0] < 3e-4 and 1.5 < rate_errors[0] / rate_errors[1] < 2.5


def _both_corrections(nominal, calibrated, program, until: float):
    """The online JointTargetCorrection and the PresolvedTargetCorrection fed
    by one TrajectorySource of ``program`` (holding its end value beyond it),
    simulated to ``until`` s; their logged [q_c; v_c; a_c] (off the 10 ms
    update grid until 3.71 s: a log at an update instant reads the map before it)."""
    n = nominal.n_joints
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(program, 2, True))
    split = builder.AddSystem(Demultiplexer([2 * n, n]))
    builder.Connect(source.get_output_port(), split.get_input_port())
    logs = []
    for fix in (
        JointTargetCorrection(nominal=nominal, calibrated=calibrated, period=0.01),
        PresolvedTargetCorrection(
            nominal=nominal, calibrated=calibrated, program=program, period=0.01
        ),
    ):
        builder.AddSystem(fix)
        builder.Connect(split.get_output_port(0), fix.GetInputPort("desired_state"))
        builder.Connect(
            split.get_output_port(1), fix.GetInputPort("desired_acceleration")
        )
        join = builder.AddSystem(Multiplexer([2 * n, n]))
        builder.Connect(fix.GetOutputPort("corrected_state"), join.get_input_port(0))
        builder.Connect(
            fix.GetOutputPort("corrected_acceleration"), join.get_input_port(1)
        )
        logs.append(LogVectorOutput(join.get_output_port(), builder, 0.00371))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(until)
    context = simulator.get_context()
    return [log.FindLog(context).data().T for log in logs]


def test_the_presolved_correction_is_the_online_one(corrector):
    """PresolvedTargetCorrection (updates solved ahead, outputs in Drake's
    TrajectoryAffineSystem) == JointTargetCorrection (solved in the
    simulation) along a 0.5 s program of the prismatic arm, and 0.1 s beyond
    its end: q_c within 1e-9 (m or rad; both solve the same IK to 1e-10 m),
    v_c and a_c within 1e-8; the correction itself is mm and mrad-sized."""
    nominal, calibrated, _, _ = corrector
    t = np.array([0.0, 0.2, 0.5])
    knots = np.stack([Q, Q + 0.05 * V, Q + 0.1 * np.sign(V)])
    program = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        t, knots.T, np.zeros(6), np.zeros(6)
    )
    online, ahead = _both_corrections(nominal, calibrated, program, until=0.6)
    assert online.shape == ahead.shape == (162, 18)
    assert np.abs(ahead[:, :6] - online[:, :6]).max() < 1e-9
    assert np.abs(ahead[:, 6:] - online[:, 6:]).max() < 1e-8
    q = program.vector_values(0.00371 * np.arange(len(ahead))).T
    assert 1e-4 < np.abs(ahead[:, :6] - q).max() < 5e-2


def test_the_presolved_correction_refuses_what_it_cannot_hold(boom):
    """A program of another shape, and one longer than MAX_PRESOLVED_UPDATES
    updates, are refused with the reason (the long one: correct it online)."""
    pair = {"nominal": boom, "calibrated": boom}
    with pytest.raises(ValueError, match=r"expected \(6, 1\) joint positions"):
        PresolvedTargetCorrection(**pair, program=PiecewisePolynomial(np.zeros((5, 1))))
    end = MAX_PRESOLVED_UPDATES * 0.01
    long = PiecewisePolynomial.FirstOrderHold([0.0, end], np.stack([Q, Q], axis=1))
    assert presolve_times(long, 0.01).size == MAX_PRESOLVED_UPDATES + 1
    assert not presolvable(long, 0.01) and presolvable(long, 0.0101)
    with pytest.raises(ValueError, match="correct it online"):
        PresolvedTargetCorrection(**pair, program=long, period=0.01)
