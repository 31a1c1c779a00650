"""The evidence a wrong joint log leaves where the torque is.

A log of another robot, with joints in another order, a torque of the other
sign, in another unit or on another time base than the motion still fits a
flexible model on the joints that carry little torque; on the joints that
carry the torque it leaves marks that a right log does not. This module
measures them (numbers in, numbers out: no rule, no message; the rule that
refuses on them is :mod:`rmdrake.dynamics.sanity`).

Loaded joints. Joint j is *loaded* when its torque RMS is at least
``share`` times the largest joint's (:func:`loaded_joints`): on the real
KUKA LWR4+ joints 2 and 4 (RMS 20-25 and 10 N m) and 3 (0.08-0.12 of joint
2's), on the real Panda joints 1-4. A joint under that (the LWR4's 1, 5, 6
and 7 at 0.01-0.05) is mostly sensor offset, friction and noise.

Shift and swap (:func:`fit_evidence`, :func:`prediction_evidence`). The
torque b is moved against the motion by each lag of ``lags`` (the torque
logged ``lag`` seconds later is paired with the motion now), and the torques
of each pair of loaded joints are exchanged; each variant is fitted again by
least squares on the same regressor A (or, for a prediction, compared with
it), and its residual sum of squares is compared with the log's as written:

* ``lag``, ``lag_ratio``: the lag of least residual and that residual over
  the unshifted one, over all joints (energy);
* ``swaps``: per loaded pair (a, b), sqrt(RSS_a + RSS_b) swapped over
  sqrt(RSS_a + RSS_b) as logged.

The fit is one QR factorisation of A on at most :data:`EVIDENCE_SAMPLES`
evenly spaced samples (a variant costs one product with Q^T), the rows kept
where every lag stays inside one log (stacked logs are not shifted across
their boundary). Example: a torque 0.3 s late on the real LWR4 gives
``lag`` +0.32 s, ``lag_ratio`` 0.56; joints 2 and 4 swapped give a swap ratio
of 0.4 for (2, 4), a right log over 1.5 for every pair.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

__all__ = [
    "EVIDENCE_SAMPLES",
    "LAG_RANGE",
    "LogEvidence",
    "fit_evidence",
    "loaded_joints",
    "log_parts",
    "positions_outside",
    "prediction_evidence",
]

EVIDENCE_SAMPLES = 4000
"""Samples (evenly spaced) the shift and swap fits use at most."""

LAG_RANGE = 0.5
"""s: the lags tried run from -LAG_RANGE to +LAG_RANGE."""

LAG_STEP = 0.02
"""s: step of the lags tried (at least one sample)."""


@dataclasses.dataclass(frozen=True)
class LogEvidence:
    """What shifting and swapping the torque does to the residual.

    Attributes:
      lag: s, the shift of the torque against the motion with the least
        residual (positive: the torque is logged late).
      lag_ratio: that residual over the unshifted one (energy, all joints).
      swaps: per pair of loaded joints (a, b) (0-based), the RMS residual of
        the two joints with their torques exchanged over the logged one.
    """

    lag: float
    lag_ratio: float
    swaps: tuple[tuple[int, int, float], ...]


def loaded_joints(rms: np.ndarray, share: float) -> np.ndarray:
    """(n,) bool: joints whose torque RMS ``rms`` (n,) is at least ``share``
    times the largest (module docstring)."""
    rms = np.asarray(rms, dtype=np.float64)
    return rms >= share * max(float(rms.max()), 1e-300)


def log_parts(t: np.ndarray, rate: float) -> np.ndarray:
    """(N,) index of the log each sample belongs to: stacked logs keep their
    own time stamps (:func:`~rmdrake.dynamics.data.stack_samples`), so a
    step that is not 1 / ``rate`` (within half a step) starts a new log."""
    step = np.diff(np.asarray(t, dtype=np.float64))
    new = np.abs(step * rate - 1.0) > 0.5
    return np.concatenate([[0], np.cumsum(new)])


def _rows(parts: np.ndarray, k_max: int, limit: int) -> np.ndarray:
    """At most ``limit`` evenly spaced sample indices i whose i - k_max and
    i + k_max lie in the same log as i."""
    N = parts.size
    i = np.arange(k_max, N - k_max)
    i = i[(parts[i - k_max] == parts[i]) & (parts[i + k_max] == parts[i])]
    if i.size > limit:
        i = i[np.linspace(0, i.size - 1, limit).round().astype(int)]
    return i


def _lags(rate: float) -> np.ndarray:
    """The lags tried, in samples (unique, sorted, 0 included)."""
    step = max(1, int(round(LAG_STEP * rate)))
    k_max = int(round(LAG_RANGE * rate))
    k = np.arange(0, k_max + 1, step)
    return np.unique(np.concatenate([-k, k]))


def _evidence(
    rss: Callable[[np.ndarray], np.ndarray],
    tau: np.ndarray,
    rows: np.ndarray,
    lags: np.ndarray,
    loaded: np.ndarray,
    rate: float,
) -> LogEvidence:
    """The evidence from ``rss``, which maps torques (R, n, V) on ``rows``
    (V variants) to (n, V) residual sums of squares."""
    shifted = np.stack([tau[rows + k] for k in lags], axis=2)  # (R, n, lags)
    energy = rss(shifted).sum(axis=0)
    zero = int(np.flatnonzero(lags == 0)[0])
    best = int(np.argmin(energy))
    ratio = float(energy[best] / max(float(energy[zero]), 1e-300))
    logged = tau[rows]
    pairs = [
        (int(a), int(b))
        for a in np.flatnonzero(loaded)
        for b in np.flatnonzero(loaded)
        if a < b
    ]
    swaps: list[tuple[int, int, float]] = []
    if pairs:
        variants = np.repeat(logged[:, :, None], len(pairs) + 1, axis=2)
        for v, (a, b) in enumerate(pairs, start=1):
            variants[:, [a, b], v] = logged[:, [b, a]]
        r = rss(variants)
        for v, (a, b) in enumerate(pairs, start=1):
            before = max(float(r[a, 0] + r[b, 0]), 1e-300)
            swaps.append((a, b, float(np.sqrt((r[a, v] + r[b, v]) / before))))
    return LogEvidence(float(lags[best] / rate), ratio, tuple(swaps))


def fit_evidence(
    regressor: Callable[[np.ndarray], np.ndarray],
    tau: np.ndarray,
    t: np.ndarray,
    rate: float,
    loaded: np.ndarray,
) -> LogEvidence:
    """The shift and swap evidence of a least-squares fit (module docstring).

    Args:
      regressor: maps sample indices (R,) to the regressor (R, n, p) of the
        fitted parameters at those samples.
      tau: (N, n) logged efforts, N m or N; ``t`` (N,) s; ``rate`` Hz.
      loaded: (n,) bool, the loaded joints (:func:`loaded_joints`).
    """
    tau = np.asarray(tau, dtype=np.float64)
    n = tau.shape[1]
    lags = _lags(rate)
    rows = _rows(log_parts(t, rate), int(np.abs(lags).max()), EVIDENCE_SAMPLES)
    if rows.size == 0:
        return LogEvidence(0.0, 1.0, ())
    Y = regressor(rows)
    R, _, p = Y.shape
    Q = np.linalg.qr(Y.reshape(R * n, p))[0]

    def rss(b: np.ndarray) -> np.ndarray:
        flat = b.reshape(R * n, -1)
        e = flat - Q @ (Q.T @ flat)
        return np.sum(e.reshape(R, n, -1) ** 2, axis=0)

    return _evidence(rss, tau, rows, lags, loaded, rate)


def prediction_evidence(
    predicted: np.ndarray,
    measured: np.ndarray,
    t: np.ndarray,
    rate: float,
    loaded: np.ndarray,
) -> LogEvidence:
    """The shift and swap evidence of a model's prediction (N, n) against the
    measured efforts (N, n), N m or N (module docstring; no refit)."""
    measured = np.asarray(measured, dtype=np.float64)
    predicted = np.asarray(predicted, dtype=np.float64)
    lags = _lags(rate)
    rows = _rows(log_parts(t, rate), int(np.abs(lags).max()), measured.shape[0])
    if rows.size == 0:
        return LogEvidence(0.0, 1.0, ())
    p = predicted[rows][:, :, None]

    def rss(b: np.ndarray) -> np.ndarray:
        return np.sum((b - p) ** 2, axis=0)

    return _evidence(rss, measured, rows, lags, loaded, rate)


def positions_outside(
    q: np.ndarray, lower: np.ndarray, upper: np.ndarray, margin: float
) -> tuple[float, np.ndarray]:
    """(share, past): the share of samples with some joint position beyond
    its limits by more than ``margin`` times the joint's range, and (n,) per
    joint the largest distance past a limit (rad or m; 0 inside). Infinite
    limits are never passed.

    Example: the LWR4's log read with the Panda's model has 100 % of its
    samples outside (the Panda's joint 4 stays below -0.07 rad); a right log
    0 %."""
    q = np.asarray(q, dtype=np.float64)
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    span = np.where(np.isfinite(upper - lower), upper - lower, np.inf)
    past = np.maximum(lower - q, q - upper)  # (N, n), > 0 outside
    outside = np.any(past > margin * span, axis=1)
    return float(np.mean(outside)) if q.size else 0.0, np.maximum(past.max(0), 0.0)
