"""Held-out torque figures (rmdrake.dynamics.validation) against independent
oracles: the injected noise (known truth), Drake's CalcInverseDynamics plus the
friction law, and the regressor called model by model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_dynamics_regressor import drake_inverse_dynamics

from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.friction import friction_torque
from rmdrake.dynamics.regressor import BLOCK_SAMPLES, torques
from rmdrake.dynamics.validation import (
    check_models,
    predict_torques,
    torque_errors,
)
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import perturb_standard_parameters
from rmdrake.model.error_parameters import apply_deltas
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import RobotModel

RTOL = 1e-9


def samples_of(t, q, qd, qdd, tau) -> JointSamples:
    return JointSamples(t=t, q=q, qd=qd, qdd=qdd, tau=tau, rate=1 / (t[1] - t[0]))


def heavier(model: RobotModel, factor: float = 1.2) -> RobotModel:
    """``model`` with every link's 10 inertial parameters scaled by ``factor``
    (masses, first and second moments alike: still physically valid)."""
    dyn = np.array(model.dynamics)
    dyn[:, :10] *= factor
    return model.with_dynamics(dyn)


@pytest.fixture(scope="module")
def run():
    """One 10 s period of a random feasible trajectory on the RV-3SB at 200 Hz
    (2000 samples), true efforts from the regressor, and the truth."""
    model = load_robot("rv3sb")
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    t, q, qd, qdd = traj.sample(200.0)
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    return model, t, q, qd, qdd, tau


def test_true_robot_error_is_the_injected_noise(run):
    model, t, q, qd, qdd, tau = run
    std = 0.01 * np.sqrt(np.mean(tau**2, axis=0))  # 1 % of each joint's RMS
    noise = np.random.default_rng(5).normal(0.0, std, tau.shape)
    measured = tau + noise
    errors = torque_errors(
        {"true": model, "heavier": heavier(model)},
        samples_of(t, q, qd, qdd, measured),
    )
    realised = np.sqrt(np.mean(noise**2, axis=0))
    measured_rms = np.sqrt(np.mean(measured**2, axis=0))
    # The true robot's prediction is the noise-free effort: its error is the
    # noise drawn, up to round-off; and the noise's std to sampling error
    # (the RMS of N = 2000 normal draws has relative std 1/sqrt(2N) = 1.6 %).
    np.testing.assert_allclose(errors.rms[0], realised, rtol=RTOL)
    np.testing.assert_allclose(errors.rms[0], std, rtol=0.08)
    np.testing.assert_allclose(errors.measured_rms, measured_rms, rtol=RTOL)
    np.testing.assert_allclose(errors.relative[0], realised / measured_rms, rtol=RTOL)
    np.testing.assert_allclose(errors.relative[0], 0.01, rtol=0.08)
    # Links 20 % too heavy: the inertial and gravity efforts are 20 % off. On
    # the arm joints 1-3 they dominate, far above the 1 % noise; on the wrist
    # friction dominates and the error grows less (here by 0.1-15 %).
    assert np.all(errors.rms[1, :3] > 3 * errors.rms[0, :3])
    assert errors.mean_relative[1] > 2 * errors.mean_relative[0]
    assert errors.labels == ("true", "heavier")
    assert errors.predicted.shape == (2, *tau.shape)


@pytest.mark.parametrize("width", [0.0, 0.05])
def test_figures_equal_drake_inverse_dynamics_plus_friction(any_robot, width):
    model = any_robot
    rng = np.random.default_rng(11)
    N, n = 150, model.n_joints
    q = rng.uniform(model.limits.lower, model.limits.upper, (N, n))
    qd, qdd = rng.uniform(-1, 1, (2, N, n)) * [[model.limits.velocity]]
    t = np.arange(N) / 100.0
    chi = perturb_standard_parameters(standard_parameters(model), rng)
    measured = torques(model, q, qd, qdd, chi)  # another robot made the log
    errors = torque_errors(
        {"m": model}, samples_of(t, q, qd, qdd, measured), coulomb_width=width
    )
    # Independent oracle: Drake's inverse dynamics of the model's plant (rotor
    # inertia, payload and prismatic joints included) plus the friction law.
    ref = drake_inverse_dynamics(MakePlant(model, visual=False)[0], q, qd, qdd)
    dyn = np.asarray(model.dynamics)
    ref += friction_torque(qd, dyn[:, 11], dyn[:, 12], width)
    for m, (Iam, fvm, fcm) in zip(  # a coupled motor (the continuous plant
        model.coupled_motors,  # has none): its law c_j (Iam a + fvm s + fcm s(s))
        model.motor_terms if model.motor_terms is not None else [],
        strict=True,
    ):
        c = model.transmission.coupling[m]
        s = qd @ c
        ref += np.outer(Iam * (qdd @ c) + friction_torque(s, fvm, fcm, width), c)
    scale = np.abs(ref).max()
    assert np.abs(errors.predicted[0] - ref).max() < RTOL * scale
    rms = np.sqrt(np.mean((ref - measured) ** 2, axis=0))
    np.testing.assert_allclose(errors.rms[0], rms, rtol=RTOL)
    rel = rms / np.sqrt(np.mean(measured**2, axis=0))
    np.testing.assert_allclose(errors.relative[0], rel, rtol=RTOL)
    units = [line[6:11].strip() for line in errors.table()[1:-1]]
    assert units == ["N" if s else "N m" for s in model.sigma]


def test_several_models_equal_one_at_a_time_across_blocks(rv3sb):
    """Models sharing kinematics share one regressor, the others get theirs,
    and the blocked evaluation covers every sample (N > one block)."""
    rng = np.random.default_rng(2)
    N = BLOCK_SAMPLES + 37
    q, qd, qdd = rng.uniform(-2, 2, (3, N, 6))
    moved = apply_deltas(rv3sb, ["dd2", "dtheta3"], [2e-3, 1e-3])  # other kinematics
    models = [rv3sb, moved, heavier(rv3sb), heavier(moved, 0.9)]
    got = predict_torques(models, q, qd, qdd, coulomb_width=0.02)
    for k, m in enumerate(models):
        ref = torques(m, q, qd, qdd, standard_parameters(m), coulomb_width=0.02)
        assert np.abs(got[k] - ref).max() < RTOL * np.abs(ref).max(), k


def test_bad_models_are_refused_naming_the_robot(rv3sb, boom):
    with pytest.raises(ValueError, match=r"robot b\.yaml: has no 'dynamics'"):
        check_models({"a.yaml": rv3sb, "b.yaml": rv3sb.with_dynamics(None)})
    five = dataclasses.replace(
        rv3sb,
        mdh=rv3sb.mdh[:5],
        sigma=rv3sb.sigma[:5],
        dynamics=rv3sb.dynamics[:5],
        limits=dataclasses.replace(
            rv3sb.limits,
            **{
                f.name: getattr(rv3sb.limits, f.name)[:5]
                for f in dataclasses.fields(rv3sb.limits)
            },
        ),
    )
    with pytest.raises(ValueError, match="one joint count, found a 6, b 5"):
        check_models({"a": rv3sb, "b": five})
    with pytest.raises(ValueError, match="log has 5 joints, the robots 6"):
        check_models({"a": rv3sb}, 5)
    with pytest.raises(ValueError, match="b and a differ in joint types"):
        check_models({"a": rv3sb, "b": boom})
    with pytest.raises(ValueError, match="at least one robot"):
        check_models({})


def test_zero_measured_torque_gives_no_relative_figure(rv3sb):
    N = 20
    t = np.arange(N) / 100.0
    z = np.zeros((N, 6))
    q = z
    tau = torques(rv3sb, q, z, z, standard_parameters(rv3sb))
    tau[:, 5] = 0.0  # joint 6 measured nothing at all
    errors = torque_errors({"m": rv3sb}, samples_of(t, q, z, z, tau))
    assert np.isnan(errors.relative[0, 5]) and np.isfinite(errors.relative[0, :5]).all()
    assert np.isfinite(errors.mean_relative).all()
    assert "n/a" in errors.table()[6]


def test_offsets_and_asymmetric_coulomb_are_predicted(rv3sb, rng):
    """A robot whose YAML has torque offsets tau0 and a negative-velocity
    Coulomb level fcn: validate predicts them (the same model without them
    differs by tau0 everywhere, and by fc - fcn more where the joint moves
    backwards: -fcn instead of -fc)."""
    from rmdrake.dynamics.validation import predict_torques

    n = rv3sb.n_joints
    tau0 = rng.uniform(-0.5, 0.5, n)
    fcn = rv3sb.dynamics[:, 12] * 1.5
    full = dataclasses.replace(rv3sb, tau0=tau0, fcn=fcn)
    q = rng.uniform(rv3sb.limits.lower, rv3sb.limits.upper, (50, n))
    qd = rng.normal(0.0, 1.0, (50, n))
    qdd = rng.normal(0.0, 1.0, (50, n))
    with_terms, without = predict_torques([full, rv3sb], q, qd, qdd)
    s = np.sign(qd)
    fc = rv3sb.dynamics[:, 12]
    expected = tau0 + np.where(s < 0, -(fcn - fc), 0.0)
    np.testing.assert_allclose(with_terms - without, expected, rtol=0, atol=1e-9)
