"""JointTargetCorrection on a robot with prismatic joints (the boom arm: joints
1 and 4 in m): at an update its corrected state moves the calibrated robot's
Drake plant tool as the nominal plant's tool moves (pose and spatial
velocity), and between updates its first-order model follows the exact map."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable

from rmdrake.compensation.correction import correct_joint_motion
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.plant import TOOL_FRAME, MakePlant
from rmdrake.systems.correction import JointTargetCorrection

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
