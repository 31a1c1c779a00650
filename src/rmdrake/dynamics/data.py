"""From a joint-space log to identification samples (paper §3.2, eq. 14-15).

A robot's log rarely has what the identification model needs: time stamps may be
irregular (the Panda logs 0.7..8.8 ms apart), accelerations are never measured
and velocities often not. :func:`prepare_samples` turns a log into uniformly
sampled, consistently filtered ``q, qd, qdd, tau``:

1. checks: strictly increasing time, no gap longer than ``max_gap`` times the
   median step, finite values, matching joint counts;
2. resampling to a uniform grid (linear interpolation) when the steps are
   irregular or a ``rate`` is asked for;
3. zero-phase low-pass filtering (Butterworth, forward-backward, ``cutoff`` Hz)
   of q, of qd when measured, and of tau *with the same filter*, so that torque
   and motion keep the same phase and gain;
4. central differences (second order, :func:`numpy.gradient`) for qd from the
   filtered q and for qdd from the filtered qd, where they are missing;
5. trimming of the filter's edge transients and optional decimation.

Before all this, an optional ``time_window`` keeps only a part of the log. After
it, standstill at the ends is found and removed (:func:`idle_ends`): a run of
samples at the start or end of at least ``idle_time`` s in which *every* joint
speed (of the prepared qd) is below ``idle_speed`` (rad/s or m/s) carries no
excitation, only static torques, and would outweigh the motion in the fit. A
warning is raised in :attr:`JointSamples.warnings` when more than ``idle_share``
of the samples left still have every joint speed below ``idle_speed``.

Several logs are prepared one by one and their samples stacked with
:func:`stack_samples`: no filter or derivative ever runs across two logs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.limits import check_memory

__all__ = [
    "IDLE_SHARE",
    "IDLE_SPEED",
    "IDLE_TIME",
    "MAX_DECIMATE",
    "MAX_RATE",
    "JointSamples",
    "check_preparation",
    "idle_ends",
    "lowpass",
    "parse_time_window",
    "prepare_samples",
    "stack_samples",
]

IDLE_SPEED = 1e-3
"""Default standstill threshold: every joint speed below it, rad/s or m/s."""
IDLE_TIME = 0.5
"""Default shortest standstill (s) removed at either end of a log."""
IDLE_SHARE = 0.3
"""Default share of still samples (after removal at the ends) that warns."""
MAX_RATE = 100_000.0
"""Hz: the highest resampling ``rate`` of a fleet (:func:`check_preparation`).
No robot controller logs its joints faster (the real logs here: 200 Hz, 573
Hz); above, the resampling only interpolates, and its size alone runs out of
memory."""
MAX_DECIMATE = 1000
"""The largest ``decimate``: one sample kept of a thousand leaves a 1 kHz log
at 1 Hz, below the excitation's harmonics."""


@dataclasses.dataclass(frozen=True)
class JointSamples:
    """Uniformly sampled joint data ready for the regressor.

    Attributes:
      t: (N,) time, s (uniform step ``1 / rate``).
      q: (N, n) joint positions, rad (m for a prismatic joint).
      qd: (N, n) joint velocities, rad/s or m/s.
      qdd: (N, n) joint accelerations, rad/s^2 or m/s^2.
      tau: (N, n) joint efforts, N m or N.
      rate: sample rate, Hz.
      notes: what was done to the log (resampled, filtered, differentiated,
        trimmed).
      warnings: what may spoil the identification (too little excitation).

    Example:

    >>> from rmdrake import JointSamples, load_robot, random_fourier_trajectory
    >>> t, q, qd, qdd = random_fourier_trajectory(load_robot("rv3sb")).sample(rate=50.0)
    >>> samples = JointSamples(t=t, q=q, qd=qd, qdd=qdd, tau=0 * q, rate=50.0)
    >>> samples.n_samples
    500
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    rate: float
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_joints(self) -> int:
        return int(self.q.shape[1])

    def split(self, fraction: float) -> tuple[JointSamples, JointSamples]:
        """The first ``fraction`` of the samples and the rest (no shuffling)."""
        if not 0.0 < fraction < 1.0:
            raise ValueError(f"split fraction: expected 0 < f < 1, found {fraction}")
        k = int(round(fraction * self.n_samples))
        return self.select(slice(0, k)), self.select(slice(k, None))

    def select(self, index: slice | np.ndarray) -> JointSamples:
        """The samples at ``index`` (a slice, mask or index array)."""
        return dataclasses.replace(
            self,
            t=self.t[index],
            q=self.q[index],
            qd=self.qd[index],
            qdd=self.qdd[index],
            tau=self.tau[index],
        )


def lowpass(x: np.ndarray, rate: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (``sosfiltfilt``).

    Args:
      x: (N, ...) uniformly sampled signal.
      rate: sample rate, Hz.
      cutoff: cut-off frequency, Hz (0 < cutoff < rate / 2).
      order: filter order (the forward-backward pass doubles it).
    """
    if not 0.0 < cutoff < rate / 2:
        raise ValueError(
            f"filter cutoff: expected 0 < cutoff < rate/2 = {rate / 2:g} Hz, "
            f"found {cutoff:g} Hz"
        )
    from scipy import signal  # here: 0.4 s to import, only filtering needs it

    sos = signal.butter(order, cutoff, fs=rate, output="sos")
    # Odd extension over three time constants of the cut-off keeps value and
    # slope continuous at the ends, so the edge transients stay small.
    padlen = min(x.shape[0] - 1, int(np.ceil(3 * rate / cutoff)))
    return signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)


