"""Identification sanity checks (issue 10): a fit of a clean log is never
flagged; a log the model cannot explain (joints swapped, a torque's sign) and a
log too short to determine the parameters are refused, naming the joints and
parameters."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identify
from rmdrake.dynamics.regressor import torques
from rmdrake.dynamics.sanity import check_identification, torque_noise
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import perturb_standard_parameters
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def log():
    """One 10 s period at 50 Hz of a random feasible trajectory of a perturbed
    RV-3SB; torques from the regressor plus 1 % of each joint's peak torque."""
    model = load_robot("rv3sb")
    chi = perturb_standard_parameters(
        standard_parameters(model), np.random.default_rng(3)
    )
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    t, q, qd, qdd = traj.sample(50.0)
    exact = torques(model, q, qd, qdd, chi)
    sigma = 0.01 * model.limits.effort
    tau = exact + sigma * np.random.default_rng(5).standard_normal(exact.shape)
    return model, (t, q, qd, qdd), exact, tau, sigma


def _identify(model, motion, tau, method="ols"):
    t, q, qd, qdd = motion
    return identify(model, prepare_samples(t, q, tau, qd, qdd), method=method)


def test_torque_noise_estimate_recovers_white_noise(log):
    _, _, _, tau, sigma = log
    assert np.all(np.abs(torque_noise(tau) / sigma - 1) < 0.2)


def test_clean_logs_are_not_flagged(log):
    model, motion, exact, tau, sigma = log
    result = _identify(model, motion, tau)
    estimated = check_identification(result, raw_torque=tau)
    assert estimated.ok, estimated.reasons
    assert np.all(estimated.residual_rms / estimated.noise < 1.5)
    assert check_identification(result, noise=sigma).ok
    exact_fit = _identify(model, motion, exact)  # noise-free: residual ~ 0
    assert check_identification(exact_fit, raw_torque=exact).ok


def test_swapped_joints_are_refused_naming_the_joints(log):
    model, (t, q, qd, qdd), _, tau, _ = log
    p = [0, 2, 1, 3, 4, 5]  # q2 and q3 logged in each other's column
    result = _identify(model, (t, q[:, p], qd[:, p], qdd[:, p]), tau)
    report = check_identification(result, raw_torque=tau)
    assert not report.ok
    text = report.reasons[0]
    assert re.match(r"torque residual far above the noise \(estimated", text), text
    assert re.search(r"joint [23] [\d.]+ N m = [\d.]+x noise", text), text


def test_a_torque_of_the_wrong_sign_is_refused(log):
    model, motion, _, tau, sigma = log
    flipped = tau.copy()
    flipped[:, 1] *= -1
    report = check_identification(_identify(model, motion, flipped), noise=sigma)
    assert not report.ok and "(declared)" in report.reasons[0]


def test_a_log_too_short_leaves_parameters_undetermined(log):
    model, (t, q, qd, qdd), _, tau, _ = log
    k = t.size // 10  # 1 s of a 10 s excitation
    short = (t[:k], q[:k], qd[:k], qdd[:k])
    report = check_identification(_identify(model, short, tau[:k]), raw_torque=tau)
    assert not report.ok
    text = report.reasons[-1]
    assert re.match(r"\d+ base parameter\(s\) not determined by the data", text)
    assert re.search(r"\w+ \([\d.e+]+ %, [\d.e+]+ % of joint \d's torque\)", text)
