"""Identification from several logs and from logs with standstill (issue 12):
noise-free logs made by the regressor from known parameters (the oracle) come
back through :func:`rmdrake.pipelines.identify.identify_file`."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.base import base_parameters
from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.identification import identify
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.dynamic_parameters import perturb_standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.pipelines.identify import identify_file

RATE = 150.0


def _motion(model, chi, seed: int, offset: float = 0.0, pad: float = 0.0):
    """One period at 150 Hz of a random Fourier trajectory (it starts and ends
    at rest), ``pad`` s of standstill added at both ends, stamps + offset."""
    t, q, qd, qdd = random_fourier_trajectory(model, fill=0.8, seed=seed).sample(RATE)
    k = int(round(pad * RATE))
    if k:
        t = np.arange(t.size + 2 * k) / RATE
        q = np.r_[np.repeat(q[:1], k, 0), q, np.repeat(q[-1:], k, 0)]
        still = np.zeros((k, q.shape[1]))
        qd, qdd = np.r_[still, qd, still], np.r_[still, qdd, still]
    return JointLog(
        t=t + offset, q=q, tau=torques(model, q, qd, qdd, chi), qd=qd, qdd=qdd
    )


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("logs")
    model = load_robot("rv3sb")
    chi = perturb_standard_parameters(
        standard_parameters(model), np.random.default_rng(3)
    )
    logs = {
        "a": _motion(model, chi, 4),
        "b": _motion(model, chi, 5, offset=1e9),  # another run, 1e9 s later
        "padded": _motion(model, chi, 4, pad=5.0),
    }
    for name, log in logs.items():
        write_joint_log(tmp / f"{name}.csv", log)
        # the same motion without velocities and accelerations: filtered and
        # differentiated, so the filter's edges matter
        write_joint_log(tmp / f"{name}_q.csv", JointLog(t=log.t, q=log.q, tau=log.tau))
    return tmp, model, base_parameters(model).regroup(chi), logs


def _base_values(path) -> np.ndarray:
    record = load_robot(path).calibration["base_parameters"]
    return np.array([v["value"] for v in record.values()])


def test_two_logs_stacked_give_the_truth(case):
    """Two runs 1e9 s apart: concatenated raw, the gap is refused; prepared
    one by one and stacked, OLS gives the truth to 1e-9 relative, equals the
    identification of the concatenated prepared samples, and every prepared
    sample of each log is used (1498 = 1500 minus the two one-sided ends)."""
    tmp, model, truth, logs = case
    a, b = logs["a"], logs["b"]
    with pytest.raises(ValueError, match="gap of 1e"):
        prepare_samples(np.r_[a.t, b.t], np.r_[a.q, b.q], np.r_[a.tau, b.tau])
    lines: list[str] = []
    out = identify_file(
        model, [tmp / "a.csv", tmp / "b.csv"], tmp / "ab.yaml", method="ols",
        echo=lines.append,
    )  # fmt: skip
    found = _base_values(out)
    assert np.abs(found - truth).max() < 1e-9 * np.abs(truth).max()
    parts = [prepare_samples(x.t, x.q, x.tau, x.qd, x.qdd) for x in (a, b)]
    assert [p.n_samples for p in parts] == [1498, 1498]
    joined = parts[0].select(slice(None))
    joined = type(joined)(
        **{k: np.concatenate([getattr(p, k) for p in parts])
           for k in ("t", "q", "qd", "qdd", "tau")},
        rate=RATE,
    )  # fmt: skip
    direct = identify(model, joined, method="ols").params
    np.testing.assert_allclose(found, direct, rtol=0, atol=1e-12 * np.abs(truth).max())
    record = load_robot(out).calibration
    assert record["logs"] == [str(tmp / "a.csv"), str(tmp / "b.csv")]
    assert record["samples"] == 2996
    assert any("1498 samples" in line for line in lines)


def test_padded_log_gives_the_unpadded_identification(case):
    """5 s of standstill at both ends, q and tau only (10 Hz filter, central
    differences): the standstill is found and removed (4.71 s at each end
    after the filter's 0.3 s edge trim) and the identification is that of the
    unpadded log within the filter's edge effect: the base parameters agree to
    2 % of the largest (measured 0.6 %; each is 4 % from the truth, the filter
    and differences' error). Kept, the standstill spoils the fit (70 %)."""
    tmp, model, truth, _ = case
    lines: list[str] = []
    kw = dict(method="ols", echo=lines.append)
    plain = _base_values(identify_file(model, tmp / "a_q.csv", tmp / "u.yaml", **kw))
    lines.clear()
    padded = _base_values(
        identify_file(model, tmp / "padded_q.csv", tmp / "p.yaml", **kw)
    )
    scale = np.abs(truth).max()
    assert np.abs(padded - plain).max() < 0.02 * scale
    assert np.abs(plain - truth).max() < 0.06 * scale
    assert any("4.71 s at the start and 4.71 s at the end" in x for x in lines)
    kept = _base_values(
        identify_file(
            model, tmp / "padded_q.csv", tmp / "k.yaml", idle_speed=0, force=True,
            **kw,
        )
    )  # fmt: skip
    assert np.abs(kept - truth).max() > 0.3 * scale


def test_trim_window_refusals(case):
    tmp, model, _, _ = case
    log = tmp / "a.csv"
    with pytest.raises(ValueError, match=r"a\.csv: trim 0:99: outside the log"):
        identify_file(model, log, tmp / "x.yaml", time_window=(0, 99), echo=print)
    with pytest.raises(ValueError, match=r"after trim: observations: .* for 52"):
        identify_file(model, log, tmp / "x.yaml", time_window=(5.0, 5.04))
    assert not (tmp / "x.yaml").exists()
