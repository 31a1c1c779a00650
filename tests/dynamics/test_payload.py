"""The tool payload identified on an identified arm (rmdrake.dynamics.payload).

Oracles: the payload's parameters the logs were made with (the regressor's
torques, or the true arm carrying it simulated in the Drake station with
friction and torque-sensor noise), and the drive-gain module's own fold of a
payload into link n."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.dynamics.data import JointSamples, prepare_samples
from rmdrake.dynamics.payload import PayloadColumns, check_payload, identify_payload
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.design import design_excitation
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import FourierTrajectory
from rmdrake.model.dynamic_parameters import (
    payload_from_inertial,
    payload_inertial,
    payload_parameters,
    perturb_standard_parameters,
    standard_parameters,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Payload, RobotModel
from rmdrake.pipelines.simulate import simulate_trajectory, station_config

TOOL = Payload(
    2.0, np.array([0.03, -0.02, 0.05]), np.array([4e-3, 5e-3, 3e-3, 0, 0, 0])
)


def _samples(model: RobotModel, trajectory: FourierTrajectory) -> JointSamples:
    """One 150 Hz period of ``trajectory`` with ``model``'s regressor torques."""
    t, q, qd, qdd = trajectory.sample(150.0)
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    return JointSamples(t, q, qd, qdd, tau, 150.0)


def test_payload_parameters_round_trip_and_fold(rv3sb):
    phi = payload_inertial(TOOL)
    back = payload_from_inertial(phi)
    assert back.mass == pytest.approx(TOOL.mass)
    np.testing.assert_allclose(back.p_EPcm, TOOL.p_EPcm, atol=1e-15)
    np.testing.assert_allclose(back.inertia, TOOL.inertia, atol=1e-15)
    T = PayloadColumns(rv3sb).T
    np.testing.assert_allclose(T @ phi, payload_parameters(rv3sb, TOOL), atol=1e-14)
    with pytest.raises(ValueError, match="mass > 0"):
        payload_from_inertial(np.zeros(10))


def test_noise_free_payload_is_exact(rv3sb):
    trajectory = random_fourier_trajectory(rv3sb, seed=1)
    loaded = _samples(dataclasses.replace(rv3sb, payload=TOOL), trajectory)
    r = identify_payload(rv3sb, loaded)
    np.testing.assert_allclose(r.phi, payload_inertial(TOOL), atol=1e-10)
    assert r.physical_ls and check_payload(r, rv3sb) == []
    assert np.all(r.residual_rms < 1e-10)


def test_unloaded_log_cancels_the_arms_model_error(rv3sb, rng):
    """The arm's model is 10-30 % off: the loaded log alone is biased, the
    difference loaded - unloaded of one trajectory is exact."""
    wrong = perturb_standard_parameters(standard_parameters(rv3sb), rng)
    true_arm = dataclasses.replace(rv3sb, dynamics=wrong.reshape(-1, 13))
    trajectory = random_fourier_trajectory(rv3sb, seed=2)
    loaded = _samples(dataclasses.replace(true_arm, payload=TOOL), trajectory)
    unloaded = _samples(true_arm, trajectory)
    alone = identify_payload(rv3sb, loaded)
    paired = identify_payload(rv3sb, loaded, unloaded)
    assert abs(alone.payload.mass / TOOL.mass - 1) > 0.05
    assert paired.payload.mass == pytest.approx(TOOL.mass, rel=1e-9)
    np.testing.assert_allclose(paired.payload.p_EPcm, TOOL.p_EPcm, atol=1e-10)


def test_refusals(rv3sb):
    trajectory = random_fourier_trajectory(rv3sb, seed=1)
    loaded = _samples(dataclasses.replace(rv3sb, payload=TOOL), trajectory)
    with pytest.raises(ValueError, match="has no dynamics"):
        identify_payload(dataclasses.replace(rv3sb, dynamics=None), loaded)
    still = dataclasses.replace(
        loaded, q=loaded.q.copy(), qd=loaded.qd.copy(), qdd=loaded.qdd.copy()
    )
    for x in (still.q, still.qd, still.qdd):
        x[:, 1:] = x[0, 1:] if x is still.q else 0.0  # only joint 1 moves
    with pytest.raises(ValueError, match="not identifiable"):
        identify_payload(rv3sb, still)
    arm_only = _samples(rv3sb, trajectory)
    minus = dataclasses.replace(loaded, tau=2 * arm_only.tau - loaded.tau)
    reasons = check_payload(identify_payload(rv3sb, minus), rv3sb)
    assert any("not positive" in r for r in reasons)
    heavy = dataclasses.replace(rv3sb, payload=TOOL.with_mass(2000.0))
    r = identify_payload(rv3sb, _samples(heavy, trajectory))
    assert any("over 10x the arm" in r for r in check_payload(r, rv3sb))


# ---- the figures: the true arm carrying the payload in the Drake station ------------
def _cases() -> dict[str, tuple]:
    """robot -> (arm without payload, payload, torque noise std N m, mass
    tolerance (relative), CoM tolerance m, design options, station options)."""
    demo = load_robot("demo_rh")
    demo_arm = dataclasses.replace(demo, payload=None)
    demo_noise = list(1e-3 * np.asarray(demo.limits.effort))
    elastic_arm = dataclasses.replace(load_robot("demo_rh_elastic"), payload=None)
    # The elastic arm: its top frequency 0.3 Hz well below the 1.4 Hz mode, the
    # controller's bandwidth below the mode (check_controller_bandwidth).
    slow, soft = {"harmonics": 3}, {"bandwidth": 3.0}
    return {
        "rv3sb": (load_robot("rv3sb"), TOOL, 0.05, 0.02, 2e-3, {}, {}),
        "demo_rh": (demo_arm, demo.payload, demo_noise, 0.01, 10e-3, {}, {}),
        "demo_rh_elastic": (
            elastic_arm,
            demo.payload,
            demo_noise,
            0.01,
            10e-3,
            slow,
            soft,
        ),
    }


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh", "demo_rh_elastic"])
def test_payload_in_the_drake_station_over_5_seeds(name):
    """A 10 s payload excitation (short DE; 3 harmonics on the elastic arm)
    run by the true arm carrying the payload (friction, 0.1 % of the
    effort limits or 0.05 N m torque noise; the elastic arm's controller on
    its rigid model), identified with the arm's own model: mass within 2 % /
    1 % and CoM within 2 mm / 10 mm on every seed (measured: README,
    identify-payload)."""
    arm, payload, noise, mass_tol, com_tol, design_options, station = _cases()[name]
    design = design_excitation(
        arm, payload=True, maxiter=15, n_random=5, progress=False, seed=0,
        **design_options,
    )  # fmt: skip
    assert design.cond < np.median(design.random_conds)
    truth = dataclasses.replace(arm, payload=payload)
    controller = dataclasses.replace(truth, compliance=None)
    for seed in range(5):
        config = station_config(torque_noise=noise, seed=seed, **station)
        log, _ = simulate_trajectory(config, truth, controller, design.trajectory)
        samples = prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd)
        r = identify_payload(arm, samples, coulomb_width=1e-3)
        assert abs(r.payload.mass / payload.mass - 1) < mass_tol, seed
        assert np.linalg.norm(r.payload.p_EPcm - payload.p_EPcm) < com_tol, seed
        assert check_payload(r, arm) == []
