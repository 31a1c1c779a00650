"""Fourier-series joint trajectories (paper eq. 11-13) and their YAML file.

A :class:`FourierTrajectory` is the finite Fourier series of the paper's eq. 11-13
plus a constant offset ``q0``, per joint i = 1..n and harmonic l = 1..N, with
omega_f = 2 pi base_frequency (base_frequency in Hz)::

    q_i(t)   = q0_i + sum_l a_il/(omega_f l) sin(omega_f l t)
                    - b_il/(omega_f l) cos(omega_f l t)              (11)
    qd_i(t)  = sum_l a_il cos(omega_f l t) + b_il sin(omega_f l t)   (12)
    qdd_i(t) = omega_f sum_l b_il l cos(omega_f l t)
                    - a_il l sin(omega_f l t)                        (13)

Units: q in rad, qd in rad/s, qdd in rad/s^2, t in s; a and b are velocity
amplitudes in rad/s. The trajectory is periodic with period 1/base_frequency. When
the coefficients satisfy the paper's eq. 17 equalities (sum_l b_il/(omega_f l) = 0,
sum_l a_il = 0, sum_l l b_il = 0) it starts at rest at q0.

:func:`fourier_series` is the one evaluation of these sums in rmdrake: the
trajectory's methods, the excitation design (a population of coefficient sets
at once) and :class:`rmdrake.systems.FourierExcitationSource` all call it.

The YAML file holds exactly these five keys (numbers in the units above; a and b
have one row of N coefficients per joint, as many rows as q0 has entries)::

    {base_frequency: 0.1, harmonics: 5, q0: [...], a: [[...] per joint],
     b: [[...] per joint]}

:class:`rmdrake.systems.FourierTrajectoryView` gives a pydrake ``Trajectory`` of
it for a ``TrajectorySource``;
:func:`rmdrake.excitation.random.random_fourier_trajectory`
draws a random one within a robot's limits.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rmdrake.arrays import as_finite_array
from rmdrake.io.atomic import atomic_write_text
from rmdrake.io.yaml import read_yaml, yaml_number
from rmdrake.limits import check_memory
from rmdrake.model.robot import RobotModel

__all__ = [
    "MAX_HARMONICS",
    "MAX_PERIOD_S",
    "FourierTrajectory",
    "check_sampling",
    "fourier_series",
    "load_fourier",
]

_FOURIER_KEYS = ("base_frequency", "harmonics", "q0", "a", "b")
MAX_HARMONICS = 100  # the paper uses 5; dense checks cost O(N^2) per joint
MAX_PERIOD_S = 3600.0  # one hour: base_frequency >= 1/3600 Hz


def check_sampling(base_frequency: float, rate: float, periods: float, n: int) -> int:
    """The samples M = periods x rate / base_frequency of a run of ``n`` joints
    (t, q, qd, qdd and tau: 1 + 4n float64 columns), checked against
    :data:`rmdrake.limits.MEMORY_CAP_BYTES` before any array is allocated.

    Raises:
      ValueError: a rate or period count that is not positive and finite, or
        a run over the memory cap (the message names the samples).

    Example:

    >>> from rmdrake.excitation import check_sampling
    >>> check_sampling(0.1, 150.0, 2, 6)  # two 10 s periods at 150 Hz
    3000
    """
    for name, v in (("rate", rate), ("periods", periods)):
        if not math.isfinite(v) or v <= 0:
            raise ValueError(f"{name}: expected a positive finite number, found {v!r}")
    M = periods * rate / base_frequency
    check_memory(
        M * (1 + 4 * n),
        f"{periods:g} period(s) of {1 / base_frequency:.4g} s at {rate:g} Hz "
        f"({M:.3g} samples x {1 + 4 * n} columns)",
        "lower the rate or the periods",
    )
    return int(round(M))


def fourier_series(
    t: np.ndarray | float,
    *,
    base_frequency: float,
    q0: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    orders: Sequence[int] = (0, 1, 2),
) -> tuple[np.ndarray, ...]:
    """Time derivatives of Fourier trajectories (eq. 11-13), batched.

    The k-th derivative of eq. 11 is, with w_l = omega_f l (rad/s),
    ``sum_l w_l^(k-1) (a_l sin(w_l t + k pi/2) - b_l cos(w_l t + k pi/2))``
    (plus q0 for k = 0): k = 0, 1, 2 are eq. 11, 12, 13. The sines and cosines
    are computed once for all requested orders; the phase shift k pi/2 is
    applied exactly (as a swap and a sign). Plain array numerics without
    validation (the hot path of the excitation design and of the Drake source
    system); :class:`FourierTrajectory` checks its inputs.

    Args:
      t: time(s) in s, a scalar or an array of shape (M,).
      base_frequency: f in Hz (omega_f = 2 pi f).
      q0: offset(s) in rad, (n,) or one per coefficient set, (P, n).
      a, b: coefficients in rad/s, (n, N) for one trajectory or (P, n, N) for a
        population of P coefficient sets.
      orders: derivative orders k >= 0 to return: 0 for q (rad), 1 for qd
        (rad/s), 2 for qdd (rad/s^2), k for rad/s^k.

    Returns:
      one array per order, of shape (n,) for one trajectory at a scalar t,
      (M, n) for one trajectory at times (M,), (P, n) for a population at a
      scalar t and (P, M, n) for a population at times (M,).

    Example:

    >>> import numpy as np
    >>> from rmdrake.excitation import fourier_series
    >>> a = np.array([[0.1]])  # one joint, one harmonic: q = q0 + a / w sin(w t)
    >>> b = np.zeros((1, 1))
    >>> t = np.array([0.0, 5.0])  # s: the start and half the 10 s period
    >>> q, qd = fourier_series(
    ...     t, base_frequency=0.1, q0=np.zeros(1), a=a, b=b, orders=(0, 1)
    ... )
    >>> q.shape, qd.round(6).tolist()
    ((2, 1), [[0.1], [-0.1]])
    """
    t = np.asarray(t, dtype=np.float64)
    scalar = t.ndim == 0
    w = 2.0 * math.pi * base_frequency * np.arange(1, a.shape[-1] + 1)  # (N,)
    phase = t.reshape(-1, 1) * w  # (M, N)
    sin, cos = np.sin(phase), np.cos(phase)
    out = []
    for k in orders:
        if k < 0:
            raise ValueError(f"orders: expected k >= 0, found {k}")
        # Even k: +-(a.sin - b.cos); odd k: +-(a.cos + b.sin); scaled by w^(k-1).
        xa, xb = (sin, cos) if k % 2 == 0 else (cos, sin)
        if k == 0:
            xa, xb = xa / w, xb / w
        elif k > 1:
            scale = w if k == 2 else w ** (k - 1)
            xa, xb = xa * scale, xb * scale
        # (M, N) @ (N, n), or (M, N) @ (P, N, n) -> (P, M, n) for a population:
        # one small product per member, so a member's sums do not depend on the
        # others (10 times faster than the equivalent einsum at P = 64).
        ea, eb = xa @ a.swapaxes(-1, -2), xb @ b.swapaxes(-1, -2)
        if k == 0:
            q0 = np.asarray(q0, dtype=np.float64)
            x = (q0[:, None, :] if q0.ndim == 2 else q0) + ea - eb
        elif k % 4 == 0:
            x = ea - eb
        elif k % 4 == 1:
            x = ea + eb
        elif k % 4 == 2:
            x = eb - ea
        else:
            x = -(ea + eb)
        out.append(x[..., 0, :] if scalar else x)
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class FourierTrajectory:
    """Periodic Fourier-series joint trajectory (paper eq. 11-13, module docstring).

    Attributes:
      base_frequency: fundamental frequency f in Hz (omega_f = 2 pi f).
      q0: (n,) joint offset in rad.
      a: (n, N) sine coefficients of qd in rad/s (N = harmonics).
      b: (n, N) cosine coefficients of qd in rad/s.

    Example:

    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> traj = random_fourier_trajectory(load_robot("rv3sb"), harmonics=3, seed=1)
    >>> traj.n_joints, traj.harmonics, traj.period
    (6, 3, 10.0)
    >>> t, q, qd, qdd = traj.sample(rate=50.0)
    >>> q.shape, bool(abs(qd[0]).max() < 1e-12)  # starts at rest
    ((500, 6), True)
    """

    base_frequency: float
    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray

    def __post_init__(self) -> None:
        f = float(self.base_frequency)
        if not math.isfinite(f) or f <= 0.0:
            raise ValueError(
                f"base_frequency: expected a positive frequency in Hz, found {f!r}"
            )
        if f * MAX_PERIOD_S < 1.0:
            raise ValueError(
                f"base_frequency: {f:g} Hz is a period of {1 / f:.3g} s, over the "
                f"{MAX_PERIOD_S:g} s limit (expected >= {1 / MAX_PERIOD_S:.3g} Hz)"
            )
        q0 = as_finite_array(self.q0, "q0", (None,))
        n = q0.shape[0]
        if n < 1:
            raise ValueError("q0: expected at least one joint, found none")
        N = np.shape(self.a)[-1] if np.ndim(self.a) else 0
        if N > MAX_HARMONICS:
            raise ValueError(
                f"harmonics: {N} is over the limit of {MAX_HARMONICS} (the "
                "paper uses 5; more would make the limit checks allocate GiB)"
            )
        a = as_finite_array(self.a, "a", (n, None))
        b = as_finite_array(self.b, "b", (n, a.shape[1]))
        if a.shape[1] < 1:
            raise ValueError("a: expected at least one harmonic, found none")
        for name, value in (("q0", q0), ("a", a), ("b", b)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "base_frequency", f)

    # ---- shape and timing ------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q0.shape[0])

    @property
    def harmonics(self) -> int:
        """Number of harmonics N."""
        return int(self.a.shape[1])

    @property
    def omega_f(self) -> float:
        """Fundamental angular frequency 2 pi f in rad/s."""
        return 2.0 * math.pi * self.base_frequency

    @property
    def period(self) -> float:
        """Period 1/f in s."""
        return 1.0 / self.base_frequency

    # ---- evaluation ------------------------------------------------------------
    def derivative(self, t: np.ndarray | float, order: int) -> np.ndarray:
        """``order``-th time derivative at t (s), in rad/s^order: (n,) for a
        scalar t, else (M, n) for times (M,)."""
        if order < 0:
            raise ValueError(f"order: expected >= 0, found {order}")
        return self._series(t, (order,))[0]

    def _series(
        self, t: np.ndarray | float, orders: Sequence[int]
    ) -> tuple[np.ndarray, ...]:
        return fourier_series(
            t,
            base_frequency=self.base_frequency,
            q0=self.q0,
            a=self.a,
            b=self.b,
            orders=orders,
        )

    def q(self, t: np.ndarray | float) -> np.ndarray:
        """Joint positions (rad), eq. 11: (n,) for a scalar t, else (M, n)."""
        return self.derivative(t, 0)

    def qd(self, t: np.ndarray | float) -> np.ndarray:
        """Joint velocities (rad/s), eq. 12."""
        return self.derivative(t, 1)

    def qdd(self, t: np.ndarray | float) -> np.ndarray:
        """Joint accelerations (rad/s^2), eq. 13."""
        return self.derivative(t, 2)

    def sample(
        self, rate: float, periods: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Samples ``periods`` periods at ``rate`` Hz, starting at t = 0.

        Returns (t, q, qd, qdd) with t of shape (M,) and the others (M, n), where
        M = round(periods * rate / base_frequency) (1500 for the paper's 150 Hz,
        0.1 Hz, one period); the end time itself is not included.
        """
        rate = float(rate)
        M = check_sampling(self.base_frequency, rate, periods, self.n_joints)
        t = np.arange(M) / rate
        return (t, *self._series(t, (0, 1, 2)))

    # ---- limits ----------------------------------------------------------------
    def peak_values(
        self, samples_per_period: int | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Extremes over one period, by dense sampling.

        Args:
          samples_per_period: default 200 per period of the highest harmonic, so
            a sampled extreme is below the true one by at most
            (1 - cos(pi/200)) ~ 1.2e-4 of the highest harmonic's amplitude.

        Returns:
          (q_min, q_max, |qd|_max, |qdd|_max), each (n,).
        """
        M = samples_per_period or 200 * self.harmonics
        t = np.arange(M) * (self.period / M)
        q, qd, qdd = self._series(t, (0, 1, 2))
        return (
            q.min(axis=0),
            q.max(axis=0),
            np.abs(qd).max(axis=0),
            np.abs(qdd).max(axis=0),
        )

    def check_limits(self, model: RobotModel) -> None:
        """Checks joint count and the position, velocity and acceleration limits.

        Raises:
          ValueError: one line naming the joint, the quantity and by how much the
            worst violation exceeds its limit (and how many others there are).
        """
        self.check_joint_count(model)
        lim = model.limits
        q_min, q_max, v_max, a_max = self.peak_values()
        found: list[tuple[float, str]] = []
        deg = 180.0 / math.pi
        for j in range(self.n_joints):
            checks = (
                ("position", lim.lower[j] - q_min[j], "below the lower limit",
                 lim.lower[j], q_min[j], "rad"),
                ("position", q_max[j] - lim.upper[j], "above the upper limit",
                 lim.upper[j], q_max[j], "rad"),
                ("velocity", v_max[j] - lim.velocity[j], "above the limit",
                 lim.velocity[j], v_max[j], "rad/s"),
                ("acceleration", a_max[j] - lim.acceleration[j], "above the limit",
                 lim.acceleration[j], a_max[j], "rad/s^2"),
            )  # fmt: skip
            for what, excess, where, limit, peak, unit in checks:
                if excess > 0:
                    rel = excess / max(abs(limit), 1e-12)
                    extra = f" ({excess * deg:.3g} deg)" if unit == "rad" else ""
                    found.append(
                        (
                            rel,
                            f"joint {j + 1} {what} reaches {peak:.6g} {unit}, "
                            f"{where} {limit:.6g} {unit} by {excess:.3g} {unit}"
                            f"{extra}",
                        )
                    )
        if found:
            found.sort(key=lambda x: -x[0])
            more = f" ({len(found) - 1} more violations)" if len(found) > 1 else ""
            raise ValueError(
                f"trajectory violates the limits of robot '{model.name}': "
                f"{found[0][1]}{more}"
            )

    def check_joint_count(self, model: RobotModel) -> None:
        """Raises ValueError when the trajectory and the robot differ in n."""
        if self.n_joints != model.n_joints:
            raise ValueError(
                f"trajectory has {self.n_joints} joints but robot '{model.name}' "
                f"has {model.n_joints}"
            )

    def check_covers(self, t: np.ndarray, what: str = "log") -> None:
        """Checks that sample times ``t`` (s, increasing) span at least one period.

        Samples at rate r of exactly one period span period - 1/r, so the rule is
        ``t[-1] - t[0] + 1.5 dt >= period`` with dt the median sample interval.

        Raises:
          ValueError: one line naming ``what``, the span covered and the period.
        """
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        covered = float(t[-1] - t[0]) if t.size else 0.0
        step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        if covered + 1.5 * step < self.period:
            raise ValueError(
                f"{what} covers {covered:.4g} s, shorter than one period "
                f"({self.period:.4g} s) of the excitation"
            )

    # ---- YAML ------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping of the module docstring (plain Python types)."""
        return {
            "base_frequency": self.base_frequency,
            "harmonics": self.harmonics,
            "q0": [float(v) for v in self.q0],
            "a": [[float(v) for v in row] for row in self.a],
            "b": [[float(v) for v in row] for row in self.b],
        }

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], source: str = "trajectory"
    ) -> FourierTrajectory:
        """Builds and validates a trajectory from the YAML mapping of the module
        docstring (five keys, no others; harmonics a positive integer; finite
        numbers; a and b with one row of ``harmonics`` entries per q0 entry).

        Raises:
          ValueError: one line naming ``source`` and the offending field.
        """
        try:
            return cls._from_dict(data)
        except ValueError as e:
            raise ValueError(f"{source}: {e}") from None

    @classmethod
    def _from_dict(cls, data: Mapping[str, Any]) -> FourierTrajectory:
        if not isinstance(data, Mapping):
            raise ValueError(
                f"expected a mapping at top level, found {type(data).__name__}"
            )
        for key in _FOURIER_KEYS:
            if key not in data:
                raise ValueError(f"missing key '{key}'")
        unknown = set(data) - set(_FOURIER_KEYS)
        if unknown:
            raise ValueError(f"unknown key(s) {', '.join(sorted(map(str, unknown)))}")
        f = yaml_number(data["base_frequency"], "base_frequency")
        N = data["harmonics"]
        if isinstance(N, bool) or not isinstance(N, int) or N < 1:
            raise ValueError(f"harmonics: expected a positive integer, found {N!r}")
        if N > MAX_HARMONICS:
            raise ValueError(f"harmonics: {N} is over the limit of {MAX_HARMONICS}")
        q0 = data["q0"]
        if not isinstance(q0, list) or not q0:
            raise ValueError(f"q0: expected a non-empty list of angles, found {q0!r}")
        n = len(q0)
        q0 = np.array([yaml_number(v, f"q0[{i}]") for i, v in enumerate(q0)])
        coeffs = {}
        for key in ("a", "b"):
            rows = data[key]
            if not isinstance(rows, list) or len(rows) != n:
                found = len(rows) if isinstance(rows, list) else repr(rows)
                raise ValueError(
                    f"{key}: expected {n} rows (one per joint, as q0), found {found}"
                )
            out = []
            for i, row in enumerate(rows):
                if not isinstance(row, list) or len(row) != N:
                    found = len(row) if isinstance(row, list) else repr(row)
                    raise ValueError(
                        f"{key}[{i}]: expected {N} coefficients (harmonics), "
                        f"found {found}"
                    )
                out.append(
                    [yaml_number(v, f"{key}[{i}][{k}]") for k, v in enumerate(row)]
                )
            coeffs[key] = np.array(out)
        return cls(base_frequency=f, q0=q0, a=coeffs["a"], b=coeffs["b"])

    def to_yaml(self) -> str:
        """The trajectory as YAML text (floats with full precision)."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None)

    def save(self, path: str | os.PathLike) -> Path:
        """Writes the trajectory YAML to ``path`` atomically; returns the path."""
        return atomic_write_text(path, self.to_yaml())

    @classmethod
    def load(cls, path: str | os.PathLike) -> FourierTrajectory:
        """Reads a Fourier YAML; see :func:`load_fourier`."""
        return load_fourier(path)


def load_fourier(path: str | os.PathLike) -> FourierTrajectory:
    """Reads and validates a Fourier trajectory YAML (the rules of
    :meth:`FourierTrajectory.from_dict`).

    Raises:
      ValueError: unreadable file or invalid content (one line naming the file).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import load_fourier, load_robot, random_fourier_trajectory
    >>> traj = random_fourier_trajectory(load_robot("rv3sb"), seed=1)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = traj.save(Path(tmp, "excitation.yaml"))
    ...     again = load_fourier(path)
    ...
    >>> again.base_frequency, again.a.shape
    (0.1, (6, 5))
    """
    path = Path(path)
    data = read_yaml(path, "trajectory YAML")
    return FourierTrajectory.from_dict(data, str(path))