def _check_time(t: np.ndarray, max_gap: float) -> float:
    dt = np.diff(t)
    if t.size < 3:
        raise ValueError(f"log: expected at least 3 samples, found {t.size}")
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        k = int(bad[0])
        raise ValueError(
            f"log: time is not strictly increasing at sample {k + 2} "
            f"(t = {t[k]:g} then {t[k + 1]:g} s)"
        )
    median = float(np.median(dt))
    gaps = np.flatnonzero(dt > max_gap * median)
    if gaps.size:
        k = int(gaps[0])
        raise ValueError(
            f"log: gap of {dt[k]:g} s after t = {t[k]:g} s "
            f"({dt[k] / median:.1f}x the median step {median:g} s; max {max_gap:g}x)"
        )
    return median


def prepare_samples(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    qd: np.ndarray | None = None,
    qdd: np.ndarray | None = None,
    *,
    rate: float | None = None,
    cutoff: float | None = None,
    order: int = 4,
    decimate: int = 1,
    trim: int | None = None,
    max_gap: float = 20.0,
    derivative_cutoff: float | None = None,
    time_window: tuple[float | None, float | None] | None = None,
    idle_speed: float | None = IDLE_SPEED,
    idle_time: float = IDLE_TIME,
    idle_share: float = IDLE_SHARE,
) -> JointSamples:
    """Uniform, filtered samples with velocities and accelerations.

    Args:
      t: (N,) time stamps, s, strictly increasing.
      q: (N, n) joint positions, rad (m for a prismatic joint).
      tau: (N, n) joint efforts, N m or N.
      qd: (N, n) measured velocities (rad/s or m/s), or None to differentiate q.
      qdd: (N, n) accelerations (rad/s^2 or m/s^2), or None to differentiate
        qd.
      rate: resample to this rate (Hz). Default: keep the samples when the steps
        are uniform (spread < 1 %), else resample at 1 / median step.
      cutoff: low-pass cut-off (Hz) of all signals. Default: no filter when qd
        and qdd are both given or ``derivative_cutoff`` is, else
        min(10 Hz, rate / 5). Use 0 to disable filtering.
      order: Butterworth order.
      decimate: keep every ``decimate``-th sample after filtering.
      trim: samples dropped at each end after filtering (edge transients of the
        forward-backward filter, which pads by odd extension over 3 / cutoff s).
        Default: 3 rate / cutoff samples when filtering, 1 when only
        differentiating (the one-sided differences at the ends).
      max_gap: largest accepted step, as a multiple of the median step.
      derivative_cutoff: if given (Hz), missing derivatives are taken of a
        signal low-passed at this frequency *inside the differentiation only*:
        q, qd and tau themselves stay unfiltered (with ``cutoff=0``). Use it
        when the drive logs q and qd but not qdd: a filtered torque smooths the
        Coulomb step at every velocity reversal, which no model of the
        unfiltered states reproduces, while qdd needs the low-pass.
      time_window: (start, end), s relative to the first time stamp: only the
        samples in [start, end] are used (None on either side: the log's
        start or end). Applied first, before resampling and filtering.
      idle_speed: standstill threshold, rad/s or m/s (see the module
        docstring); None or 0 keeps standstill at the ends and never warns.
      idle_time: shortest standstill removed at an end, s.
      idle_share: share (0..1) of still samples left that raises a warning.

    Raises:
      ValueError: non-monotonic time, gaps, NaN, shape mismatches, a
        decimate out of bounds (:func:`check_preparation`), a rate whose
        samples are over the memory cap, a time window outside the log, too
        few samples left after trimming, a log with no joint ever faster than
        ``idle_speed``.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, prepare_samples, random_fourier_trajectory
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=100.0)
    >>> tau = np.zeros_like(q)
    >>> samples = prepare_samples(t, q, tau)  # qd, qdd by filtered differences
    >>> round(samples.rate, 6), samples.q.shape[1], samples.n_samples < len(t)
    (100.0, 6, True)
    """
    log = _checked_log(t, q, tau, qd, qdd)
    check_preparation(decimate=decimate)  # a rate: the memory cap of _resample
    median = _check_time(log.t, max_gap)
    notes: list[str] = []
    if time_window is not None:
        log, median = _keep_window(log, time_window, max_gap, notes)
    if rate is None:
        rate = 1.0 / median
    log = _resample(log, rate, median, notes)
    if cutoff is None:
        complete = log.qd is not None and log.qdd is not None
        cutoff = 0.0 if complete or derivative_cutoff else min(10.0, rate / 5)
    if cutoff > 0:
        log = _lowpass_log(log, rate, cutoff, order, notes)
    qd, qdd = _differentiate(log, rate, derivative_cutoff, order, notes)
    begin, end = _trim_range(log.t.shape[0], trim, rate, cutoff, derivative_cutoff)
    warnings: list[str] = []
    if idle_speed:
        begin, end = _drop_standstill(
            qd[begin:end],
            begin,
            end,
            rate=rate,
            idle_speed=idle_speed,
            idle_time=idle_time,
            idle_share=idle_share,
            notes=notes,
            warnings=warnings,
        )
    keep = slice(begin, end, decimate)
    samples = JointSamples(
        t=log.t[keep],
        q=log.q[keep],
        qd=qd[keep],
        qdd=qdd[keep],
        tau=log.tau[keep],
        rate=rate / decimate,
        notes=tuple(notes),
        warnings=tuple(warnings),
    )
    if samples.n_samples < 2:
        raise ValueError(
            f"log: {samples.n_samples} samples left after trimming; the log is too "
            f"short ({log.t.shape[0]} samples)"
        )
    return samples


