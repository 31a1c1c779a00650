"""Excitation design for dynamic identification (paper eq. 14-17).

:func:`design_excitation` chooses the coefficients of a
:class:`~rmdrake.excitation.trajectory.FourierTrajectory` (eq. 11-13) that minimise the
condition number cond(A) of the base observation matrix A (eq. 14-16) by
Differential Evolution, subject to eq. 17: the motion starts and ends at rest at
q0 (equalities, held by construction through :class:`FourierParametrization`)
and stays inside the robot's position, velocity and acceleration limits
(inequalities, held by scaling every candidate with :func:`fit_to_limits`).

A robot cell (``checker``, :class:`rmdrake.kinematics.clearance.ClearanceChecker`,
with a ``clearance`` in m) adds one more inequality: every candidate whose
motion at the design samples comes closer than the clearance to the cell or
between non-adjacent links is infeasible (its cost is a penalty above every
feasible cost, lower the longer it stays clear), and a candidate becomes the
best so far only once its final trajectory keeps the clearance at every sample
of one period at ``sample_rate`` (the log rate).

Units: q0 and positions in rad, coefficients and velocities in rad/s, accelerations
in rad/s^2 (m, m/s, m/s^2 for a prismatic joint: every limit is per joint, in its
unit), frequencies and sample rates in Hz, times in s.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.excitation.trajectory import (
    MAX_HARMONICS,
    MAX_PERIOD_S,
    FourierTrajectory,
    fourier_series,
)
from rmdrake.execution import SERIAL, Execution, TaskRunner
from rmdrake.io.atomic import atomic_write_text
from rmdrake.limits import check_memory
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.dynamics.base import BaseParameters
    from rmdrake.dynamics.payload import PayloadColumns
    from rmdrake.kinematics.clearance import ClearanceChecker

INFEASIBLE = 1e13
"""Cost of a candidate that breaks the clearance (plus up to INFEASIBLE)."""

LIMIT_SAMPLES_PER_HARMONIC = 40
"""Samples per period and harmonic at which :func:`design_excitation` scales
each candidate into the limits (besides its design samples): a sampled peak
is below the true one by at most 1 - cos(pi / 40) = 0.3 % of the highest
harmonic's amplitude, so the final scaling on 200 per harmonic barely
shrinks the winner (on 50 design samples of 5 harmonics alone it could by
1 - cos(pi / 10) = 4.9 %). Checking them costs one Fourier series, not the
regressor."""

FINALISTS = 16
"""The DE's last bests (on the design samples) that :func:`design_excitation`
evaluates on the full period, keeping the lowest there: the design samples'
cond(A) only tracks the full period's to a few % (seed 1 of the RV-3SB at
the default sizes: 35.8 on the full period for the best of them, 39.0 for
the DE's last best)."""

__all__ = [
    "ExcitationCost",
    "ExcitationResult",
    "FourierParametrization",
    "WallBudgetWarning",
    "design_excitation",
    "fit_to_limits",
    "limit_scales",
    "random_fourier_trajectory",
]


class FourierParametrization:
    """Free coordinates of Fourier coefficients that start at rest (eq. 17).

    The equalities of eq. 17, q(0) = q0, qd(0) = 0 and qdd(0) = 0, are linear in
    each joint's coefficients: sum_l a_l = 0, sum_l b_l / l = 0 and
    sum_l l b_l = 0. They hold *by construction* for a = x_a Ba^T and
    b = x_b Bb^T, with Ba (N, N-1) and Bb (N, N-2) orthonormal bases of the null
    spaces: every point of the search space is a trajectory that starts (and,
    being periodic, ends) at rest at q0. Free coordinates per joint: 2N - 3
    (7 for the paper's N = 5), laid out joint by joint, a-part first.

    Example:

    >>> import numpy as np
    >>> from rmdrake.excitation import FourierParametrization
    >>> free = FourierParametrization(n_joints=6, harmonics=5)
    >>> free.size  # 2 N - 3 = 7 free coordinates per joint
    42
    """

    def __init__(self, n_joints: int, harmonics: int) -> None:
        import scipy.linalg

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
        """(P, size) coordinates -> a, b of shape (P, n, N), rad/s or m/s."""
        x = np.asarray(x, dtype=np.float64)
        x = x.reshape(x.shape[0], self.n_joints, self.per_joint)
        ka = self.Ba.shape[1]
        return x[..., :ka] @ self.Ba.T, x[..., ka:] @ self.Bb.T


