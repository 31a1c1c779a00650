"""Drive gains identified from motor currents with and without a known payload
(:mod:`rmdrake.dynamics.drive_gains`).

Oracle: the true gains of a simulated rv3sb. The unloaded currents are the
regressor torques of the shipped dynamics / gains; the loaded ones add the
payload's torques from Drake (CalcInverseDynamics of MakePlant with the payload
welded to the tool, minus the same without it), so the payload folding into
link n is checked against an independent computation too.
Tolerances: noise-free 1e-6 relative (observed ~1e-14); 1 % current noise
(std 1 % of each joint's current std, 400 samples per log): 5 % relative
(observed max 2.6 %, median 1.3 % over 20 seeds).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_dynamics_regressor import drake_inverse_dynamics

from rmdrake.dynamics import standard_parameters, torques
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.drive_gains import identify_drive_gains, prepare_current_logs
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.model.dynamic_parameters import payload_parameters
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import Payload

GAINS = np.array([55.0, 80.0, 42.0, 12.0, 9.5, 6.0])  # N m/A
PAYLOAD = Payload(
    mass=2.0,
    p_EPcm=np.array([0.01, -0.02, 0.05]),
    inertia=np.array([0.01, 0.012, 0.008, 0.001, -0.0005, 0.0002]),
)


def _drake_torques(model, q, qd, qdd) -> np.ndarray:
    return drake_inverse_dynamics(MakePlant(model, visual=False)[0], q, qd, qdd)


def _currents(model, rng, loaded: bool, noise: float = 0.0, N: int = 400):
    n = model.n_joints
    q, qd, qdd = (rng.uniform(-2.0, 2.0, (N, n)) for _ in range(3))
    bare = dataclasses.replace(model, payload=None)
    tau = torques(bare, q, qd, qdd, standard_parameters(bare))
    if loaded:
        with_payload = dataclasses.replace(bare, payload=PAYLOAD)
        tau += _drake_torques(with_payload, q, qd, qdd)
        tau -= _drake_torques(bare, q, qd, qdd)
    i = tau / GAINS
    i += noise * np.std(i, axis=0) * rng.standard_normal(i.shape)
    t = np.arange(N) * 0.01
    return JointSamples(t=t, q=q, qd=qd, qdd=qdd, tau=i, rate=100.0)


def test_noise_free_gains_and_parameters_are_the_truth(rv3sb, rng):
    r = identify_drive_gains(
        rv3sb, _currents(rv3sb, rng, False), _currents(rv3sb, rng, True), PAYLOAD
    )
    assert np.abs(r.gains / GAINS - 1).max() < 1e-6
    truth = r.base.regroup(standard_parameters(rv3sb))
    assert np.abs(r.beta - truth).max() < 1e-6 * np.abs(truth).max()
    assert r.residual_rms.max() < 1e-6 * GAINS.min()


def test_one_percent_noise(rv3sb, rng):
    r = identify_drive_gains(
        rv3sb,
        _currents(rv3sb, rng, False, 0.01),
        _currents(rv3sb, rng, True, 0.01),
        PAYLOAD,
    )
    err = np.abs(r.gains / GAINS - 1).max()
    assert 1e-5 < err < 0.05, err  # noise does reach the gains, within 5 %


def test_payload_parameters_fold_into_link_n(rv3sb):
    phi = payload_parameters(rv3sb, PAYLOAD)
    assert phi[9] == PAYLOAD.mass
    with_payload = dataclasses.replace(rv3sb, payload=PAYLOAD)
    bare = dataclasses.replace(rv3sb, payload=None)
    diff = standard_parameters(with_payload) - standard_parameters(bare)
    # A difference of two parameter sets (cancellation) against the payload's own.
    np.testing.assert_allclose(diff[-13:-3], phi, rtol=1e-13, atol=1e-15)


def test_bad_inputs_refused_in_one_line(rv3sb, rng, tmp_path):
    free, loaded = _currents(rv3sb, rng, False, N=60), _currents(rv3sb, rng, True, N=60)
    massless = dataclasses.replace(PAYLOAD, mass=0.0)
    with pytest.raises(ValueError, match="payload.mass: expected a known mass"):
        identify_drive_gains(rv3sb, free, loaded, massless)
    flipped = dataclasses.replace(loaded, tau=loaded.tau * [1, 1, -1, 1, 1, 1])
    flipped_free = dataclasses.replace(free, tau=free.tau * [1, 1, -1, 1, 1, 1])
    with pytest.raises(ValueError, match=r"non-positive drive gain\(s\) on joint"):
        identify_drive_gains(rv3sb, flipped_free, flipped, PAYLOAD)
    with pytest.raises(ValueError, match="at least one unloaded and one loaded"):
        identify_drive_gains(rv3sb, free, [], PAYLOAD)
    still = dataclasses.replace(free, qd=0 * free.qd, qdd=0 * free.qdd)
    still_l = dataclasses.replace(loaded, qd=0 * free.qd, qdd=0 * free.qdd)
    with pytest.raises(ValueError, match="gains: not determined by the logs"):
        identify_drive_gains(rv3sb, still, still_l, PAYLOAD)  # joint 1 never loaded
    log = JointLog(t=free.t, q=free.q, tau=free.tau, qd=free.qd, qdd=free.qdd)
    path = write_joint_log(tmp_path / "tau.csv", log)
    with pytest.raises(ValueError, match="tau.csv: a torque log .*currents"):
        prepare_current_logs([path], 6)