# ---- the steps of prepare_samples, in order -----------------------------------------
@dataclasses.dataclass(frozen=True)
class _Log:
    """A joint log on its way to :class:`JointSamples`.

    Attributes:
      t: (N,) time stamps, s.
      q: (N, n) joint positions, rad or m.
      tau: (N, n) joint efforts, N m or N.
      qd: (N, n) joint velocities, rad/s or m/s; None when not measured.
      qdd: (N, n) joint accelerations, rad/s^2 or m/s^2; None when not
        measured.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None

    def with_signals(
        self, t: np.ndarray, f: Callable[[np.ndarray], np.ndarray]
    ) -> _Log:
        """The log at time stamps ``t`` (s) with signals f(q), f(tau), and
        f(qd), f(qdd) where measured."""
        return _Log(
            t=t,
            q=f(self.q),
            tau=f(self.tau),
            qd=None if self.qd is None else f(self.qd),
            qdd=None if self.qdd is None else f(self.qdd),
        )


def _checked_log(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    qd: np.ndarray | None,
    qdd: np.ndarray | None,
) -> _Log:
    """The arrays of :func:`prepare_samples` as a :class:`_Log` (float arrays;
    units there).

    Raises:
      ValueError: NaN or infinite values, shapes that do not match (N,) and
        (N, n).
    """
    t = as_finite_array(t, "log t", (None,))
    N = t.shape[0]
    q = as_finite_array(q, "log q", (N, None))
    n = q.shape[1]
    tau = as_finite_array(tau, "log tau", (N, n))
    qd = None if qd is None else as_finite_array(qd, "log qd", (N, n))
    qdd = None if qdd is None else as_finite_array(qdd, "log qdd", (N, n))
    return _Log(t=t, q=q, tau=tau, qd=qd, qdd=qdd)


def _keep_window(
    log: _Log,
    window: tuple[float | None, float | None],
    max_gap: float,
    notes: list[str],
) -> tuple[_Log, float]:
    """The samples of ``log`` in ``window`` (s from its first time stamp) and
    their median step (s); appends what was kept to ``notes``.

    Raises:
      ValueError: a window outside the log or leaving fewer than 3 samples,
        a gap in what is kept.
    """
    t_first = float(log.t[0])
    keep_t = _window_mask(log.t, window)
    log = log.with_signals(log.t[keep_t], lambda x: x[keep_t])
    t = log.t
    notes.append(
        f"kept {t[0] - t_first:g} to {t[-1] - t_first:g} s of the log (time window)"
    )
    return log, _check_time(t, max_gap)


def _resample(log: _Log, rate: float, median: float, notes: list[str]) -> _Log:
    """``log`` linearly interpolated onto a uniform grid at ``rate`` Hz from its
    first time stamp, unless its steps are already uniform (spread <= 1 % of
    the ``median`` step, s) at that rate; appends a note when resampled.

    Raises:
      MemoryError: the resampled log over the memory cap.
    """
    t = log.t
    dt = np.diff(t)
    uniform = float(dt.max() - dt.min()) <= 0.01 * median
    if uniform and not abs(rate * median - 1.0) > 1e-9:  # not <=: a NaN resamples
        return log
    n = log.q.shape[1]
    M = (t[-1] - t[0]) * rate + 1  # float: no overflow before the check
    check_memory(
        M * (2 + 4 * n),
        f"resampling {t[-1] - t[0]:.6g} s of log at {rate:g} Hz ({M:.3g} samples)",
        "lower the rate",
    )
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate)) + 1) / rate
    notes.append(f"resampled to {rate:g} Hz (linear interpolation)")
    return log.with_signals(grid, lambda x: _interp(grid, t, x))


def _lowpass_log(
    log: _Log, rate: float, cutoff: float, order: int, notes: list[str]
) -> _Log:
    """``log`` (uniform at ``rate`` Hz) with every signal through the same
    zero-phase Butterworth low-pass (:func:`lowpass`, ``cutoff`` Hz); appends
    a note."""
    log = log.with_signals(log.t, lambda x: lowpass(x, rate, cutoff, order))
    notes.append(
        f"zero-phase Butterworth low-pass, order {order}, {cutoff:g} Hz, on q, "
        "qd, qdd and tau alike"
    )
    return log


def _differentiate(
    log: _Log,
    rate: float,
    derivative_cutoff: float | None,
    order: int,
    notes: list[str],
) -> tuple[np.ndarray, np.ndarray]:
    """(qd, qdd), (N, n) each in rad/s and rad/s^2 or m/s and m/s^2: the
    measured ones, else central differences of q and qd (uniform at ``rate``
    Hz), taken of the signal low-passed at ``derivative_cutoff`` Hz when
    given; appends a note per derivative taken."""

    def smooth(x: np.ndarray) -> np.ndarray:
        if derivative_cutoff is None:
            return x
        return lowpass(x, rate, derivative_cutoff, order)

    qd, qdd = log.qd, log.qdd
    if derivative_cutoff is not None and (qd is None or qdd is None):
        notes.append(
            f"derivatives of signals low-passed at {derivative_cutoff:g} Hz (zero "
            "phase); the signals themselves kept as logged"
        )
    if qd is None:
        qd = np.gradient(smooth(log.q), 1.0 / rate, axis=0)
        notes.append("qd by central differences of q")
    if qdd is None:
        qdd = np.gradient(smooth(qd), 1.0 / rate, axis=0)
        notes.append("qdd by central differences of qd")
    return qd, qdd


def _trim_range(
    size: int,
    trim: int | None,
    rate: float,
    cutoff: float,
    derivative_cutoff: float | None,
) -> tuple[int, int]:
    """[begin, end) of the ``size`` samples left after dropping ``trim`` at
    each end; default ``trim``: 3 rate / (lowest cut-off, Hz) samples when
    filtered, else 1.

    Raises:
      ValueError: fewer than 2 samples left.
    """
    if trim is None:
        lowest = min(cutoff if cutoff > 0 else np.inf, derivative_cutoff or np.inf)
        trim = int(np.ceil(3 * rate / lowest)) if np.isfinite(lowest) else 1
    begin, end = trim, size - trim
    if end - begin < 2:
        raise ValueError(
            f"log: {max(end - begin, 0)} samples left after trimming {trim} at "
            f"each end; the log is too short for the filter ({size} samples)"
        )
    return begin, end


def _drop_standstill(
    qd: np.ndarray,
    begin: int,
    end: int,
    *,
    rate: float,
    idle_speed: float,
    idle_time: float,
    idle_share: float,
    notes: list[str],
    warnings: list[str],
) -> tuple[int, int]:
    """[begin, end) without the standstill at its ends (:func:`idle_ends` of
    ``qd``, the (end - begin, n) velocities in rad/s or m/s there, at ``rate``
    Hz; ``idle_speed`` rad/s or m/s, ``idle_time`` s); appends a note of what
    was removed, and a warning when more than ``idle_share`` of the samples
    left are still.

    Raises:
      ValueError: no joint ever faster than ``idle_speed``.
    """
    head, tail, still = idle_ends(qd, rate, idle_speed, idle_time)
    removed = [
        f"{k / rate:.3g} s at the {side}"
        for k, side in ((head, "start"), (tail, "end"))
        if k
    ]
    if removed:
        notes.append(
            f"removed standstill (every joint speed < {idle_speed:g} rad/s or "
            f"m/s for >= {idle_time:g} s): {' and '.join(removed)}"
        )
    share = float(np.mean(still[head : still.size - tail]))
    if share > idle_share:
        warnings.append(
            f"{100 * share:.0f} % of the samples have every joint speed below "
            f"{idle_speed:g} rad/s or m/s (more than {100 * idle_share:.0f} %): "
            "little excitation; the fit may be poor"
        )
    return begin + head, end - tail


def idle_ends(
    qd: np.ndarray, rate: float, speed: float, min_time: float
) -> tuple[int, int, np.ndarray]:
    """Standstill at the ends of uniformly sampled joint velocities.

    Args:
      qd: (N, n) joint velocities, rad/s or m/s.
      rate: sample rate, Hz.
      speed: threshold, rad/s or m/s: a sample is still when every joint's
        speed is below it.
      min_time: a still run at an end is counted only when it lasts at least
        this long, s.

    Returns:
      (head, tail, still): the numbers of still samples to drop at the start
      and the end (0 when that run is shorter than ``min_time``), and the (N,)
      boolean still mask.

    Raises:
      ValueError: no sample has any joint faster than ``speed``.
    """
    still = np.abs(qd).max(axis=1) < speed
    moving = np.flatnonzero(~still)
    if moving.size == 0:
        raise ValueError(
            f"log: no joint moves faster than {speed:g} rad/s or m/s (idle "
            "speed): nothing to identify"
        )
    head, tail = int(moving[0]), int(still.size - 1 - moving[-1])
    shortest = min_time * rate
    return (head if head >= shortest else 0), (tail if tail >= shortest else 0), still


def _window_mask(
    t: np.ndarray, window: tuple[float | None, float | None]
) -> np.ndarray:
    """Samples of ``t`` inside ``window`` (s from t[0]); refuses a window
    outside the log or leaving fewer than 3 samples."""
    duration = float(t[-1] - t[0])
    start = 0.0 if window[0] is None else float(window[0])
    end = duration if window[1] is None else float(window[1])
    shown = f"{'' if window[0] is None else f'{start:g}'}:" + (
        "" if window[1] is None else f"{end:g}"
    )
    if not (0.0 <= start < end <= duration * (1 + 1e-12)):
        raise ValueError(
            f"trim {shown}: outside the log (0 to {duration:g} s from its first "
            "time stamp) or empty"
        )
    rel = t - t[0]
    mask = (rel >= start) & (rel <= end)
    if np.count_nonzero(mask) < 3:
        raise ValueError(
            f"trim {shown}: leaves {np.count_nonzero(mask)} samples; expected at "
            "least 3"
        )
    return mask


def parse_time_window(text: str) -> tuple[float | None, float | None]:
    """``"START:END"`` (s; either side may be empty) as (start, end)."""
    parts = text.split(":")
    if len(parts) != 2:
        raise ValueError(f"trim: expected START:END in s, found {text!r}")
    try:
        start, end = (float(p) if p.strip() else None for p in parts)
    except ValueError:
        raise ValueError(f"trim: expected START:END in s, found {text!r}") from None
    if any(v is not None and not np.isfinite(v) for v in (start, end)):
        raise ValueError(f"trim: expected finite START:END in s, found {text!r}")
    if start is not None and end is not None and not end > start:
        raise ValueError(
            f"trim {text}: END {end:g} s is not after START {start:g} s; the window "
            "keeps START:END, s from each log's start"
        )
    if start is not None and start < 0 or end is not None and end <= 0:
        raise ValueError(
            f"trim {text}: s from each log's start, expected START >= 0 and END > 0"
        )
    return start, end


def check_preparation(
    *,
    rate: float | None = None,
    decimate: int = 1,
    **_other: object,
) -> None:
    """Refuses the options of :func:`prepare_samples` that no log can satisfy,
    before any log is read (``fleet``: one refusal, not a failed row per
    arm): a ``rate`` (Hz) not finite, <= 0 or over :data:`MAX_RATE` (one log
    alone is held to the memory cap of its samples instead), a ``decimate``
    not an integer in 1..:data:`MAX_DECIMATE` (a time window is checked as it
    is parsed, :func:`parse_time_window`). Other keyword options are ignored
    (checked where they are used).

    Raises:
      ValueError: one line naming the option and its bound.
    """
    if rate is not None and not (np.isfinite(rate) and 0 < rate <= MAX_RATE):
        raise ValueError(
            f"rate {rate:g} Hz: expected a rate in (0, {MAX_RATE:g}] Hz (no joint "
            "log is sampled faster; resampling above the log's rate adds nothing)"
        )
    if int(decimate) != decimate or not 1 <= decimate <= MAX_DECIMATE:
        raise ValueError(
            f"decimate {decimate:g}: expected an integer in 1..{MAX_DECIMATE} (keep "
            "every k-th sample; more leaves too few samples of the motion)"
        )


def stack_samples(parts: Sequence[JointSamples]) -> JointSamples:
    """The samples of several prepared logs, one after the other (their
    equations stacked). ``t`` keeps each log's own time stamps, so it is not
    increasing across logs; each part was prepared alone, so no filter or
    derivative crosses a boundary.

    Raises:
      ValueError: no parts, different joint counts or rates (resample alike).
    """
    if not parts:
        raise ValueError("stack: expected at least one set of samples")
    first = parts[0]
    if len(parts) == 1:
        return first
    for k, p in enumerate(parts[1:], start=2):
        if p.n_joints != first.n_joints:
            raise ValueError(
                f"stack: log {k} has {p.n_joints} joints, log 1 has {first.n_joints}"
            )
        if abs(p.rate - first.rate) > 1e-3 * first.rate:  # stamps ~1e9 s: ~1e-5
            raise ValueError(
                f"stack: log {k} is sampled at {p.rate:g} Hz, log 1 at "
                f"{first.rate:g} Hz; resample them alike (give a rate)"
            )
    counts = ", ".join(str(p.n_samples) for p in parts)
    notes = dict.fromkeys(n for p in parts for n in p.notes)  # ordered, unique
    return JointSamples(
        **{
            key: np.concatenate([getattr(p, key) for p in parts])
            for key in ("t", "q", "qd", "qdd", "tau")
        },
        rate=first.rate,
        notes=(*notes, f"{len(parts)} logs stacked ({counts} samples)"),
        warnings=tuple(w for p in parts for w in p.warnings),
    )


def _interp(grid: np.ndarray, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Linear interpolation of the columns of x (N, n) onto ``grid``."""
    return np.stack([np.interp(grid, t, x[:, j]) for j in range(x.shape[1])], axis=1)
