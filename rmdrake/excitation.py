"""Excitation trajectories for dynamic identification (paper §3.2).

A :class:`FourierTrajectory` is the finite Fourier series of the paper's eq. 11-13
plus a constant offset ``q0`` (DESIGN §3), per joint i = 1..n and harmonic
l = 1..N, with omega_f = 2 pi base_frequency (base_frequency in Hz)::

    q_i(t)   = q0_i + sum_l a_il/(omega_f l) sin(omega_f l t)
                    - b_il/(omega_f l) cos(omega_f l t)              (11)
    qd_i(t)  = sum_l a_il cos(omega_f l t) + b_il sin(omega_f l t)   (12)
    qdd_i(t) = omega_f sum_l b_il l cos(omega_f l t)
                    - a_il l sin(omega_f l t)                        (13)

Units: q in rad, qd in rad/s, qdd in rad/s^2, t in s; a and b are velocity
amplitudes in rad/s. The trajectory is periodic with period 1/base_frequency. When
the coefficients satisfy the paper's eq. 17 equalities (sum_l b_il/(omega_f l) = 0,
sum_l a_il = 0, sum_l l b_il = 0) it starts at rest at q0.

The file format is the Fourier YAML of DESIGN §3::

    {base_frequency: 0.1, harmonics: 5, q0: [...], a: [[...] per joint],
     b: [[...] per joint]}

This module holds array numerics only (no diagram wiring); the Drake source
system is :class:`rmdrake.systems.FourierExcitationSource`, and
:meth:`FourierTrajectory.to_pydrake` gives a pydrake ``Trajectory`` for a
``TrajectorySource``. The excitation *design* (paper eq. 16-17) lives here too.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg
import yaml
from pydrake.trajectories import Trajectory

from rmdrake.arrays import as_finite_array
from rmdrake.io import atomic_write_text
from rmdrake.robot import RobotModel

__all__ = [
    "ExcitationCost",
    "ExcitationResult",
    "FourierParametrization",
    "FourierTrajectory",
    "design_excitation",
    "fit_to_limits",
    "fourier_derivative",
    "fourier_batch",
    "load_fourier",
    "random_fourier_trajectory",
]

_FOURIER_KEYS = ("base_frequency", "harmonics", "q0", "a", "b")


def fourier_derivative(
    t: np.ndarray | float,
    base_frequency: float,
    q0: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    order: int = 0,
) -> np.ndarray:
    """The ``order``-th time derivative of the Fourier trajectory (eq. 11-13).

    Plain array numerics with no validation (the hot path of the Drake source
    system); use :class:`FourierTrajectory` for checked inputs.

    Args:
      t: time(s) in s, a scalar or an array of shape (T,).
      base_frequency: f in Hz (omega_f = 2 pi f).
      q0: (n,) offset in rad.
      a, b: (n, N) coefficients in rad/s.
      order: 0 for q (rad), 1 for qd (rad/s), 2 for qdd (rad/s^2), k >= 0.

    Returns:
      (n,) for a scalar ``t``, else (T, n).
    """
    scalar = np.ndim(t) == 0
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    N = a.shape[1]
    w = 2.0 * math.pi * base_frequency * np.arange(1, N + 1)  # (N,) rad/s
    # q = q0 + sum A sin(w t) - B cos(w t) with A = a/w, B = b/w; the k-th
    # derivative shifts the phase by k pi/2 and scales by w^k.
    scale = w ** (order - 1)  # (N,)
    phase = np.multiply.outer(t, w) + order * (math.pi / 2.0)  # (T, N)
    out = np.sin(phase) @ (a * scale).T - np.cos(phase) @ (b * scale).T
    if order == 0:
        out += q0
    return out[0] if scalar else out


@dataclasses.dataclass(frozen=True)
class FourierTrajectory:
    """Periodic Fourier-series joint trajectory (paper eq. 11-13, module docstring).

    Attributes:
      base_frequency: fundamental frequency f in Hz (omega_f = 2 pi f).
      q0: (n,) joint offset in rad.
      a: (n, N) sine coefficients of qd in rad/s (N = harmonics).
      b: (n, N) cosine coefficients of qd in rad/s.
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
        q0 = as_finite_array(self.q0, "q0", (None,))
        n = q0.shape[0]
        if n < 1:
            raise ValueError("q0: expected at least one joint, found none")
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
        """``order``-th time derivative at t (s): (n,) for a scalar, else (T, n)."""
        if order < 0:
            raise ValueError(f"order: expected >= 0, found {order}")
        return fourier_derivative(
            t, self.base_frequency, self.q0, self.a, self.b, order
        )

    def q(self, t: np.ndarray | float) -> np.ndarray:
        """Joint positions (rad), eq. 11: (n,) for a scalar t, else (T, n)."""
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
        if not math.isfinite(rate) or rate <= 0:
            raise ValueError(f"rate: expected a positive rate in Hz, found {rate!r}")
        if not math.isfinite(periods) or periods <= 0:
            raise ValueError(f"periods: expected > 0, found {periods!r}")
        M = int(round(periods * rate / self.base_frequency))
        t = np.arange(M) / rate
        return t, self.q(t), self.qd(t), self.qdd(t)

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
        q = self.q(t)
        return (
            q.min(axis=0),
            q.max(axis=0),
            np.abs(self.qd(t)).max(axis=0),
            np.abs(self.qdd(t)).max(axis=0),
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

    # ---- pydrake ---------------------------------------------------------------
    def to_pydrake(self, end_time: float = math.inf) -> Trajectory:
        """This trajectory as a pydrake ``Trajectory`` (an (n, 1) column).

        Values and derivatives of every order are evaluated exactly (no
        interpolation), so ``TrajectorySource(traj, output_derivative_order=2)``
        outputs [q; qd; qdd]. ``end_time`` (s, default infinite) is what
        ``end_time()`` reports; keep it infinite in a ``TrajectorySource``, which
        outputs zero derivatives after the end time.
        """
        return _FourierPydrakeTrajectory(self, 0, float(end_time))

    # ---- YAML ------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The DESIGN §3 mapping (plain Python types)."""
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
        """Builds and validates a trajectory from a DESIGN §3 mapping.

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
        f = _number(data["base_frequency"], "base_frequency")
        N = data["harmonics"]
        if isinstance(N, bool) or not isinstance(N, int) or N < 1:
            raise ValueError(f"harmonics: expected a positive integer, found {N!r}")
        q0 = data["q0"]
        if not isinstance(q0, list) or not q0:
            raise ValueError(f"q0: expected a non-empty list of angles, found {q0!r}")
        n = len(q0)
        q0 = np.array([_number(v, f"q0[{i}]") for i, v in enumerate(q0)])
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
                out.append([_number(v, f"{key}[{i}][{k}]") for k, v in enumerate(row)])
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
    """Reads and validates a Fourier trajectory YAML (DESIGN §3).

    Raises:
      ValueError: unreadable file or invalid content (one line naming the file).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise ValueError(
            f"cannot read trajectory YAML '{path}': {e.strerror}"
        ) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise ValueError(f"{path}: not valid YAML ({e.__class__.__name__})") from None
    return FourierTrajectory.from_dict(data, str(path))


def random_fourier_trajectory(
    model: RobotModel,
    *,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    fill: float = 0.5,
    seed: int = 0,
) -> FourierTrajectory:
    """A random trajectory that satisfies the paper's eq. 17 (tests, benches,
    starting points; not an optimised excitation).

    Per joint: coefficients uniform in [-1, 1], projected onto the equalities of
    eq. 17 (sum_l a_l = 0, sum_l b_l/(omega_f l) = 0, sum_l omega_f l b_l = 0: the
    motion starts at rest at q0 = the middle of the joint range), then scaled so
    that the eq. 17 bounds on position excursion, velocity and acceleration are
    ``fill`` times the robot's half range, velocity limit and acceleration limit
    (those bounds are sums of amplitudes, so the actual peaks are lower).

    Args:
      harmonics: N >= 3 (two equalities constrain b).
      base_frequency: f in Hz.
      fill: fraction of the limits to use, 0 < fill <= 1.
      seed: seed of the coefficients.
    """
    if harmonics < 3:
        raise ValueError(f"harmonics: expected >= 3, found {harmonics}")
    if not 0.0 < fill <= 1.0:
        raise ValueError(f"fill: expected 0 < fill <= 1, found {fill}")
    rng = np.random.default_rng(seed)
    n, N = model.n_joints, harmonics
    wl = 2.0 * math.pi * base_frequency * np.arange(1, N + 1)  # omega_f l, rad/s
    a = rng.uniform(-1.0, 1.0, (n, N))
    b = rng.uniform(-1.0, 1.0, (n, N))
    a -= a.mean(axis=1, keepdims=True)
    C = np.vstack([1.0 / wl, wl])  # (2, N): the two equalities on b
    b -= (b @ C.T) @ np.linalg.solve(C @ C.T, C)
    lim = model.limits
    q0 = 0.5 * (lim.lower + lim.upper)
    amp = np.hypot(a, b)
    bounds = np.stack([(amp / wl).sum(1), amp.sum(1), (amp * wl).sum(1)])
    room = np.stack([0.5 * (lim.upper - lim.lower), lim.velocity, lim.acceleration])
    scale = fill * np.min(room / bounds, axis=0)
    return FourierTrajectory(
        base_frequency=base_frequency,
        q0=q0,
        a=a * scale[:, None],
        b=b * scale[:, None],
    )


def _number(value: Any, what: str) -> float:
    if isinstance(value, str):
        try:  # PyYAML (YAML 1.1) reads 5e5 and 5.0e5 as strings
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what}: expected a number, found {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{what}: expected a finite number, found {value!r}")
    return float(value)


class _FourierPydrakeTrajectory(Trajectory):
    """pydrake ``Trajectory`` view of the ``order``-th derivative of a
    :class:`FourierTrajectory` (exact evaluation, any order)."""

    def __init__(self, traj: FourierTrajectory, order: int, end_time: float) -> None:
        Trajectory.__init__(self)
        self._traj = traj
        self._order = order
        self._end = end_time

    def __deepcopy__(self, memo: dict) -> _FourierPydrakeTrajectory:
        # TrajectorySource deep-copies its trajectory; the data are immutable.
        return _FourierPydrakeTrajectory(self._traj, self._order, self._end)

    def DoClone(self) -> _FourierPydrakeTrajectory:
        return _FourierPydrakeTrajectory(self._traj, self._order, self._end)

    def do_rows(self) -> int:
        return self._traj.n_joints

    def do_cols(self) -> int:
        return 1

    def do_start_time(self) -> float:
        return 0.0

    def do_end_time(self) -> float:
        return self._end

    def do_value(self, t: float) -> np.ndarray:
        return self._traj.derivative(float(t), self._order)[:, None]

    def do_has_derivative(self) -> bool:
        return True

    def DoEvalDerivative(self, t: float, derivative_order: int) -> np.ndarray:
        return self._traj.derivative(float(t), self._order + derivative_order)[:, None]

    def DoMakeDerivative(self, derivative_order: int) -> _FourierPydrakeTrajectory:
        return _FourierPydrakeTrajectory(
            self._traj, self._order + derivative_order, self._end
        )


# ---- excitation design (paper eq. 14-17) ----------------------------------------
class FourierParametrization:
    """Free coordinates of Fourier coefficients that start at rest (eq. 17).

    The equalities of eq. 17, q(0) = q0, qd(0) = 0 and qdd(0) = 0, are linear in
    each joint's coefficients: sum_l a_l = 0, sum_l b_l / l = 0 and
    sum_l l b_l = 0. They hold *by construction* for a = x_a Ba^T and
    b = x_b Bb^T, with Ba (N, N-1) and Bb (N, N-2) orthonormal bases of the null
    spaces: every point of the search space is a trajectory that starts (and,
    being periodic, ends) at rest at q0. Free coordinates per joint: 2N - 3
    (7 for the paper's N = 5), laid out joint by joint, a-part first.
    """

    def __init__(self, n_joints: int, harmonics: int) -> None:
        if harmonics < 3:
            raise ValueError(
                f"harmonics: expected >= 3 (eq. 17 puts two equalities on b), "
                f"found {harmonics}"
            )
        l = np.arange(1, harmonics + 1, dtype=np.float64)
        self.n_joints = int(n_joints)
        self.harmonics = int(harmonics)
        self.Ba = scipy.linalg.null_space(np.ones((1, harmonics)))
        self.Bb = scipy.linalg.null_space(np.stack([1.0 / l, l]))
        self.per_joint = self.Ba.shape[1] + self.Bb.shape[1]

    @property
    def size(self) -> int:
        """Number of free coordinates, n (2N - 3)."""
        return self.n_joints * self.per_joint

    def coefficients(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P, size) coordinates -> a, b of shape (P, n, N), rad/s."""
        x = np.asarray(x, dtype=np.float64)
        x = x.reshape(x.shape[0], self.n_joints, self.per_joint)
        ka = self.Ba.shape[1]
        return x[..., :ka] @ self.Ba.T, x[..., ka:] @ self.Bb.T


def fourier_batch(
    base_frequency: float, q0: np.ndarray, a: np.ndarray, b: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (rad, rad/s, rad/s^2) of P trajectories at times t (s).

    Args:
      q0: (n,) or (P, n) offsets; a, b: (P, n, N) coefficients; t: (S,).

    Returns:
      three (P, S, n) arrays (eq. 11-13).
    """
    N = a.shape[-1]
    w = 2.0 * math.pi * base_frequency * np.arange(1, N + 1)
    ph = np.multiply.outer(np.asarray(t, dtype=np.float64), w)
    sn, cs = np.sin(ph), np.cos(ph)
    q0 = np.asarray(q0, dtype=np.float64)
    q0 = q0[:, None, :] if q0.ndim == 2 else q0
    q = q0 + np.einsum("sl,pnl->psn", sn / w, a) - np.einsum("sl,pnl->psn", cs / w, b)
    qd = np.einsum("sl,pnl->psn", cs, a) + np.einsum("sl,pnl->psn", sn, b)
    qdd = np.einsum("sl,pnl->psn", cs * w, b) - np.einsum("sl,pnl->psn", sn * w, a)
    return q, qd, qdd


def fit_to_limits(
    base_frequency: float,
    q0: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    model: RobotModel,
    margin: float,
    t: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Scales each joint's coefficients down (never up) so that its motion at
    times ``t`` stays within ``margin`` times the room to the position limits
    (on each side of q0) and ``margin`` times the velocity and acceleration
    limits. Scaling keeps eq. 17's equalities. Returns the scaled (a, b)."""
    q, qd, qdd = fourier_batch(base_frequency, q0, a, b, t)
    q0 = np.broadcast_to(np.asarray(q0, dtype=np.float64), q[:, 0, :].shape)
    lim = model.limits
    tiny = 1e-300
    s = np.minimum.reduce(
        [
            np.ones(q0.shape),
            margin * (lim.upper - q0) / np.maximum(q.max(axis=1) - q0, tiny),
            margin * (q0 - lim.lower) / np.maximum(q0 - q.min(axis=1), tiny),
            margin * lim.velocity / np.maximum(np.abs(qd).max(axis=1), tiny),
            margin * lim.acceleration / np.maximum(np.abs(qdd).max(axis=1), tiny),
        ]
    )
    return a * s[..., None], b * s[..., None]


class ExcitationCost:
    """The DE objective of eq. 16, vectorised over a population.

    Per candidate x (coordinates of :class:`FourierParametrization`):
    coefficients -> :func:`fit_to_limits` at the design times -> q, qd, qdd ->
    base regressor (paper eq. 15, the A of eq. 14) -> Gram matrix G = A^T A ->
    criterion ``"cond"``: cond(A) = sqrt(lambda_max / lambda_min) of G (paper
    eq. 16), or ``"logdet"``: -mean(log lambda) (D-optimality, minimised).
    Candidates go in chunks of ``chunk`` to bound memory (about
    chunk * S * n * 13 n doubles).
    """

    def __init__(
        self,
        *,
        model: RobotModel,
        base,
        parametrization: FourierParametrization,
        q0: np.ndarray,
        base_frequency: float,
        times: np.ndarray,
        margin: float = 0.95,
        criterion: str = "cond",
        chunk: int = 64,
    ) -> None:
        if criterion not in ("cond", "logdet"):
            raise ValueError(
                f"criterion: expected 'cond' or 'logdet', found {criterion!r}"
            )
        from rmdrake.dynamics import SerialChain

        self.model = model
        self.chain = SerialChain.from_model(model)
        self.base = base
        self.parametrization = parametrization
        self.q0 = np.asarray(q0, dtype=np.float64)
        self.base_frequency = float(base_frequency)
        self.times = np.asarray(times, dtype=np.float64)
        self.margin = float(margin)
        self.criterion = criterion
        self.chunk = int(chunk)

    def coefficients(
        self, X: np.ndarray, times: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Feasible (a, b), (P, n, N), of candidates X (P, k); the limits are
        checked at ``times`` (default the design times)."""
        a, b = self.parametrization.coefficients(np.atleast_2d(X))
        t = self.times if times is None else times
        return fit_to_limits(
            self.base_frequency, self.q0, a, b, self.model, self.margin, t
        )

    def gram(self, a: np.ndarray, b: np.ndarray, times: np.ndarray) -> np.ndarray:
        """(P, nb, nb) Gram matrices A^T A of trajectories (a, b) at ``times``."""
        out = []
        for k in range(0, a.shape[0], self.chunk):
            q, qd, qdd = fourier_batch(
                self.base_frequency,
                self.q0,
                a[k : k + self.chunk],
                b[k : k + self.chunk],
                times,
            )
            P, S, n = q.shape
            Y = self.base.regressor(
                self.chain, q.reshape(-1, n), qd.reshape(-1, n), qdd.reshape(-1, n)
            ).reshape(P, S * n, -1)
            out.append(np.matmul(Y.transpose(0, 2, 1), Y))
        return np.concatenate(out)

    @staticmethod
    def cond(G: np.ndarray) -> np.ndarray:
        """cond(A) = sqrt(lambda_max / lambda_min) of Gram matrices (P, p, p);
        1e12 for singular ones."""
        ev = np.linalg.eigvalsh(G)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.sqrt(ev[:, -1] / ev[:, 0])
        return np.where(ev[:, 0] > 0, c, 1e12)

    def score(self, G: np.ndarray) -> np.ndarray:
        """The criterion of Gram matrices (lower is better)."""
        if self.criterion == "cond":
            return self.cond(G)
        ev = np.linalg.eigvalsh(G)
        return -np.mean(np.log(np.maximum(ev, 1e-300)), axis=1)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        a, b = self.coefficients(X)
        return self.score(self.gram(a, b, self.times))


@dataclasses.dataclass(frozen=True)
class ExcitationResult:
    """Result of :func:`design_excitation`.

    Attributes:
      trajectory: the optimised trajectory (inside the limits, at rest at t = 0).
      criterion: ``"cond"`` or ``"logdet"``.
      cond: cond(A) of the base observation matrix on the full period
        (sample_rate / base_frequency samples, e.g. 1500).
      random_conds: cond(A) on the full period of random feasible trajectories
        in the same limits: random coordinates in the same box, scaled into the
        limits like every DE candidate, then by a random amplitude u ~ U(0, 1]
        (a random point of the feasible set, not only of its boundary).
      random_conds_full: the same trajectories without the random amplitude
        (every one touching a limit on each joint): a stricter baseline.
      history: (G, 3) rows of (generation, wall time s, best cost so far).
      time: wall time of the optimisation, s.
      generations: DE generations run; stopped: why the DE stopped.
    """

    trajectory: FourierTrajectory
    criterion: str
    cond: float
    random_conds: np.ndarray
    random_conds_full: np.ndarray
    history: np.ndarray
    time: float
    generations: int
    stopped: str


class _Budget(Exception):
    """Raised inside the DE objective when the time budget is spent."""


def design_excitation(
    model: RobotModel,
    *,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    sample_rate: float = 150.0,
    design_samples: int = 100,
    q0: np.ndarray | None = None,
    criterion: str = "cond",
    margin: float = 0.95,
    per_link: int = 13,
    seed: int = 0,
    popsize: int = 15,
    maxiter: int = 400,
    max_time: float = 240.0,
    n_random: int = 50,
    progress: bool = True,
) -> ExcitationResult:
    """Optimal Fourier excitation by Differential Evolution (paper eq. 16-17).

    Minimises cond(A) (or the D-optimal criterion) of the base observation
    matrix over the free coordinates of :class:`FourierParametrization`, so the
    equalities of eq. 17 hold by construction; every candidate is scaled into
    ``margin`` times the robot's position, velocity and acceleration limits
    (:func:`fit_to_limits`, checked on the sampled motion, which is less
    conservative than eq. 17's sums of amplitudes yet never exceeds a limit).
    The DE runs on ``design_samples`` evenly spaced samples of one period (the
    trajectory has only ``harmonics`` harmonics, so 100 samples see its whole
    shape); the result's cond(A) is then evaluated on the full period at
    ``sample_rate``. The whole population is evaluated in one vectorised call.

    Args:
      model: the robot (kinematics; its limits are the bounds).
      harmonics, base_frequency: N and f (Hz) of eq. 11-13.
      sample_rate: samples per second of the final evaluation, Hz.
      design_samples: samples per period used inside the DE.
      q0: (n,) rest pose, rad; default the middle of each joint's range.
      criterion: ``"cond"`` (paper eq. 16) or ``"logdet"`` (D-optimal).
      margin: fraction of each limit the trajectory may use.
      per_link: standard parameters per link of the base set (10, 11 or 13).
      seed, popsize, maxiter: of the DE (scipy conventions).
      max_time: wall-time budget of the DE, s; it stops with the best so far.
      n_random: random feasible trajectories evaluated for comparison.
      progress: show a progress bar with the best cost.

    Raises:
      ValueError: bad sizes, q0 outside the limits, a model without limits room.
    """
    from rmdrake.dynamics.base import base_parameters
    from rmdrake.optimize import differential_evolution

    n = model.n_joints
    lim = model.limits
    q0 = (
        0.5 * (lim.lower + lim.upper) if q0 is None else as_finite_array(q0, "q0", (n,))
    )
    outside = np.flatnonzero((q0 <= lim.lower) | (q0 >= lim.upper))
    if outside.size:
        j = int(outside[0])
        raise ValueError(
            f"q0: joint {j + 1} at {q0[j]:.4g} rad is not strictly inside its "
            f"limits [{lim.lower[j]:.4g}, {lim.upper[j]:.4g}] rad"
        )
    if design_samples < 4 * harmonics:
        raise ValueError(
            f"design_samples: expected >= 4 x harmonics = {4 * harmonics}, "
            f"found {design_samples}"
        )
    period = 1.0 / base_frequency
    t_design = np.arange(design_samples) * (period / design_samples)
    t_full = np.arange(int(round(sample_rate * period))) / sample_rate
    t_dense = np.arange(200 * harmonics) * (period / (200 * harmonics))
    param = FourierParametrization(n, harmonics)
    base = base_parameters(model, per_link)
    cost = ExcitationCost(
        model=model,
        base=base,
        parametrization=param,
        q0=q0,
        base_frequency=base_frequency,
        times=t_design,
        margin=margin,
        criterion=criterion,
    )
    # Box: per coordinate, the velocity amplitude of a fundamental that would
    # sweep the whole joint range (or the velocity limit if lower).
    half = np.minimum(
        0.5 * (lim.upper - lim.lower) * 2 * math.pi * base_frequency, lim.velocity
    )
    half = np.repeat(half, param.per_joint)
    bounds = np.stack([-half, half], axis=1)

    history: list[tuple[int, float, float]] = []
    best: dict[str, Any] = {"x": None, "f": np.inf}
    t0 = time.perf_counter()

    def objective(X: np.ndarray) -> np.ndarray:
        if time.perf_counter() - t0 > max_time and best["x"] is not None:
            raise _Budget
        c = cost(X)
        k = int(np.argmin(c))
        if c[k] < best["f"]:
            best.update(x=X[k].copy(), f=float(c[k]))
        history.append((len(history), time.perf_counter() - t0, best["f"]))
        return c

    try:
        res = differential_evolution(
            objective,
            bounds,
            seed=seed,
            popsize=popsize,
            maxiter=maxiter,
            tol=1e-6,
            progress=progress,
            desc=f"excitation design ({criterion})",
        )
        stopped = str(res.message)
    except _Budget:
        stopped = f"time budget of {max_time:g} s spent"
    elapsed = time.perf_counter() - t0

    def full(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, b = cost.coefficients(X, t_dense)
        return a, b, cost.cond(cost.gram(a, b, t_full))

    a, b, cond = full(best["x"][None])
    trajectory = FourierTrajectory(base_frequency=base_frequency, q0=q0, a=a[0], b=b[0])
    trajectory.check_limits(model)
    rng = np.random.default_rng(seed + 1)
    X_random = rng.uniform(bounds[:, 0], bounds[:, 1], (n_random, bounds.shape[0]))
    a_r, b_r, conds_full = full(X_random)
    u = rng.uniform(0.0, 1.0, (n_random, 1, 1))
    u = np.maximum(u, 1e-3)  # U(0, 1], never exactly at rest
    return ExcitationResult(
        trajectory=trajectory,
        criterion=criterion,
        cond=float(cond[0]),
        random_conds=cost.cond(cost.gram(a_r * u, b_r * u, t_full)),
        random_conds_full=conds_full,
        history=np.array(history),
        time=elapsed,
        generations=max(len(history) - 1, 0),
        stopped=stopped,
    )
