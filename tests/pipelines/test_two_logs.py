"""Issue 12's target on simulated logs: two logs of different excitations
identified together predict a third log better than either alone (the third
log noise-free, so its error is the identified model's alone)."""

from __future__ import annotations

import numpy as np

from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.loading import load_robot
from rmdrake.pipelines.identify import identify_file
from rmdrake.pipelines.validate import validate_file

NOISE = 0.05  # torque noise std, fraction of each joint's torque RMS


def _log(model, path, seed, noise=NOISE):
    """A 5 s, 100 Hz log of a random feasible excitation (seeded), torques from
    the regressor plus Gaussian noise (``noise`` x each joint's torque RMS);
    q, qd, qdd exact."""
    traj = random_fourier_trajectory(model, fill=0.8, seed=seed)
    t, q, qd, qdd = traj.sample(100.0)
    keep = t < 5.0
    t, q, qd, qdd = t[keep], q[keep], qd[keep], qdd[keep]
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    rng = np.random.default_rng(100 + seed)
    tau = tau + rng.normal(0.0, noise * np.sqrt(np.mean(tau**2, axis=0)), tau.shape)
    write_joint_log(path, JointLog(t=t + 1e4 * seed, q=q, tau=tau, qd=qd, qdd=qdd))
    return path


def test_two_logs_together_predict_a_third_better(tmp_path):
    model = load_robot("rv3sb")
    a, b = (_log(model, tmp_path / f"log{s}.csv", s) for s in (1, 2))
    c = _log(model, tmp_path / "log3.csv", 3, noise=0.0)  # the model error alone
    quiet = {"echo": lambda _: None, "method": "ols", "force": True}
    fits = {
        "a": identify_file(model, a, tmp_path / "a.yaml", **quiet),
        "b": identify_file(model, b, tmp_path / "b.yaml", **quiet),
        "ab": identify_file(model, [a, b], tmp_path / "ab.yaml", **quiet),
    }
    errors = validate_file(list(fits.values()), c, echo=lambda _: None)
    mean = {
        k: float(np.mean(rel)) for k, rel in zip(fits, errors.relative, strict=True)
    }
    # With twice the data the parameter error, hence the prediction error on
    # an unseen excitation, shrinks by about 1/sqrt(2) (measured: 0.76 of the
    # two single fits' mean, 0.86 of the better one).
    assert mean["ab"] < min(mean["a"], mean["b"]), mean
    assert mean["ab"] < 0.85 * (mean["a"] + mean["b"]) / 2, mean
