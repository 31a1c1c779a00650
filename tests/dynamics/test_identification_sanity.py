"""Identification sanity checks: a fit of a clean log, or of a log with effects
the model lacks (Stribeck friction, a torque-sensor low-pass, a cable spring),
is never refused (the latter warn, naming the unexplained share per joint); a
log the model cannot explain (joints swapped, a torque's sign, another robot's
kinematics, torque shifted in time) and a log too short to determine the
parameters are refused, naming the joints and parameters; absurd logs and
priors are refused with one line each, masses far from the prior's warned.
The same rule on real logs: test_real_log_sanity.py."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from scipy.signal import lfilter, lfilter_zi

from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identify
from rmdrake.dynamics.regressor import torques
from rmdrake.dynamics.sanity import (
    check_identification,
    check_masses,
    check_prediction,
    check_prior,
    check_torque_log,
)
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import (
    perturb_standard_parameters,
    standard_parameters,
)
from rmdrake.model.loading import load_robot

RATE = 50.0  # Hz


@pytest.fixture(scope="module")
def log():
    """One 10 s period at 50 Hz of a random feasible trajectory of a perturbed
    RV-3SB; torques from the regressor plus 1 % of each joint's effort limit."""
    model = load_robot("rv3sb")
    chi = perturb_standard_parameters(
        standard_parameters(model), np.random.default_rng(3)
    )
    traj = random_fourier_trajectory(model, fill=0.8, seed=4)
    t, q, qd, qdd = traj.sample(RATE)
    exact = torques(model, q, qd, qdd, chi)
    sigma = 0.01 * model.limits.effort
    tau = exact + sigma * np.random.default_rng(5).standard_normal(exact.shape)
    return model, (t, q, qd, qdd), exact, tau, sigma


def _identify(model, motion, tau, method="ols"):
    t, q, qd, qdd = motion
    return identify(model, prepare_samples(t, q, tau, qd, qdd), method=method)


def _check(model, motion, tau):
    """The after-fit rule with the shift and swap evidence."""
    t, q, qd, qdd = motion
    samples = prepare_samples(t, q, tau, qd, qdd)
    result = identify(model, samples, method="ols")
    return check_identification(result, model=model, samples=samples)


def test_clean_logs_are_not_flagged(log):
    model, motion, exact, tau, _ = log
    report = _check(model, motion, tau)
    assert report.ok, report.reasons  # joint 1: its noise is 11 % of its torque
    assert np.all(report.heldout_rms / report.scale < 0.12)
    exact_fit = check_identification(_identify(model, motion, exact))  # noise-free
    assert exact_fit.ok and not exact_fit.warnings


def _stribeck(model, qd):
    """Unmodelled Stribeck friction: 3 % of the effort limit, fading over
    0.1 rad/s."""
    return 0.03 * model.limits.effort * np.exp(-((qd / 0.1) ** 2)) * np.sign(qd)


def _low_pass(tau, time_constant=0.05):
    """A first-order torque-sensor low-pass (time constant 50 ms)."""
    a = np.exp(-1.0 / (RATE * time_constant))
    out = np.empty_like(tau)
    for j in range(tau.shape[1]):
        zi = lfilter_zi([1 - a], [1, -a]) * tau[0, j]
        out[:, j] = lfilter([1 - a], [1, -a], tau[:, j], zi=zi)[0]
    return out


@pytest.mark.parametrize("effect", ["stribeck", "low-pass", "cable spring"])
def test_unmodelled_effects_pass_with_a_warning(log, effect):
    model, motion, exact, _, sigma = log
    q, qd = motion[1], motion[2]
    tau = exact + 0.1 * sigma * np.random.default_rng(6).standard_normal(exact.shape)
    if effect == "stribeck":
        tau = tau + _stribeck(model, qd)
    elif effect == "low-pass":
        tau = _low_pass(tau)
    else:  # a cable on joint 1: tau = -k (q - q0), k = 2.7 N m/rad
        tau = tau.copy()
        tau[:, 0] -= 0.03 * model.limits.effort[0] * (q[:, 0] - q[:, 0].mean())
    report = _check(model, motion, tau)
    assert report.ok, report.reasons
    assert 1 <= len(report.warnings) <= 2  # loaded joints, then the others
    for warning in report.warnings:
        assert re.match(
            r"the model leaves (part of the torque|joints that carry little torque) "
            r"unexplained \(written\):\n  joint \d: [\d.]+ % of its torque scale",
            warning,
        )
    if effect == "cable spring":
        assert "\n  joint 1: " in report.warnings[0]


def _refused(report, pattern):
    assert not report.ok
    assert any(re.search(pattern, r) for r in report.reasons), report.reasons


