"""NPZ joint logs written by other tools (keys ``times``, ``positions``,
``velocities``, ``torques``) read to the same JointLog as rmdrake's CSV."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log


@pytest.fixture
def log(rng) -> JointLog:
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 50))
    q, qd, tau = (rng.standard_normal((50, 3)) for _ in range(3))
    return JointLog(t=t, q=q, tau=tau, qd=qd)


def _same(a: JointLog, b: JointLog) -> None:
    for key in ("t", "q", "tau", "qd", "qdd"):
        x, y = getattr(a, key), getattr(b, key)
        assert (x is None) == (y is None), key
        if x is not None:
            np.testing.assert_array_equal(x, y)


def test_other_tools_keys_read_as_the_csv(log, tmp_path):
    write_joint_log(tmp_path / "log.csv", log)
    csv = read_joint_log(tmp_path / "log.csv")
    np.savez(
        tmp_path / "other.npz",
        times=log.t, positions=log.q, velocities=log.qd, torques=log.tau,
    )  # fmt: skip
    _same(read_joint_log(tmp_path / "other.npz", n_joints=3), csv)
    write_joint_log(tmp_path / "own.npz", log)  # rmdrake's own names
    _same(read_joint_log(tmp_path / "own.npz"), csv)
    np.savez(tmp_path / "mixed.npz", t=log.t, positions=log.q, tau=log.tau)
    _same(
        read_joint_log(tmp_path / "mixed.npz"), JointLog(t=log.t, q=log.q, tau=log.tau)
    )


@pytest.mark.parametrize(
    "arrays, message",
    [
        (dict(t=1, times=1, q=2, tau=2), "arrays 't' and 'times' both given"),
        (dict(times=1, positions=2), r"missing array 'tau' \(or 'torques'\)"),
        (dict(times=2, positions=2, torques=2), "array 'times': expected 1 dim"),
    ],
)
def test_bad_other_tools_npz_is_refused(tmp_path, arrays, message):
    shapes = {1: (5,), 2: (5, 2)}
    np.savez(tmp_path / "bad.npz", **{k: np.ones(shapes[d]) for k, d in arrays.items()})
    with pytest.raises(ValueError, match=message):
        read_joint_log(tmp_path / "bad.npz")