def limit_scales(
    excursion: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    q0: np.ndarray,
    model: RobotModel,
    margin: float,
) -> np.ndarray:
    """(P, n) factor in (0, 1] per trajectory and joint that brings sampled
    motions inside the limits: the largest s <= 1 with q0 + s e inside
    ``margin`` times the room to each position limit (on each side of q0), and
    s |qd| and s |qdd| inside ``margin`` times the velocity and acceleration
    limits, at every sample. Eq. 17's inequalities on the samples, checked for
    a whole population in one vectorised pass.

    Args:
      excursion: (P, M, n) q - q0 at M samples, rad or m.
      qd, qdd: (P, M, n) velocities (rad/s or m/s) and accelerations (rad/s^2
        or m/s^2) at the same samples.
      q0: (n,) or (P, n) offsets in rad or m.
      model: the robot whose limits apply.
      margin: fraction of each limit the motion may use, e.g. 0.95.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.excitation import limit_scales
    >>> robot = load_robot("rv3sb")
    >>> q0 = np.zeros(6)
    >>> e = np.full((1, 1, 6), 10.0)  # (P, S, n): 10 rad from q0, beyond every limit
    >>> rest = np.zeros((1, 1, 6))
    >>> s = limit_scales(e, rest, rest, q0, robot, 0.95)
    >>> s.shape, bool((s < 1).all())
    ((1, 6), True)
    """
    q0 = np.broadcast_to(np.asarray(q0, dtype=np.float64), excursion[:, 0, :].shape)
    lim = model.limits
    tiny = 1e-300
    return np.minimum.reduce(
        [
            np.ones(q0.shape),
            margin * (lim.upper - q0) / np.maximum(excursion.max(axis=1), tiny),
            margin * (q0 - lim.lower) / np.maximum(-excursion.min(axis=1), tiny),
            margin * lim.velocity / np.maximum(np.abs(qd).max(axis=1), tiny),
            margin * lim.acceleration / np.maximum(np.abs(qdd).max(axis=1), tiny),
        ]
    )


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
    limits (:func:`limit_scales`). One factor per joint and coefficient set,
    so eq. 17's equalities still hold.

    Args:
      base_frequency: f in Hz.
      q0: (n,) or (P, n) offsets in rad or m.
      a, b: (P, n, N) coefficients in rad/s or m/s.
      model: the robot whose limits apply.
      margin: fraction of each limit the motion may use, e.g. 0.95.
      t: (M,) times in s at which the motion is checked.

    Returns:
      the scaled (a, b), (P, n, N) each.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, random_fourier_trajectory
    >>> from rmdrake.excitation import fit_to_limits
    >>> robot = load_robot("rv3sb")
    >>> traj = random_fourier_trajectory(robot, seed=0)
    >>> t = np.linspace(0.0, traj.period, 500)
    >>> a10, b10 = 10 * traj.a[None], 10 * traj.b[None]  # (P, n, N): 10 times too large
    >>> a, b = fit_to_limits(0.1, traj.q0, a10, b10, robot, 0.95, t)
    >>> a.shape, bool((np.abs(a) <= np.abs(a10)).all())
    ((1, 6, 5), True)
    """
    e, qd, qdd = fourier_series(
        t, base_frequency=base_frequency, q0=np.zeros(a.shape[-2]), a=a, b=b
    )
    s = limit_scales(e, qd, qdd, q0, model, margin)
    return a * s[..., None], b * s[..., None]


class ExcitationCost:
    """The DE objective of eq. 16, vectorised over a population.

    Per candidate x (coordinates of :class:`FourierParametrization`):
    coefficients -> q - q0, qd, qdd at the S design ``times`` and the
    ``limit_times`` (s; one
    :func:`~rmdrake.excitation.trajectory.fourier_series` evaluation for the
    whole population) -> one factor per joint into the limits at all those
    samples (:func:`limit_scales`, eq. 17; the scaled motion is that factor
    times the sampled one, so the series is not evaluated again) -> base
    regressor at the design times (paper eq. 15, the A of eq. 14, S n x p)
    -> information matrix G = A^T A (p x p) -> criterion ``"cond"``:
    cond(A) = sqrt(lambda_max / lambda_min) of G (paper eq. 16), or
    ``"logdet"``: -mean(log lambda) (D-optimality, minimised). The series is
    cheap and the regressor is not, so the limits may be checked on denser
    samples than A is built from (None: the design times only).

    Precision of the Gram route: a backward-stable symmetric eigensolver gives
    each eigenvalue of G to about eps lambda_max, so lambda_min carries a
    relative error of about eps cond(A)^2, 1e-16 x 1e6 = 1e-10 for
    cond(A) = 1000 (designs sit at 30-1000): the same figure as a tall SVD of
    A to far better than the DE needs (tests check 1e-8), at a fraction of
    its cost (a 600 x 52 SVD costs 4-6 times the 52 x 52 eigenvalues plus
    the product).

    Candidates go in chunks of ``chunk`` to bound memory (about
    chunk * S * n * 13 n doubles). With a ``checker``, a candidate whose motion
    at the design times comes closer than ``clearance`` (m) costs
    :data:`INFEASIBLE` x (2 - k / S), k its samples clear before the first that
    is not (:meth:`clear_samples`).

    The cost pickles (a chunk of a generation is a task on a Dask worker,
    :func:`design_excitation`'s ``execution``); so does its ``checker``
    (:class:`~rmdrake.kinematics.clearance.ClearanceChecker`).

    Example:

    >>> import numpy as np
    >>> from rmdrake import base_parameters, load_robot
    >>> from rmdrake.excitation import ExcitationCost, FourierParametrization
    >>> robot = load_robot("rv3sb")
    >>> free = FourierParametrization(robot.n_joints, harmonics=5)
    >>> cost = ExcitationCost(
    ...     model=robot,
    ...     base=base_parameters(robot),
    ...     parametrization=free,
    ...     q0=np.zeros(6),
    ...     base_frequency=0.1,
    ...     times=np.linspace(0.0, 10.0, 50, endpoint=False),
    ... )
    >>> X = np.random.default_rng(0).uniform(-1.0, 1.0, (4, free.size))
    >>> costs = cost(X)
    >>> costs.shape, bool((costs >= 1.0).all())
    ((4,), True)
    """

    def __init__(
        self,
        *,
        model: RobotModel,
        base: BaseParameters | PayloadColumns,
        parametrization: FourierParametrization,
        q0: np.ndarray,
        base_frequency: float,
        times: np.ndarray,
        margin: float = 0.95,
        criterion: str = "cond",
        chunk: int = 64,
        checker: ClearanceChecker | None = None,
        clearance: float = 0.0,
        limit_times: np.ndarray | None = None,
    ) -> None:
        if criterion not in ("cond", "logdet"):
            raise ValueError(
                f"criterion: expected 'cond' or 'logdet', found {criterion!r}"
            )
        from rmdrake.dynamics.chain import SerialChain

        self.model = model
        self.chain = SerialChain.from_model(model)
        self.base = base
        self.parametrization = parametrization
        self.q0 = np.asarray(q0, dtype=np.float64)
        self.base_frequency = float(base_frequency)
        self.times = np.asarray(times, dtype=np.float64)
        self.limit_times = (
            self.times
            if limit_times is None
            else np.concatenate([self.times, np.asarray(limit_times, np.float64)])
        )
        self.margin = float(margin)
        self.criterion = criterion
        self.chunk = int(chunk)
        self.checker = checker
        self.clearance = float(clearance)

    def clear_samples(
        self, a: np.ndarray, b: np.ndarray, times: np.ndarray
    ) -> np.ndarray:
        """(P,) how many samples at ``times`` (s) of trajectories (a, b) keep the
        clearance before the first that does not (S: all of them; S without a
        checker). Samples are checked every 4th first, so a collision is found
        early."""
        P, S = a.shape[0], times.size
        if self.checker is None:
            return np.full(P, S)
        order = np.concatenate([np.arange(k, S, 4) for k in range(4)])
        q = fourier_series(
            times[order], base_frequency=self.base_frequency, q0=self.q0, a=a, b=b
        )[0]
        return np.array([self.checker.clear_prefix(qp, self.clearance) for qp in q])

    def coefficients(
        self, X: np.ndarray, times: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Feasible (a, b), (P, n, N), of candidates X (P, k); the limits are
        checked at ``times`` (default the design and limit times)."""
        a, b = self.parametrization.coefficients(np.atleast_2d(X))
        t = self.limit_times if times is None else times
        return fit_to_limits(
            self.base_frequency, self.q0, a, b, self.model, self.margin, t
        )

    def motion(
        self, X: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Feasible candidates and their motion at the design times, from one
        series evaluation at the design and limit times: (a, b) as
        :meth:`coefficients` (P, n, N), rad/s or m/s, and q, qd, qdd
        (P, S, n) at the S design times, in rad, rad/s, rad/s^2 (m for a
        prismatic joint)."""
        a, b = self.parametrization.coefficients(np.atleast_2d(X))
        e, qd, qdd = fourier_series(
            self.limit_times,
            base_frequency=self.base_frequency,
            q0=np.zeros(a.shape[1]),
            a=a,
            b=b,
        )
        s = limit_scales(e, qd, qdd, self.q0, self.model, self.margin)
        sm = s[:, None, :]
        S = self.times.size
        q = self.q0 + e[:, :S] * sm
        return a * s[..., None], b * s[..., None], q, qd[:, :S] * sm, qdd[:, :S] * sm

    def gram(self, a: np.ndarray, b: np.ndarray, times: np.ndarray) -> np.ndarray:
        """(P, p, p) Gram matrices A^T A of trajectories (a, b) at ``times``."""
        q, qd, qdd = fourier_series(
            times, base_frequency=self.base_frequency, q0=self.q0, a=a, b=b
        )
        return self.gram_of_motion(q, qd, qdd)

    def gram_of_motion(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
    ) -> np.ndarray:
        """(P, p, p) Gram matrices A^T A of sampled motions q, qd, qdd
        (P, S, n; rad, rad/s, rad/s^2 or m, m/s, m/s^2), ``chunk`` motions at
        a time; A (S n x p) in the regressor's SI units (N m or N per
        parameter unit)."""
        P, S, n = q.shape
        out = []
        for k in range(0, P, self.chunk):
            part = slice(k, k + self.chunk)
            Y = self.base.regressor(
                self.chain,
                q[part].reshape(-1, n),
                qd[part].reshape(-1, n),
                qdd[part].reshape(-1, n),
            )
            Y = Y.reshape(-1, S * n, Y.shape[-1])
            out.append(np.matmul(Y.transpose(0, 2, 1), Y))
        return np.concatenate(out)

    @staticmethod
    def eigenvalues(G: np.ndarray) -> np.ndarray:
        """(P, p) eigenvalues, ascending, of symmetric matrices G (P, p, p)
        (their lower triangles); NaN rows where LAPACK fails (non-finite G).

        LAPACK's values-only path (dsytrd to a tridiagonal, dsterf), the one
        numpy's ``eigvalsh`` takes, called per matrix: faster than the batched
        ``eigvalsh`` for matrices of a base parameter set's size.
        """
        import scipy.linalg.lapack

        out = np.full(G.shape[:2], np.nan)
        for k, g in enumerate(G):
            if not np.isfinite(g).all():
                continue
            _, d, e, _, info = scipy.linalg.lapack.dsytrd(g, lower=1)
            if info == 0:
                w, info = scipy.linalg.lapack.dsterf(d, e)
                if info == 0:
                    out[k] = w
        return out

    @classmethod
    def cond(cls, G: np.ndarray) -> np.ndarray:
        """cond(A) = sqrt(lambda_max / lambda_min) of Gram matrices (P, p, p);
        1e12 for singular ones (lambda_min <= 0) or failed ones."""
        return cls.cond_of_eigenvalues(cls.eigenvalues(G))

    @staticmethod
    def cond_of_eigenvalues(ev: np.ndarray) -> np.ndarray:
        """cond(A) (P,) from the ascending eigenvalues (P, p) of A^T A: the
        rule of :meth:`cond`."""
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.sqrt(ev[:, -1] / ev[:, 0])
        return np.where(ev[:, 0] > 0, c, 1e12)

    def score(self, G: np.ndarray) -> np.ndarray:
        """The criterion of Gram matrices (lower is better)."""
        return self.score_of_eigenvalues(self.eigenvalues(G))

    def score_of_eigenvalues(self, ev: np.ndarray) -> np.ndarray:
        """The criterion (P,) from the ascending eigenvalues (P, p) of A^T A:
        cond(A), or -mean(log lambda) for ``"logdet"``."""
        if self.criterion == "cond":
            return self.cond_of_eigenvalues(ev)
        return -np.mean(np.log(np.maximum(ev, 1e-300)), axis=1)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        a, b, q, qd, qdd = self.motion(X)
        c = self.score(self.gram_of_motion(q, qd, qdd))
        if self.checker is not None:
            S = self.times.size
            k = self.clear_samples(a, b, self.times)
            c = np.where(k < S, INFEASIBLE * (2.0 - k / S), c)
        return c


@dataclasses.dataclass(frozen=True)
class ExcitationResult:
    """Result of :func:`design_excitation`.

    Attributes:
      trajectory: the optimised trajectory (inside the limits, at rest at t = 0).
      criterion: ``"cond"`` or ``"logdet"``.
      cond: cond(A) of the base observation matrix on the full period
        (whatever the criterion).
      samples: samples of that full period, sample_rate / base_frequency
        (1500 for the paper's 150 Hz and 0.1 Hz).
      random_conds: cond(A) on the full period of random feasible trajectories
        in the same limits: random coordinates in the same box, scaled into the
        limits like every DE candidate, then by a random amplitude u ~ U(0, 1]
        (a random point of the feasible set, not only of its boundary).
      random_conds_full: the same trajectories without the random amplitude
        (every one touching a limit on each joint): a stricter baseline.
      history: (G, 3) rows of (generation, wall time s, best cost so far).
      time: wall time of the optimisation, s.
      generations: DE generations run; stopped: why the DE stopped.
      min_clearance: with a cell, the smallest signed distance (m) of the
        trajectory's samples of the full period to the cell (and between
        non-adjacent links when the checker includes them); NaN without one.
      log_det: the D-optimality figure on the full period, whatever the
        criterion: log det(A^T A) / p, the mean log eigenvalue of the
        information matrix of the p base parameters (higher is better; A in
        the regressor's SI units).
      payload: A holds the payload's 10 columns
        (:class:`~rmdrake.dynamics.payload.PayloadColumns`), not the base
        parameters'.
      finalists: the criterion (cond(A), or -log det(A^T A) / p) on the full
        period of the DE's last bests (at most :data:`FINALISTS`, oldest
        first); the trajectory is the lowest of them.
      budget_warning: the warning line when the wall-time budget stopped the
        DE or the random baseline (the result then depends on the machine's
        speed and load), else empty: the generations decided.

    Example:

    >>> from rmdrake import design_excitation, load_robot
    >>> robot = load_robot("rv3sb")
    >>> result = design_excitation(
    ...     robot, harmonics=3, maxiter=2, n_random=2, progress=False
    ... )
    >>> type(result).__name__, result.generations, result.random_conds.shape
    ('ExcitationResult', 2, (2,))
    """

    trajectory: FourierTrajectory
    criterion: str
    cond: float
    samples: int
    random_conds: np.ndarray
    random_conds_full: np.ndarray
    history: np.ndarray
    time: float
    generations: int
    stopped: str
    min_clearance: float = math.nan
    log_det: float = math.nan
    payload: bool = False
    finalists: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    budget_warning: str = ""

    def save(self, path: str | os.PathLike) -> Path:
        """Writes the trajectory YAML (:meth:`FourierTrajectory.save`) to
        ``path`` atomically, headed by a ``# warning: ...`` comment when the
        wall-time budget stopped the design (:attr:`budget_warning`), so the
        file says it; returns the path."""
        head = f"# warning: {self.budget_warning}\n" if self.budget_warning else ""
        return atomic_write_text(path, head + self.trajectory.to_yaml())

    def summary(self) -> str:
        """Two lines: the DE run, then cond(A) against the random baselines
        (their median, and how many times higher than the optimised one)."""
        tr = self.trajectory
        text = (
            f"{tr.harmonics} harmonics at {tr.base_frequency:g} Hz; DE "
            f"({self.criterion}) ran {self.generations} generations in "
            f"{self.time:.1f} s ({self.stopped})"
            + (
                f"; the best of its last {self.finalists.size} bests on the full period"
                if self.finalists.size > 1
                else ""
            )
            + "\n"
            f"cond(A{' of the payload' if self.payload else ''}) on "
            f"{self.samples} samples: optimised {self.cond:.4g} "
            f"(log det(A^T A) / p = {self.log_det:.4g})"
        )
        if self.random_conds.size:
            median = float(np.median(self.random_conds))
            median_full = float(np.median(self.random_conds_full))
            text += (
                f"; median of {self.random_conds.size} random feasible "
                f"trajectories {median:.4g} ({median / self.cond:.2f}x higher), "
                f"{median_full:.4g} ({median_full / self.cond:.2f}x) when each is "
                f"scaled up to its limits"
            )
        if not math.isnan(self.min_clearance):
            text += (
                f"\nclearance to the cell >= "
                f"{self.min_clearance * 1e3:.1f} mm on the {self.samples} samples"
            )
        if self.budget_warning:
            text += f"\nwarning: {self.budget_warning}"
        return text


class WallBudgetWarning(UserWarning):
    """An excitation design stopped by its wall-time budget: its result
    depends on the machine's speed and load (:func:`design_excitation`)."""


def _budget_warning(
    keys: tuple[str, str],
    max_time: float,
    *,
    generations: int | None,
    maxiter: int,
    baseline: tuple[int, int] | None,
) -> str:
    """The warning line of a design the wall-time budget ``max_time`` (s)
    stopped: after ``generations`` of ``maxiter`` (None: the DE finished)
    and/or with ``baseline`` = (evaluated, asked) random trajectories
    (None: all evaluated). ``keys``: the caller's names of the wall-time
    budget and of the generations."""
    time_key, generations_key = keys
    what = []
    if generations is not None:
        what.append(f"after generation {generations} of {maxiter}")
    if baseline is not None:
        what.append(f"its random baseline after {baseline[0]} of {baseline[1]}")
    return (
        f"excitation design stopped by its wall-time budget {time_key} = "
        f"{max_time:g} s {' and '.join(what)}: the result depends on the "
        f"machine's load; budget by {generations_key} (and no {time_key}) for "
        "the same bytes on any machine"
    )


class _Budget(Exception):
    """Raised inside the DE objective when the time budget is spent."""


def _check_sizes(
    n: int, N: int, f: float, rate: float, max_time: float | None, per_link: int
) -> None:
    """Refuses, before any allocation, sizes outside :data:`MAX_HARMONICS`,
    :data:`MAX_PERIOD_S`, the memory cap (a Gram evaluation of 64 candidates on
    the full period: 64 x rate/f x n x per_link n doubles) or a bad budget."""
    if not 3 <= N <= MAX_HARMONICS:
        raise ValueError(
            f"harmonics: expected >= 3 (eq. 17 puts two equalities on b) and "
            f"<= {MAX_HARMONICS}, found {N}"
        )
    for name, v in (
        ("base_frequency", f),
        ("sample_rate", rate),
        ("max_time", 1.0 if max_time is None else max_time),
    ):
        if not math.isfinite(v) or v <= 0:
            raise ValueError(f"{name}: expected a positive finite number, found {v}")
    if f * MAX_PERIOD_S < 1.0:
        raise ValueError(
            f"base_frequency: {f:g} Hz is a period of {1 / f:.3g} s, over the "
            f"{MAX_PERIOD_S:g} s limit"
        )
    S = rate / f
    check_memory(
        64.0 * S * n * per_link * n,
        f"excitation: cond(A) on {S:.3g} samples ({rate:g} Hz x {1 / f:.3g} s)",
        "lower the sample rate or raise the base frequency",
    )


def design_excitation(
    model: RobotModel,
    *,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    sample_rate: float = 150.0,
    design_samples: int = 50,
    q0: np.ndarray | None = None,
    criterion: str = "cond",
    margin: float = 0.95,
    per_link: int = 13,
    seed: int = 0,
    popsize: int = 5,
    maxiter: int = 600,
    max_time: float | None = None,
    n_random: int = 50,
    progress: bool = True,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
    payload: bool = False,
    execution: Execution | None = None,
    budget_keys: tuple[str, str] = ("max_time", "maxiter"),
) -> ExcitationResult:
    """Optimal Fourier excitation by Differential Evolution (paper eq. 16-17).

    Minimises cond(A) (or the D-optimal criterion) of the base observation
    matrix over the free coordinates of :class:`FourierParametrization`, so the
    equalities of eq. 17 hold by construction; every candidate is scaled into
    ``margin`` times the robot's position, velocity and acceleration limits
    (:func:`limit_scales`, checked on the sampled motion at
    :data:`LIMIT_SAMPLES_PER_HARMONIC` samples per harmonic and period, which
    is less conservative than eq. 17's sums of amplitudes; the final
    trajectory is scaled again on 200 per harmonic, so it never exceeds a
    limit). The DE builds A on ``design_samples`` evenly spaced samples of
    one period; the result's cond(A) is then evaluated on the full period at
    ``sample_rate``. The population is evaluated vectorised, in chunks of 64
    candidates; with an ``execution`` that has workers, each generation's
    chunks are tasks on them (scipy's deferred updating: a generation's
    candidates do not depend on each other's costs), and the design is the
    same, bit for bit, as in this process.

    Default sizes (``bench/excitation.py`` prints their cost and the cond(A)
    each seed reaches on the RV-3SB): cond(A) on 50 design samples tracks the
    1500 of the period to a few % at the DE's bests (random feasible
    candidates: median ratio 1.006, worst 0.90; 25 samples: median 1.16); 32
    samples, or popsize 8 or 15 for the same candidates, ended higher. The
    DE's end point moves by several % with the round-off of the cost.

    Args:
      model: the robot (kinematics; its limits are the bounds).
      harmonics, base_frequency: N and f (Hz) of eq. 11-13.
      sample_rate: samples per second of the final evaluation, Hz.
      design_samples: samples per period used inside the DE.
      q0: (n,) rest pose, rad or m; default the middle of each joint's range.
      criterion: ``"cond"`` (paper eq. 16) or ``"logdet"`` (D-optimal).
      margin: fraction of each limit the trajectory may use.
      per_link: standard parameters per link of the base set (10, 11 or 13).
      seed, popsize, maxiter: of the DE (scipy conventions).
      max_time: wall-time budget of the design, s; None (the default): none,
        the generations decide and the design is the same, bit for bit, on
        any machine at any load. With a budget, the clock is checked between
        chunks of 64 candidates, so the DE stops within one chunk's
        evaluation of it with the best so far; the random baseline then
        stops at the budget too (at least one trajectory). A design the
        budget stopped depends on the machine's load: it warns
        (:class:`WallBudgetWarning`, naming the budget and the generation)
        and says so in :attr:`ExcitationResult.budget_warning`, its summary
        and the file :meth:`ExcitationResult.save` writes.
      n_random: random feasible trajectories evaluated for comparison.
      progress: show a progress bar with the best cost.
      checker, clearance: the robot's cell and the distance (m) the motion keeps
        from it and between non-adjacent links (module docstring); None: the
        limits only. The random baseline ignores the cell.
      payload: A is the payload's 10 regressor columns (inertial parameters at
        the tool frame, :class:`~rmdrake.dynamics.payload.PayloadColumns`)
        instead of the base parameters': a motion that identifies a tool
        payload on an identified arm (``per_link`` then unused).
      budget_keys: the names the warning gives ``max_time`` and ``maxiter``
        (a scenario's ``design_time`` and ``design_maxiter``, the CLI's
        ``--max-time`` and ``--maxiter``).
      execution: where each generation's chunks are evaluated (None: in this
        process). Workers add a round trip per generation and a start-up
        cost, so at the default sizes (210 candidates, 4 chunks) the design is
        faster in this process; workers pay with more cores, a larger
        population or a cell's clearance checks.

    Raises:
      ValueError: bad sizes, q0 outside the limits, a model without limits room,
        q0 closer than the clearance, or no candidate keeping the clearance.

    Example:

    >>> from rmdrake import design_excitation, load_robot
    >>> robot = load_robot("rv3sb")
    >>> result = design_excitation(
    ...     robot, harmonics=3, maxiter=2, n_random=2, progress=False
    ... )
    >>> result.trajectory.harmonics, result.criterion, bool(result.cond >= 1.0)
    (3, 'cond', True)
    """
    n = model.n_joints
    q0 = _rest_pose(model, q0)
    _check_sizes(n, harmonics, base_frequency, sample_rate, max_time, per_link)
    if design_samples < 4 * harmonics:
        raise ValueError(
            f"design_samples: expected >= 4 x harmonics = {4 * harmonics}, "
            f"found {design_samples}"
        )
    t_design, t_full, t_dense, t_limits = _sample_times(
        harmonics, base_frequency, sample_rate, design_samples
    )
    if checker is not None and not checker.clear(q0, clearance)[0]:
        raise ValueError(
            f"q0 comes closer than the clearance of {clearance:g} m to the cell "
            "or between links; choose another rest pose or a smaller clearance"
        )
    cost = _design_cost(
        model,
        q0,
        harmonics=harmonics,
        base_frequency=base_frequency,
        t_design=t_design,
        t_limits=t_limits,
        margin=margin,
        criterion=criterion,
        per_link=per_link,
        payload=payload,
    )
    cost.checker, cost.clearance = checker, float(clearance)
    bounds = _search_box(model, base_frequency, cost.parametrization)
    chunks = math.ceil(popsize * bounds.shape[0] / cost.chunk)  # per generation
    with TaskRunner(execution or SERIAL, tasks=chunks) as runner:
        run = _run_de(
            cost,
            bounds,
            seed=seed,
            popsize=popsize,
            maxiter=maxiter,
            max_time=max_time,
            progress=progress,
            final_times=(t_dense, t_full),
            runner=runner,
        )
    if not len(run.finalists):
        raise ValueError(
            f"no candidate kept the clearance of {clearance:g} m at every sample "
            "of the period; raise the budget or lower the clearance"
        )
    a, b = cost.coefficients(run.finalists, t_dense)
    eigenvalues = cost.eigenvalues(cost.gram(a, b, t_full))
    finalists = cost.score_of_eigenvalues(eigenvalues)
    i = int(np.argmin(finalists))
    a, b, eigenvalues = a[i : i + 1], b[i : i + 1], eigenvalues[i]
    cond = cost.cond_of_eigenvalues(eigenvalues[None])
    log_det = float(np.mean(np.log(np.maximum(eigenvalues, 1e-300))))
    trajectory = FourierTrajectory(base_frequency=base_frequency, q0=q0, a=a[0], b=b[0])
    trajectory.check_limits(model)
    min_clearance = math.nan
    if checker is not None:
        q_full = fourier_series(t_full, base_frequency=base_frequency, q0=q0, a=a, b=b)[
            0
        ][0]
        min_clearance = float(checker.clearance(q_full).min())
    conds, conds_full = _random_baseline(
        cost,
        bounds,
        t_dense,
        t_full,
        seed=seed + 1,
        n_random=n_random,
        start=run.start,
        max_time=max_time,
    )
    budget = ""
    cut = run.budget_stopped or len(conds) < n_random
    if max_time is not None and cut:
        budget = _budget_warning(
            budget_keys,
            max_time,
            generations=max(len(run.history) - 1, 0) if run.budget_stopped else None,
            maxiter=maxiter,
            baseline=(len(conds), n_random) if len(conds) < n_random else None,
        )
        warnings.warn(budget, WallBudgetWarning, stacklevel=2)
    return ExcitationResult(
        trajectory=trajectory,
        criterion=criterion,
        cond=float(cond[0]),
        samples=t_full.size,
        random_conds=np.array(conds),
        random_conds_full=np.array(conds_full),
        history=np.array(run.history),
        time=run.elapsed,
        generations=max(len(run.history) - 1, 0),
        stopped=run.stopped,
        min_clearance=min_clearance,
        log_det=log_det,
        payload=payload,
        finalists=finalists,
        budget_warning=budget,
    )


# ---- the steps of design_excitation, in order ---------------------------------------
def _rest_pose(model: RobotModel, q0: np.ndarray | None) -> np.ndarray:
    """(n,) rest pose, rad or m: ``q0``, or by default the middle of each
    joint's range.

    Raises:
      ValueError: NaN, a wrong shape, or a joint not strictly inside its limits.
    """
    n = model.n_joints
    lim = model.limits
    q0 = (
        0.5 * (lim.lower + lim.upper) if q0 is None else as_finite_array(q0, "q0", (n,))
    )
    outside = np.flatnonzero((q0 <= lim.lower) | (q0 >= lim.upper))
    if outside.size:
        j = int(outside[0])
        unit = "m" if model.sigma[j] == 1 else "rad"
        raise ValueError(
            f"q0: joint {j + 1} at {q0[j]:.4g} {unit} is not strictly inside its "
            f"limits [{lim.lower[j]:.4g}, {lim.upper[j]:.4g}] {unit}"
        )
    return q0


def _sample_times(
    harmonics: int, base_frequency: float, sample_rate: float, design_samples: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t_design, t_full, t_dense, t_limits), s, evenly spaced over one period
    from 0: ``design_samples`` samples (A of the DE's cost), the samples at
    ``sample_rate`` Hz (the final cond(A)), 200 per harmonic (where the final
    trajectory's limits are checked) and :data:`LIMIT_SAMPLES_PER_HARMONIC`
    per harmonic (where the DE's candidates are scaled into the limits)."""
    period = 1.0 / base_frequency
    t_design = np.arange(design_samples) * (period / design_samples)
    t_full = np.arange(int(round(sample_rate * period))) / sample_rate
    t_dense = np.arange(200 * harmonics) * (period / (200 * harmonics))
    limits = LIMIT_SAMPLES_PER_HARMONIC * harmonics
    t_limits = np.arange(limits) * (period / limits)
    return t_design, t_full, t_dense, t_limits


def _design_cost(
    model: RobotModel,
    q0: np.ndarray,
    *,
    harmonics: int,
    base_frequency: float,
    t_design: np.ndarray,
    t_limits: np.ndarray | None = None,
    margin: float,
    criterion: str,
    per_link: int,
    payload: bool = False,
) -> ExcitationCost:
    """The DE objective: ``criterion`` of the base observation matrix (base set
    of ``per_link`` parameters per link, and with 13 the coupled motors'
    ``Iam, fvm, fcm`` of a robot that has them, as identify fits them) at
    ``t_design`` (s) of trajectories at
    rest at ``q0`` (rad or m) with ``harmonics`` harmonics of
    ``base_frequency`` Hz, each scaled into ``margin`` times the limits at
    ``t_design`` and ``t_limits`` (s); with ``payload``, of the payload's 10
    columns instead.

    Raises:
      ValueError: an unknown ``per_link`` or ``criterion``.
    """
    from rmdrake.dynamics.base import base_parameters
    from rmdrake.dynamics.payload import PayloadColumns

    param = FourierParametrization(model.n_joints, harmonics)
    if payload:
        base = PayloadColumns(model)
    elif per_link == 13 and model.coupled_motors:  # + the coupled motors' terms
        base = base_parameters(model, terms=model.dynamic_terms)
    else:
        base = base_parameters(model, per_link)
    return ExcitationCost(
        model=model,
        base=base,
        parametrization=param,
        q0=q0,
        base_frequency=base_frequency,
        times=t_design,
        margin=margin,
        criterion=criterion,
        limit_times=t_limits,
    )


def _search_box(
    model: RobotModel, base_frequency: float, param: FourierParametrization
) -> np.ndarray:
    """(k, 2) lower and upper bound of each free coordinate, rad/s or m/s: the
    velocity amplitude of a fundamental (``base_frequency`` Hz) that would
    sweep the whole joint range, or the velocity limit if lower."""
    lim = model.limits
    half = np.minimum(
        0.5 * (lim.upper - lim.lower) * 2 * math.pi * base_frequency, lim.velocity
    )
    half = np.repeat(half, param.per_joint)
    return np.stack([-half, half], axis=1)


@dataclasses.dataclass(frozen=True)
class _DeRun:
    """What :func:`_run_de` found.

    Attributes:
      finalists: (K, k) the last K <= :data:`FINALISTS` bests' coordinates,
        oldest first (the best last; none when no candidate kept the
        clearance).
      history: (generation, wall time s, best cost so far) per generation.
      stopped: why the DE stopped.
      budget_stopped: the wall-time budget stopped it.
      start: ``time.perf_counter()`` at the start, s (the budget's origin).
      elapsed: wall time of the run, s.
    """

    finalists: np.ndarray
    history: list[tuple[int, float, float]]
    stopped: str
    budget_stopped: bool
    start: float
    elapsed: float


def _run_de(
    cost: ExcitationCost,
    bounds: np.ndarray,
    *,
    seed: int,
    popsize: int,
    maxiter: int,
    max_time: float | None,
    progress: bool,
    final_times: tuple[np.ndarray, np.ndarray] | None = None,
    runner: TaskRunner | None = None,
) -> _DeRun:
    """Minimises ``cost`` over the box ``bounds`` by Differential Evolution
    (:func:`rmdrake.optimize.differential_evolution`, tol 1e-6, deferred
    updating), keeping the last :data:`FINALISTS` bests seen (each lower
    than the one before); with a ``max_time`` (None: none), stops early, with
    them, once ``max_time`` s of wall time are spent (checked between chunks of
    candidates; between generations when ``runner`` is parallel, which
    evaluates a generation's chunks as tasks). With a cell
    (``cost.checker``), a candidate becomes the best only if its final
    trajectory (limits at ``final_times[0]``, s) keeps the clearance at every
    sample of ``final_times[1]`` (s); one that does not is given the
    infeasible cost. The best is updated chunk by chunk in population order
    (in this process), so the run does not depend on where chunks ran."""
    from rmdrake.optimize import differential_evolution

    history: list[tuple[int, float, float]] = []
    best: dict[str, Any] = {"x": None, "f": np.inf}
    bests: collections.deque[np.ndarray] = collections.deque(maxlen=FINALISTS)
    t0 = time.perf_counter()

    def spent() -> bool:
        """The wall-time budget is spent (never without one), and a best
        exists."""
        if max_time is None or best["x"] is None:
            return False
        return time.perf_counter() - t0 > max_time

    def chunk_costs(X: np.ndarray):
        """The cost of each chunk of X, in order; _Budget once the budget
        is spent (and a best exists)."""
        starts = range(0, len(X), cost.chunk)
        if runner is not None and runner.parallel:
            if spent():
                raise _Budget
            yield from runner.scipy_map(cost, [X[k : k + cost.chunk] for k in starts])
            return
        for k in starts:  # the clock, chunk by chunk
            if spent():
                raise _Budget
            yield cost(X[k : k + cost.chunk])

    def objective(X: np.ndarray) -> np.ndarray:
        c = np.empty(len(X))
        for k, part in zip(range(0, len(X), cost.chunk), chunk_costs(X), strict=True):
            c[k : k + cost.chunk] = part
            for i in k + np.argsort(c[k : k + cost.chunk]):
                if not c[i] < min(best["f"], INFEASIBLE):
                    break
                if _keeps_clearance(cost, X[i], final_times):
                    best.update(x=X[i].copy(), f=float(c[i]))
                    bests.append(best["x"])
                    break
                c[i] = INFEASIBLE
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
            desc=f"excitation design ({cost.criterion})",
        )
        stopped, budget_stopped = str(res.message), False
    except _Budget:
        stopped = (
            f"wall-time budget of {max_time:g} s spent in generation {len(history)}"
        )
        budget_stopped = True
    elapsed = time.perf_counter() - t0
    return _DeRun(
        finalists=np.array(bests).reshape(len(bests), bounds.shape[0]),
        history=history,
        stopped=stopped,
        budget_stopped=budget_stopped,
        start=t0,
        elapsed=elapsed,
    )


def _keeps_clearance(
    cost: ExcitationCost,
    x: np.ndarray,
    final_times: tuple[np.ndarray, np.ndarray] | None,
) -> bool:
    """Whether candidate x (k,) keeps the clearance on the final trajectory:
    scaled into the limits at ``final_times[0]``, every sample of
    ``final_times[1]`` (s) checked. True without a checker."""
    if cost.checker is None or final_times is None:
        return True
    t_limits, t_samples = final_times
    a, b = cost.coefficients(x[None], t_limits)
    return bool(cost.clear_samples(a, b, t_samples)[0] == t_samples.size)


def _full_period(
    cost: ExcitationCost, X: np.ndarray, t_dense: np.ndarray, t_full: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, cond) of candidates X (P, k): their coefficients (P, n, N) in
    rad/s or m/s, scaled into the limits at ``t_dense`` (s), and cond(A) (P,)
    on the full period's samples ``t_full`` (s)."""
    a, b = cost.coefficients(X, t_dense)
    return a, b, cost.cond(cost.gram(a, b, t_full))


def _random_baseline(
    cost: ExcitationCost,
    bounds: np.ndarray,
    t_dense: np.ndarray,
    t_full: np.ndarray,
    *,
    seed: int,
    n_random: int,
    start: float,
    max_time: float | None,
) -> tuple[list[float], list[float]]:
    """cond(A) on the full period of ``n_random`` random feasible trajectories
    (see :class:`ExcitationResult`): coordinates uniform in ``bounds``, from
    ``numpy.random.default_rng(seed)``, scaled into the limits, then by a
    random amplitude in (0, 1] (first list) or not (second list). With a
    ``max_time`` (None: none), stops once ``max_time`` s have passed since
    ``start`` (``time.perf_counter()``, s), after at least one trajectory."""
    rng = np.random.default_rng(seed)
    X_random = rng.uniform(bounds[:, 0], bounds[:, 1], (n_random, bounds.shape[0]))
    u = np.maximum(rng.uniform(0.0, 1.0, (n_random, 1, 1)), 1e-3)  # U(0, 1]
    conds, conds_full = [], []
    for k in range(n_random):  # the baseline stops with the budget
        if k and max_time is not None and time.perf_counter() - start > max_time:
            break
        a_r, b_r, c_full = _full_period(cost, X_random[k : k + 1], t_dense, t_full)
        conds_full.append(c_full[0])
        conds.append(cost.cond(cost.gram(a_r * u[k], b_r * u[k], t_full))[0])
    return conds, conds_full