def test_swapped_joints_are_refused_naming_the_joints(log):
    model, (t, q, qd, qdd), _, tau, _ = log
    p = [0, 2, 1, 3, 4, 5]  # q2 and q3 logged in each other's column
    report = _check(model, (t, q[:, p], qd[:, p], qdd[:, p]), tau)
    _refused(report, r"^held out: .*joint [23] [\d.]+ % unexplained")


def test_a_torque_of_the_wrong_sign_is_refused(log):
    model, motion, _, tau, _ = log
    flipped = tau.copy()
    flipped[:, 1] *= -1
    report = _check(model, motion, flipped)
    _refused(report, r"^sign: joint 2's torque negated leaves 0\.\d+x the residual")


def test_torque_shifted_in_time_is_refused(log):
    model, motion, _, tau, _ = log
    late = np.roll(tau, int(0.3 * RATE), axis=0)  # torque 0.3 s late
    _refused(_check(model, motion, late), r"^time base: the torque 0\.3 s late")
    early = np.roll(tau, -int(0.2 * RATE), axis=0)
    _refused(_check(model, motion, early), r"^time base: the torque 0\.2 s early")


def test_another_robots_kinematics_are_refused(log):
    _, motion, _, tau, _ = log
    demo = load_robot("demo_rh")  # 6 joints, other MDH lengths
    _refused(_check(demo, motion, tau), r"^held out: ")


def test_a_log_too_short_leaves_parameters_undetermined(log):
    model, (t, q, qd, qdd), _, tau, _ = log
    k = t.size // 10  # 1 s of a 10 s excitation
    short = (t[:k], q[:k], qd[:k], qdd[:k])
    report = check_identification(_identify(model, short, tau[:k]))
    assert not report.ok
    text = report.reasons[-1]
    pattern = r"undetermined: \w+ \(std [\d.e+]+ %, [\d.e+]+ % of joint \d\)"
    assert re.match(pattern, text)


def test_prediction_rule_matches(log):
    """validate's rule: the true model's prediction passes, a sign refused."""
    model, (t, q, qd, qdd), exact, tau, _ = log
    assert check_prediction(exact, tau).ok
    flipped = tau.copy()
    flipped[:, 1] *= -1
    _refused(check_prediction(exact, flipped), "^sign: joint 2's ")
    _refused(check_prediction(1.5 * exact, tau), "^prediction: joint ")
    late = np.roll(tau, int(0.3 * RATE), axis=0)
    report = check_prediction(exact, late, t=t, rate=RATE)
    _refused(report, r"^time base: the torque 0\.3 s late")
    swapped = tau[:, [0, 2, 1, 3, 4, 5]]
    report = check_prediction(exact, swapped, t=t, rate=RATE)
    _refused(report, r"^joint order: joints 2 and 3 exchanged leave 0\.\d+x")
    assert check_prediction(exact, tau, t=t, rate=RATE).ok


def test_torque_logs_in_n_mm_or_constant_are_refused(log):
    model, _, _, tau, _ = log
    effort = model.limits.effort
    assert check_torque_log(tau, effort) == []
    (mm,) = check_torque_log(1000 * tau, effort)
    assert re.match(r"unit: the 99th-percentile \|torque\| of joints 1, .* up to ", mm)
    (zero,) = check_torque_log(0 * tau, effort)
    assert zero.startswith("torque log: joint(s) 1, 2, 3, 4, 5, 6 constant")


def test_priors_not_physical_or_not_this_robot_are_refused():
    model = load_robot("rv3sb")
    dyn = np.array(model.dynamics)
    dyn[1, 9] = -9.5
    with pytest.raises(ValueError, match=r"prior: robot 'rv3sb' is not physical: l"):
        check_prior(model, model.with_dynamics(dyn))
    with pytest.raises(ValueError, match=r"other kinematics than robot 'rv3sb'"):
        check_prior(model, load_robot("demo_rh"))
    heavy = np.array(model.dynamics)
    heavy[:, :10] *= 50
    with pytest.raises(ValueError, match=r"weighs .* 50x off robot 'rv3sb'"):
        check_prior(model, dataclasses.replace(model.with_dynamics(heavy), name="x"))
    check_prior(model, model)  # its own dynamics: fine


def test_masses_far_from_the_prior_are_warned():
    prior = np.array([10.0, 8.0, 3.0, 1.0, 0.5, 0.1])
    assert check_masses(prior * 3, prior) == []
    assert check_masses(np.r_[prior[:5], 0.001], prior) == []  # a light link
    (warning,) = check_masses(np.r_[prior[0], 8035.0, prior[2:]], prior)
    assert warning.startswith("identified link masses over 10x off the prior's")
    assert "\n  link 2: 8035 kg (prior 8 kg)\n" in warning
