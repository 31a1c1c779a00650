"""Data preparation: resampling, zero-phase filtering and differentiation
recover the analytic derivatives of a known motion; bad logs are refused."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.data import (
    lowpass,
    parse_time_window,
    prepare_samples,
    stack_samples,
)


def motion(t):
    """Two joints, 0.2 Hz and 0.5 Hz sines: q, qd, qdd analytic."""
    w = 2 * np.pi * np.array([0.2, 0.5])
    a = np.array([0.8, 0.3])
    q = a * np.sin(w * t[:, None])
    qd = a * w * np.cos(w * t[:, None])
    qdd = -a * w**2 * np.sin(w * t[:, None])
    return q, qd, qdd


def test_irregular_log_gives_analytic_derivatives():
    """Irregular 1 kHz-ish stamps (0.7..1.3 ms), no qd/qdd: after resampling,
    10 Hz filtering and central differences, qd and qdd match the analytic
    derivatives to 2e-5 and 5e-4 (relative to their peaks; qdd carries the
    interpolation error of the irregular stamps, differentiated twice)."""
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.7e-3, 1.3e-3, 12000))
    q, qd, qdd = motion(t)
    tau = 2.0 * qdd + 0.5 * qd  # any signal: filtered with the same filter
    s = prepare_samples(t, q, tau, rate=1000.0, cutoff=10.0)
    assert s.rate == 1000.0
    np.testing.assert_allclose(np.diff(s.t), 1e-3, rtol=1e-9)
    q_, qd_, qdd_ = motion(s.t)
    assert np.abs(s.q - q_).max() < 1e-5 * np.abs(q_).max()
    assert np.abs(s.qd - qd_).max() < 2e-5 * np.abs(qd_).max()
    assert np.abs(s.qdd - qdd_).max() < 5e-4 * np.abs(qdd_).max()
    tau_expected = 2.0 * qdd_ + 0.5 * qd_
    assert np.abs(s.tau - tau_expected).max() < 5e-4 * np.abs(tau_expected).max()
    assert any("resampled" in n for n in s.notes)
    assert any("qdd by central differences" in n for n in s.notes)


def test_uniform_log_with_derivatives_is_kept_as_is():
    t = np.arange(1500) / 150.0
    q, qd, qdd = motion(t)
    s = prepare_samples(t, q, qd, qd, qdd)  # tau = qd, for the check
    np.testing.assert_array_equal(s.q, q[1:-1])
    np.testing.assert_array_equal(s.qdd, qdd[1:-1])
    assert s.notes == ()


def test_lowpass_removes_noise_without_phase_lag():
    rate = 500.0
    t = np.arange(5000) / rate
    clean = np.sin(2 * np.pi * 1.0 * t)
    noisy = clean + 0.1 * np.random.default_rng(0).standard_normal(t.size)
    out = lowpass(noisy, rate, 5.0)
    # Noise of std 0.1 in a 5 Hz band of 250 Hz: about 0.014 left.
    assert np.std(out - clean) < 0.02
    # Zero phase: the best-matching shift of the output is no shift.
    lags = range(-20, 21)
    fits = [np.sum((np.roll(out, k) - clean)[100:-100] ** 2) for k in lags]
    assert list(lags)[int(np.argmin(fits))] == 0
    with pytest.raises(ValueError, match="filter cutoff"):
        lowpass(noisy, rate, 300.0)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t, q: (np.r_[t[:5], t[4], t[6:]], q), "not strictly increasing"),
        (lambda t, q: (np.r_[t[:50], t[50:] + 1.0], q), "gap of 1.0"),
        (lambda t, q: (t, np.where(np.arange(len(t))[:, None] == 7, np.nan, q)),
         "log q: expected finite"),
        (lambda t, q: (t, q[:, :1]), r"log tau: expected shape"),
        (lambda t, q: (t[:2], q[:2]), "at least 3 samples"),
    ],
)  # fmt: skip
def test_bad_logs_are_refused(edit, message):
    t = np.arange(200) / 100.0
    q, _, _ = motion(t)
    t2, q2 = edit(t, q)
    tau = np.zeros((len(t2), 2))
    with pytest.raises(ValueError, match=message):
        prepare_samples(t2, q2, tau)


def test_too_short_for_the_filter():
    t = np.arange(50) / 100.0
    q, _, _ = motion(t)
    with pytest.raises(ValueError, match="too short for the filter"):
        prepare_samples(t, q, q, cutoff=2.0)


def test_derivative_cutoff_keeps_signals_raw():
    """With derivative_cutoff, q, qd and tau are returned as logged while qdd
    is the derivative of the low-passed qd (to 5e-4 of its peak here)."""
    t = np.arange(3000) / 150.0
    q, qd, qdd = motion(t)
    rng = np.random.default_rng(1)
    tau = np.sign(qd) + 0.01 * rng.standard_normal(qd.shape)  # Coulomb steps
    s = prepare_samples(t, q, tau, qd, derivative_cutoff=5.0)
    k = slice(90, 3000 - 90)  # trim = 3 rate / 5 Hz
    np.testing.assert_array_equal(s.tau, tau[k])
    np.testing.assert_array_equal(s.qd, qd[k])
    assert np.abs(s.qdd - qdd[k]).max() < 5e-4 * np.abs(qdd).max()
    assert any("kept as logged" in n for n in s.notes)


def test_stacked_logs_stay_apart():
    """Two logs 1e9 s apart, filtered and differentiated one by one: the stack
    is their samples one after the other, bit for bit those of each log
    prepared alone (nothing lost or mixed at the boundary)."""
    t = np.arange(2000) / 100.0
    q, _, _ = motion(t)
    a = prepare_samples(t, q, q)
    b = prepare_samples(t + 1e9, q[::-1], q[::-1])
    s = stack_samples([a, b])
    # 31 dropped at each end: ceil(3 rate / 10 Hz), rate = 1 / median step
    assert s.n_samples == a.n_samples + b.n_samples == 2 * (2000 - 2 * 31)
    for key in ("t", "q", "qd", "qdd", "tau"):
        np.testing.assert_array_equal(getattr(s, key)[: a.n_samples], getattr(a, key))
        np.testing.assert_array_equal(getattr(s, key)[a.n_samples :], getattr(b, key))
    assert s.t[a.n_samples - 1] < 20 and s.t[a.n_samples] > 1e9
    assert "2 logs stacked (1938, 1938 samples)" in s.notes
    with pytest.raises(ValueError, match="log 2 has 1 joints"):
        stack_samples([a, prepare_samples(t, q[:, :1], q[:, :1])])
    with pytest.raises(ValueError, match="sampled at 50 Hz, log 1 at 100 Hz"):
        stack_samples([a, prepare_samples(t[::2], q[::2], q[::2])])


def test_time_window_keeps_the_part_of_the_log():
    t = 5.0 + np.arange(1000) / 100.0  # 0..9.99 s from the first stamp
    q, _, _ = motion(t)
    s = prepare_samples(t, q, q, cutoff=0, time_window=(2.0, None))
    alone = prepare_samples(t[200:], q[200:], q[200:], cutoff=0)
    np.testing.assert_array_equal(s.qdd, alone.qdd)
    assert "kept 2 to 9.99 s of the log (time window)" in s.notes
    assert parse_time_window("2:") == (2.0, None)
    assert parse_time_window(":3.5") == (None, 3.5)
    for window, message in [
        ((-1.0, None), r"trim -1:: outside the log \(0 to 9.99 s"),
        ((None, 11.0), "trim :11: outside"),
        ((5.0, 5.0), "trim 5:5: outside the log .* or empty"),
        ((5.0, 5.015), "trim 5:5.015: leaves 2 samples"),
    ]:
        with pytest.raises(ValueError, match=message):
            prepare_samples(t, q, q, time_window=window)
    for text in ("1", "a:b", "1:2:3", "nan:"):
        with pytest.raises(ValueError, match="trim: expected"):
            parse_time_window(text)


def test_standstill_at_the_ends_is_removed_and_a_still_log_warns():
    """3 s still before a motion (sines from rest would not be: use q = 0 then
    the motion's q shifted to start at rest); removed from the start only and
    said; a still middle holding 40 % of the samples warns (> 30 %)."""
    rate = 100.0
    t = np.arange(1300) / rate
    still = t < 3.0
    q, qd, qdd = motion(t - 3.0)
    q = np.where(still[:, None], 0.0, q)
    qd = np.where(still[:, None], 0.0, qd)
    qdd = np.where(still[:, None], 0.0, qdd)
    s = prepare_samples(t, q, q, qd, qdd)  # no filter: trim 1 at each end
    assert s.t[0] == pytest.approx(3.0, abs=0.015)
    assert any("2.99 s at the start" in n and "end" not in n for n in s.notes)
    assert s.warnings == ()
    middle = (t > 5) & (t < 9.5)
    qd_m = np.where(middle[:, None], 0.0, qd)
    s = prepare_samples(t, q, q, qd_m, qdd)
    assert len(s.warnings) == 1 and "more than 30 %" in s.warnings[0]
    kept = prepare_samples(t, q, q, qd, qdd, idle_speed=0)
    assert kept.n_samples == 1298 and not any("standstill" in n for n in kept.notes)
    with pytest.raises(ValueError, match="no joint moves faster than 0.001"):
        prepare_samples(t, q, q, 0 * qd, qdd)
