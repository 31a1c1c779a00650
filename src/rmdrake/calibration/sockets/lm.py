"""Kinematic calibration from a ball seated in sockets: :class:`SocketLM`.

The estimator follows the scikit-learn contract of the plate and point
estimators (``__init__`` stores options, ``fit(data)`` checks the data and
returns self, results end in ``_``). Unknowns: the error parameters and one
point per socket in the base frame
(:class:`~rmdrake.calibration.sockets.problem.SocketProblem`). Steps:

1. checks: the joint count; every socket has at least 2 rows and every
   placement at least as many rows as the 3 unknowns per socket it adds; a
   Jacobian within :data:`MAX_JACOBIAN_BYTES`; every known distance within
   twice the robot's reach (else mm?) and within the sanity length bound of
   the distance between its sockets' mean balls by the nominal model (else a
   distance of other sockets or sockets mixed up between placements)
   before any fit;
2. the parameter set: a preset (``base``: none, the nominal kinematics with
   the socket points fitted; ``offsets``; ``full``) reduced to what sockets
   identify well (:data:`WEAK_RTOL`), or names that must all be identifiable
   at ``rtol``
   (:func:`analyse_socket_identifiability`: the socket points projected out
   first, then the fixed preference order of
   :mod:`rmdrake.calibration.identifiability`); ``auto`` chooses by
   leave-one-placement-out cross-validation (:func:`select_socket_parameters`);
3. Levenberg-Marquardt (MINPACK) from the nominal with each socket point at
   its rows' mean, the distance residuals weighted by ``noise /
   distance_noise``;
4. outliers: a row whose 3-D distance from its socket point exceeds
   :data:`GROSS_Z` times the noise per coordinate (declared, or the
   residuals' robust scale: 1.4826 x their median absolute coordinate) is a
   gross error (a row from another socket, a ball not seated): named, and the
   fit refused. Such rows are looked for first under a robust (Cauchy) fit
   (:meth:`SocketLM._robust_gross`), which one of them cannot drag, then in
   the least-squares fit. Rows beyond the chi (3 dof) quantile at a
   family-wise 0.1 % but below that are named as a warning (on the real
   Panda of MUKCa, 4 of 497 rows at 8-12 times the noise: unmodelled effects,
   not mistakes). ``drop_outliers`` drops the robust fit's gross rows, then
   refits and drops again (the gross rows of a pass alone when it has any),
   until none is left, at most 5 times, and never more than
   :data:`MAX_DROPPED_SHARE` of the rows (refused instead); an estimated
   noise over :data:`~rmdrake.calibration.sanity.SOCKET_MAX_NOISE` is
   refused (``auto`` judged against its own residuals would otherwise call
   any contradiction noise);
5. standard deviations sqrt(diag(sigma^2 (J^T J)^-1)) of the unknowns, sigma
   the declared noise or the residuals' (each residual is in noise units
   scaled to m), and the ``calibration`` record on ``model_`` with MUKCa's
   metrics (:func:`~rmdrake.calibration.sockets.problem.socket_metrics`)
   before and after.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.calibration.config import (
    MAX_DISTANCE_NOISE,
    CalibrationConfig,
    SocketLMConfig,
)
from rmdrake.calibration.identifiability import (
    IdentifiabilityReport,
    analyse_columns,
)
from rmdrake.calibration.lm import delta_lines, least_squares_std, solve_lm
from rmdrake.calibration.parameters import joint_offset_names, resolve_parameters
from rmdrake.calibration.sanity import (
    SOCKET_MAX_NOISE,
    CalibrationBounds,
    SanityReport,
    out_of_bounds_reason,
)
from rmdrake.calibration.selection import StepwiseSelection, stepwise_selection
from rmdrake.calibration.sockets.data import DEFAULT_DISTANCE_NOISE, SocketMeasurements
from rmdrake.calibration.sockets.problem import (
    SocketProblem,
    scale_column,
    socket_metrics,
)
from rmdrake.kinematics.forward import robot_reach, tool_points
from rmdrake.kinematics.rotations import skew
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "WEAK_RTOL",
    "SOCKET_PRESETS",
    "PlacementCV",
    "SocketLM",
    "analyse_socket_identifiability",
    "cross_validate_placements",
    "make_socket_calibrator",
    "row_distances",
    "select_socket_parameters",
]

SOCKET_PRESETS: tuple[str, ...] = ("auto", "base", "offsets", "full")
"""Parameter presets of a socket calibration (as for points)."""

WEAK_RTOL = 0.03
"""Identifiability threshold of a socket calibration's presets and ``auto``
(at least the caller's ``rtol``): a parameter is not fitted when over 97 %
of its unit-scaled effect on the ball is that of the sockets and the
parameters kept before it. The ball sits near the last joint's axis, so the
wrist's parameters are nearly interchangeable there: on MUKCa's real Panda
the structural threshold (1e-6) fits 25 parameters and returns dr6 -43 mm
and dbeta7 -26 deg (std 9 mm and 1.2 deg) for the same held-out consistency
(0.281 mm) as the 22 this one keeps, whose largest deltas are 1.3 deg and
0.5 mm: the model must not carry a wrist geometry the data did not see."""

OUTLIER_ALPHA = 1e-3
"""Family-wise false-alarm rate of the outlier warning over all rows."""

NOISE_FLOOR = 1e-9
"""m: the least estimated noise (noise-free simulated data leave round-off
residuals, which are not a scale to judge rows by)."""

GROSS_Z = 20.0
"""A row this many noise sigmas (per coordinate) from its socket point is a
gross error: refused. The real Panda of MUKCa has rows up to 12.4 sigmas
(unmodelled effects); a ball 3 mm off its seat is over 20 at its 0.15 mm."""


MAX_DROPPED_SHARE = 0.1
"""The largest share of the rows ``drop_outliers`` drops: a few balls not
seated or rows of another socket are mistakes to drop; more than a tenth of
the rows far from their socket are data that contradict each other (sockets
mixed up between placements), refused instead."""


MAX_JACOBIAN_BYTES = 512 * 2**20
"""The largest dense Jacobian (rows x unknowns x 8 bytes) a socket
calibration builds: MUKCa's 497 configurations in 16 sockets make 0.9 MiB;
the bound keeps memory within a laptop's for the several fits of ``auto``."""


MIN_LEVER = 1e-3
"""m per rad (or m per m): a parameter that moves the ball by less than this
RMS over the rows per unit change is not fitted (a joint whose axis passes
within a millimetre of the ball: its offset would take any value)."""


def analyse_socket_identifiability(
    model: RobotModel,
    data: SocketMeasurements,
    names: list[str],
    *,
    rtol: float = 1e-6,
    weight: float = 1.0,
) -> IdentifiabilityReport:
    """Which of ``names`` the socket data identify, at the nominal model.

    Nuisance columns projected out first: the socket points, a rotation of
    the base frame (three columns e_c x p_i: the socket points absorb it
    exactly when each socket's rows agree, so it is taken as absorbed though
    the nominal rows still disagree), and without a known distance the common
    length scale (:func:`~rmdrake.calibration.sockets.problem.scale_column`).
    A parameter that moves the ball by less than :data:`MIN_LEVER` RMS per
    unit has no effect (the last joint's offset with the ball on its axis).
    Then the greedy pass in the MDH preference order
    (:func:`~rmdrake.calibration.identifiability.analyse_columns`).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import analyse_socket_identifiability, simulate_sockets
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_sockets(robot, placements=3, per_socket=6, seed=0).data
    >>> report = analyse_socket_identifiability(robot, data, ["dtheta1", "dtheta2"])
    >>> report.identifiable, sorted(report.dropped)
    (['dtheta2'], ['dtheta1'])
    """
    idx = error_parameter_indices(model, names)
    problem = SocketProblem(model.table, data, idx, sigma=model.sigma, weight=weight)
    x0 = problem.start()
    J = problem.jacobian(x0)
    N, k = data.n_rows, len(names)
    lever = np.sqrt(np.sum(J[: 3 * N, :k] ** 2, axis=0) / N)
    J[:, :k][:, lever < MIN_LEVER] = 0.0
    rotation = np.zeros((J.shape[0], 3))  # d (w x p_i) / dw = -[p_i]x
    rotation[: 3 * N] = -skew(problem.predicted(x0)).reshape(3 * N, 3)
    extra = [rotation]
    nuisance = "socket"
    if data.distances.shape[0] == 0:
        extra.append(scale_column(model.table, data, sigma=model.sigma)[:, None])
        nuisance = "socket_unscaled"
    return analyse_columns(np.hstack([J, *extra]), list(names), idx, rtol, nuisance)


def row_distances(problem: SocketProblem, x: np.ndarray) -> tuple[np.ndarray, float]:
    """((N,) each row's 3-D distance from its socket point at x, m; the
    residuals' robust noise scale per coordinate, 1.4826 x their median
    absolute coordinate, at least :data:`NOISE_FLOOR`, m)."""
    N = problem.q.shape[0]
    r = problem.residuals(x)[: 3 * N]
    noise = max(1.4826 * float(np.median(np.abs(r))), NOISE_FLOOR)
    return np.linalg.norm(r.reshape(N, 3), axis=1), noise


def _candidates(model: RobotModel, params: str | Sequence[str]) -> list[str]:
    if not isinstance(params, str):
        return resolve_parameters(model, list(params)) if len(params) else []
    if params == "base":
        return []
    if params == "offsets":
        return joint_offset_names(model)
    if params == "full":
        return error_parameter_names(model, "full")
    if "," not in params and not params.startswith("d"):
        raise ValueError(
            f"unknown parameter preset '{params}' for socket data: expected "
            f"{', '.join(SOCKET_PRESETS)} or a comma-separated list of names"
        )
    return resolve_parameters(model, params)


@dataclasses.dataclass(frozen=True)
class PlacementCV:
    """Leave-one-placement-out cross-validation of a socket calibration.

    Attributes:
      errors: (N,) every held-out row's distance from its socket's mean, m,
        by the model fitted without its placement (data order).
      before: (N,) the same by the nominal model, m.
      distortion, distortion_before: (D,) each known distance's distortion
        when its placement was held out, m.
      placement: (N,) each row's placement.
      fold_rms: (P,) RMS of ``errors`` per held-out placement, m.
      distance_placement: (D,) the placement of each known distance.
    """

    errors: np.ndarray
    before: np.ndarray
    distortion: np.ndarray
    distortion_before: np.ndarray
    placement: np.ndarray
    fold_rms: np.ndarray
    distance_placement: np.ndarray

    def table_lines(self, names: Sequence[str] | None = None) -> list[str]:
        """Per held-out placement (``names``, default ``placement <p>``): its
        rows, consistency mean before and after, distortion before and after
        (mm; several distances: their mean |.|)."""
        lines = [
            f"{'held-out placement':<20} {'rows':>5} {'consistency mean [mm]':>22} "
            f"{'distortion [mm]':>18}",
        ]
        for p in range(self.fold_rms.size):
            rows = self.placement == p
            d = self.distance_placement == p
            label = names[p] if names is not None else f"placement {p}"

            after, before = (
                _distortion_text(self.distortion, d),
                _distortion_text(self.distortion_before, d),
            )
            lines.append(
                f"{label:<20} {int(rows.sum()):>5} "
                f"{np.mean(self.before[rows]) * 1e3:>10.3f} -> "
                f"{np.mean(self.errors[rows]) * 1e3:>7.3f} "
                f"{before:>8} -> {after:>7}"
            )
        before = np.mean(self.before) * 1e3
        lines.append(
            f"{'all':<20} {self.placement.size:>5} {before:>10.3f} -> "
            f"{self.mean_abs * 1e3:>7.3f} "
            f"{'mean |.|':>8} {np.mean(np.abs(self.distortion)) * 1e3:>10.3f}"
        )
        return lines

    @property
    def mean_abs(self) -> float:
        """Mean held-out consistency error, m."""
        return float(np.mean(self.errors))

    @property
    def rms(self) -> float:
        """RMS held-out consistency error, m."""
        return float(np.sqrt(np.mean(self.errors**2)))

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (m)."""
        return {
            "scheme": "leave one placement out",
            "placements": int(self.fold_rms.size),
            "consistency_mean": self.mean_abs,
            "consistency_rms": self.rms,
            "consistency_mean_nominal": float(np.mean(self.before)),
            "distortion_mean": float(np.mean(self.distortion)),
            "distortion_mean_abs": float(np.mean(np.abs(self.distortion))),
            "distortion_max_abs": float(np.max(np.abs(self.distortion), initial=0)),
        }


def _distortion_text(values: np.ndarray, mask: np.ndarray) -> str:
    """One placement's distortion in mm: signed for one distance, mean |.| for
    several, ``-`` for none."""
    x = values[mask]
    if x.size == 0:
        return "-"
    return f"{x[0] * 1e3:+.3f}" if x.size == 1 else f"{np.abs(x).mean() * 1e3:.3f}"


def cross_validate_placements(make: Any, data: SocketMeasurements) -> PlacementCV:
    """Fits ``make()`` (an unfitted :class:`SocketLM`) on all placements but
    one, and scores the held-out placement's consistency and distortion by
    the fitted model (the held-out rows never enter the fit), each placement
    in turn.

    Raises:
      ValueError: fewer than 2 placements, or a fit that fails (one line).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import SocketLM, cross_validate_placements
    >>> from rmdrake.calibration import simulate_sockets
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_sockets(robot, placements=3, per_socket=6, seed=0).data
    >>> cv = cross_validate_placements(lambda: SocketLM(robot, params="offsets"), data)
    >>> type(cv).__name__
    'PlacementCV'
    """
    P = data.n_placements
    if P < 2:
        raise ValueError(
            "leave-one-placement-out needs at least 2 placements (sockets joined "
            "by known distances are one placement)"
        )
    placement = data.placement
    errors, before = np.zeros(data.n_rows), np.zeros(data.n_rows)
    dist, dist0 = np.zeros(data.distances.shape[0]), np.zeros(data.distances.shape[0])
    d_place = data.placement_of_socket[data.distance_index[:, 0]]
    fold_rms = np.zeros(P)
    for p in range(P):
        rows = placement == p
        est = make().fit(data.subset(~rows))
        held = data.subset(rows)
        model = est.model_
        after = socket_metrics(model.table, held, sigma=model.sigma)
        nominal = socket_metrics(est.model.table, held, sigma=model.sigma)
        errors[rows], before[rows] = after.errors, nominal.errors
        dist[d_place == p], dist0[d_place == p] = after.distortion, nominal.distortion
        fold_rms[p] = after.rms
    return PlacementCV(errors, before, dist, dist0, placement, fold_rms, d_place)


@dataclasses.dataclass(frozen=True)
class SocketSelection(StepwiseSelection):
    """The outcome of :func:`select_socket_parameters` (``folds`` = the
    placements)."""

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (m)."""
        return {
            "rule": "one-standard-error rule on the leave-one-placement-out RMS "
            "of the held-out consistency error over the candidates base, "
            "offsets and full (identifiable subsets)",
            "placements": self.folds,
            "chosen": self.label,
            "selection_cv_rms": self.cv_rms,
            "threshold": self.threshold,
            "candidates": self.candidate_records(),
        }

    def summary_lines(self) -> list[str]:
        """The candidates and the choice, in mm."""
        return [
            f"automatic parameter choice (leave one of {self.folds} placements out, "
            f"one-SE rule: the smallest set with CV RMS <= "
            f"{self.threshold * 1e3:.4g} mm):",
            *self.candidate_lines("mm", 1e3),
        ]


def select_socket_parameters(
    make_with: Any,
    data: SocketMeasurements,
    *,
    max_steps: int = 0,
    progress: bool = False,
) -> SocketSelection:
    """The parameter set chosen by leave-one-placement-out cross-validation
    and the one-SE rule (:mod:`rmdrake.calibration.selection`): the score of a
    set is the RMS over every held-out row of its distance from its socket's
    mean, SE the std of the per-placement RMS / sqrt(P). ``make_with(names)``
    is an unfitted estimator for a list of names. The candidates: ``base``,
    ``offsets``, at most ``max_steps`` forward additions from the identifiable
    ``full`` set (each step fits P placements per remaining name: the default
    0 keeps the choice to seconds), then ``full``."""
    probe = make_with([])
    model, weight = probe.model, probe.distance_weight
    P = data.n_placements

    def score(names: list[str]) -> tuple[float, float, float]:
        try:
            cv = cross_validate_placements(lambda: make_with(names), data)
        except ValueError:
            return np.inf, np.inf, np.inf
        se = float(np.std(cv.fold_rms, ddof=1) / np.sqrt(P))
        return cv.rms, float(cv.errors.max()), se

    def identifiable(names: list[str]) -> list[str]:
        return analyse_socket_identifiability(
            model, data, names, rtol=WEAK_RTOL, weight=weight
        ).identifiable

    full = identifiable(error_parameter_names(model, "full"))
    result = stepwise_selection(
        score,
        identifiable(joint_offset_names(model)),
        full,
        start_label="offsets",
        before=[("base", [])],
        after=[("full", full)],
        max_steps=max_steps,
        progress=progress,
    )
    return SocketSelection(*result, P, 0)


class SocketLM:
    """Levenberg-Marquardt calibration from a ball seated in sockets (the
    module docstring).

    Args:
      model: the nominal robot; its tool point is the ball's centre.
      params: ``auto``, ``base``, ``offsets``, ``full`` or a list of names.
      noise: the seating repeatability, m per coordinate (None: estimated from
        the residuals).
      distance_noise: std of a known distance, m.
      drop_outliers: drop the outlying rows and refit instead of refusing.
      rtol: identifiability threshold; xtol, ftol, gtol, max_nfev: least
        squares options; loss, f_scale: as scipy's (``linear`` only here).

    The attributes are set by ``fit``.

    Attributes:
      names_, deltas_, std_: the error parameters, values and std (rad or m).
      socket_ids_, sockets_, sockets_std_: (S,), (S, 3) socket points in B and
        their std, m.
      metrics_, metrics_nominal_: :class:`~rmdrake.calibration.sockets.
        problem.SocketMetrics` of the calibrated and the nominal model on the
        data kept.
      dropped_: 0-based rows dropped as outliers (``drop_outliers``).
      residual_rms_: RMS 3-D distance of the rows from their socket points, m.
      not_fitted_: {name: reason} of the ``full`` parameters the data do not
        fit (for a preset or ``auto``; a list of names: none).
      model_, identifiability_, selection_ (``auto``), sanity_, fit_time_,
      result_ (scipy's least-squares result).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import SocketLM, simulate_sockets
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_sockets(robot, placements=3, per_socket=6, seed=0).data
    >>> lm = SocketLM(robot, params="offsets").fit(data)
    >>> lm.method, len(lm.names_) > 0
    ('lm', True)
    """

    method = "lm"
    loss = "linear"
    f_scale = 1.0

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "auto",
        noise: float | None = None,
        distance_noise: float = DEFAULT_DISTANCE_NOISE,
        drop_outliers: bool = False,
        rtol: float = 1e-6,
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
        max_nfev: int | None = None,
        progress: bool = False,
    ) -> None:
        self.model = model
        self.params = params
        self.noise = noise
        self.distance_noise = distance_noise
        self.drop_outliers = drop_outliers
        self.rtol = rtol
        self.xtol = xtol
        self.ftol = ftol
        self.gtol = gtol
        self.max_nfev = max_nfev
        self.progress = progress

    @property
    def distance_weight(self) -> float:
        """w of the distance residuals: the seating noise (declared, else 0.1
        mm) / ``distance_noise``, so both kinds of residual are in units of
        the seating noise."""
        seat = self.noise if self.noise else 1e-4
        return seat / self.distance_noise

    def _check(self, data: SocketMeasurements) -> None:
        n = self.model.n_joints
        if data.n_joints != n:
            raise ValueError(
                f"{data.n_joints} joint columns, but the robot has {n} joints"
            )
        if self.distance_noise <= 0 or not np.isfinite(self.distance_noise):
            raise ValueError("distance_noise: expected a positive std in m")
        S = data.socket_ids.size
        k = len(error_parameter_names(self.model, "full"))
        size = 8 * (3 * data.n_rows + data.distances.shape[0]) * (k + 3 * S)
        if size > MAX_JACOBIAN_BYTES:
            raise ValueError(
                f"{data.n_rows} configurations in {S} sockets make a Jacobian of "
                f"{size / 2**20:.4g} MiB, over the {MAX_JACOBIAN_BYTES // 2**20} MiB "
                "bound: calibrate from fewer sockets or configurations"
            )
        counts = np.bincount(data.socket_index, minlength=S)
        few = np.flatnonzero(counts < 2)
        if few.size:
            raise ValueError(
                f"socket {int(data.socket_ids[few[0]])} has {int(counts[few[0]])} "
                "row(s): a socket needs at least 2 seated configurations (its "
                "point is 3 unknowns)"
            )
        per_place = np.bincount(data.placement, minlength=data.n_placements)
        sockets = np.bincount(data.placement_of_socket, minlength=data.n_placements)
        short = np.flatnonzero(per_place < 3 * sockets)
        if short.size:
            p = int(short[0])
            ids = data.socket_ids[data.placement_of_socket == p]
            raise ValueError(
                f"the placement of sockets {', '.join(map(str, ids.tolist()))} has "
                f"{int(per_place[p])} configurations for the {3 * int(sockets[p])} "
                "unknowns of its socket points: record more"
            )

    def _check_distances(self, data: SocketMeasurements) -> None:
        """Refuses known distances the robot contradicts before any fit: one
        beyond twice its reach (no ball is seated at both sockets: mm?), or
        one that differs from the distance between the two sockets' mean
        balls by the nominal model by more than a calibration may correct
        (:class:`~rmdrake.calibration.sanity.CalibrationBounds`' length bound:
        a distance of another pair, or sockets mixed up between placements).

        Raises:
          ValueError: one line naming the sockets, the distances (m) and the
            bound.
        """
        if data.distances.shape[0] == 0:
            return
        model = self.model
        reach = robot_reach(model)
        far = data.distances[:, 2] > 2 * reach
        if far.any():
            a, b, d = data.distances[np.argmax(far)]
            raise ValueError(
                f"known distance {d:g} m between sockets {int(a)} and {int(b)} is "
                f"over twice the reach of robot '{model.name}' ({2 * reach:.3g} m): "
                "no ball is seated in both; mm? convert the distances to m"
            )
        balls = tool_points(model.table, data.q, sigma=model.sigma)
        index, S = data.socket_index, data.socket_ids.size
        means = np.zeros((S, 3))
        np.add.at(means, index, balls)
        means /= np.bincount(index, minlength=S)[:, None]
        a, b = data.distance_index.T
        nominal = np.linalg.norm(means[a] - means[b], axis=1)
        bounds = CalibrationBounds()
        limit = bounds.length + bounds.length_fraction * reach
        off = np.abs(nominal - data.distances[:, 2])
        if np.any(off > limit):
            k = int(np.argmax(off))
            sa, sb, d = data.distances[k]
            raise ValueError(
                f"known distance {d * 1e3:.4g} mm between sockets {int(sa)} and "
                f"{int(sb)}, but robot '{model.name}' puts their mean balls "
                f"{nominal[k] * 1e3:.4g} mm apart, more than the "
                f"{limit * 1e3:.3g} mm a calibration may correct: a distance of "
                "other sockets, socket ids mixed up between placements, or a "
                "distance not in m"
            )

    def _names(self, data: SocketMeasurements) -> list[str]:
        model = self.model
        unseen = None
        if isinstance(self.params, str) and self.params == "auto":
            self.selection_ = select_socket_parameters(
                self._with, data, progress=self.progress
            )
            names = list(self.selection_.chosen)
            unseen = analyse_socket_identifiability(
                model,
                data,
                error_parameter_names(model, "full"),
                rtol=WEAK_RTOL,
                weight=self.distance_weight,
            ).dropped
        else:
            names = _candidates(model, self.params)
        preset = isinstance(self.params, str) and self.params in SOCKET_PRESETS
        rtol = max(self.rtol, WEAK_RTOL) if preset else self.rtol
        report = analyse_socket_identifiability(
            model, data, names, rtol=rtol, weight=self.distance_weight
        )
        if not preset and report.dropped:
            name, why = next(iter(report.dropped.items()))
            raise ValueError(
                f"parameter {name} cannot be identified from sockets: {why}"
            )
        self.identifiability_ = report
        self.not_fitted_ = dict(report.dropped if unseen is None else unseen)
        names = report.identifiable
        unknowns = len(names) + 3 * data.socket_ids.size
        equations = 3 * data.n_rows + data.distances.shape[0]
        if equations < unknowns + 5:
            raise ValueError(
                f"{data.n_rows} configurations in {data.socket_ids.size} sockets "
                f"cannot identify {len(names)} parameters and the socket points "
                f"({unknowns} unknowns and 5 dof to check them): record more or "
                "name fewer parameters"
            )
        return names

    def _with(self, names: Sequence[str]) -> SocketLM:
        """This estimator's options with an explicit parameter list (a
        candidate of ``auto``: fitted without std, outlier check or record)."""
        est = SocketLM(
            self.model,
            params=list(names),
            noise=self.noise,
            distance_noise=self.distance_noise,
            rtol=self.rtol,
            xtol=self.xtol,
            ftol=self.ftol,
            gtol=self.gtol,
            max_nfev=self.max_nfev,
        )
        est._candidate = True
        return est

    def _problem(self, data: SocketMeasurements, names: list[str]) -> SocketProblem:
        """The residual problem of ``names`` on ``data`` at the nominal."""
        model = self.model
        idx = error_parameter_indices(model, names)
        return SocketProblem(
            model.table, data, idx, sigma=model.sigma, weight=self.distance_weight
        )

    def _solve(self, data: SocketMeasurements, names: list[str]) -> tuple:
        problem = self._problem(data, names)
        return problem, solve_lm(problem, problem.start(), self)

    def fit(self, data: SocketMeasurements) -> SocketLM:
        """Calibrates from the socket measurements; returns self."""
        t0 = time.perf_counter()
        self._check(data)
        self._check_distances(data)
        names = self._names(data)
        self.dropped_ = np.zeros(0, dtype=np.intp)
        candidate = getattr(self, "_candidate", False)
        kept = np.arange(data.n_rows)
        self._gross_rows = np.zeros(0, dtype=np.intp)
        self._too_many = 0  # rows drop_outliers would have dropped, over the share
        most = MAX_DROPPED_SHARE * data.n_rows
        if not candidate:  # gross errors seen by a robust fit, not dragged by them
            gross = self._robust_gross(data, names)
            if gross.size > most and self.drop_outliers:
                self._too_many = gross.size
            elif gross.size and self.drop_outliers:
                self.dropped_ = gross
                kept = np.delete(kept, gross)
                self._check(data.subset(kept))
            self._gross_rows = gross
        problem, result = self._solve(data.subset(kept), names)
        for _ in range(5 if self.drop_outliers and not candidate else 0):
            d, noise, _ = self._rows(problem, result.x)
            bad = self._outliers(d, noise)
            if not bad.size:
                break
            # Gross rows first: one 5 mm off drags its socket's point and can
            # push that socket's good rows past the milder threshold.
            gross = bad[d[bad] > GROSS_Z * noise]
            bad = gross if gross.size else bad
            if self.dropped_.size + bad.size > most:
                self._too_many = self.dropped_.size + bad.size
                break
            self.dropped_ = np.sort(np.concatenate([self.dropped_, kept[bad]]))
            kept = np.delete(kept, bad)
            self._check(data.subset(kept))
            problem, result = self._solve(data.subset(kept), names)
        deltas, sockets = problem.unpack(result.x)
        self.result_ = result
        self.names_, self.deltas_ = names, deltas.copy()
        self.model_ = apply_deltas(self.model, names, self.deltas_)
        if candidate:
            return self
        used = data.subset(kept)
        self.data_ = used
        self.socket_ids_, self.sockets_ = used.socket_ids, sockets.copy()
        r = problem.residuals(result.x)
        e = row_distances(problem, result.x)[0]
        self.residual_rms_ = float(np.sqrt(np.mean(e**2)))
        std = least_squares_std(problem.jacobian(result.x), r)
        if self.noise:  # the declared noise, not the residuals'
            dof = r.size - result.x.size
            std = std * self.noise / max(float(np.sqrt(r @ r / dof)), 1e-300)
        k = len(names)
        self.std_, self.sockets_std_ = std[:k], std[k:].reshape(-1, 3)
        m = self.model
        self.metrics_ = socket_metrics(self.model_.table, used, sigma=m.sigma)
        self.metrics_nominal_ = socket_metrics(m.table, used, sigma=m.sigma)
        self._fitted, self._x = problem, result.x
        self.sanity_ = self.check()
        self.fit_time_ = time.perf_counter() - t0
        self.model_ = dataclasses.replace(self.model_, calibration=self.record())
        return self

    def _robust_gross(self, data: SocketMeasurements, names: list[str]) -> np.ndarray:
        """0-based rows over :data:`GROSS_Z` robust noise sigmas from their
        socket point under a robust fit: scipy's ``trf`` with the Cauchy loss
        from the nominal with each socket point at its rows' median, the loss
        scale the nominal rows' median distance from those medians. A row from
        another socket, tens of mm off, drags a least-squares fit into
        absurd parameters that then explain it; the robust fit lets it stand
        out."""
        import scipy.optimize

        problem = self._problem(data, names)
        p = problem.predicted(problem.start())
        S, index = problem.n_sockets, problem.socket
        medians = np.array([np.median(p[index == s], axis=0) for s in range(S)])
        scale = float(np.median(np.linalg.norm(p - medians[index], axis=1)))
        x0 = problem.pack(np.zeros(problem.k), medians)
        result = scipy.optimize.least_squares(
            problem.residuals,
            x0,
            jac=problem.jacobian,
            method="trf",
            loss="cauchy",
            f_scale=max(scale, NOISE_FLOOR),
            x_scale="jac",
        )
        d, noise = row_distances(problem, result.x)
        if self.noise:
            noise = max(noise, self.noise)
        return np.flatnonzero(d > GROSS_Z * noise)

    def _rows(
        self, problem: SocketProblem, x: np.ndarray
    ) -> tuple[np.ndarray, float, str]:
        """(N,) each row's 3-D distance from its socket point (m), the noise
        per coordinate (m: declared, else :func:`row_distances`' robust
        scale) and its source, from one evaluation of the residuals."""
        d, robust = row_distances(problem, x)
        if self.noise:
            return d, float(self.noise), "declared"
        return d, robust, "robust scale of the residuals"

    @staticmethod
    def _outliers(d: np.ndarray, noise: float) -> np.ndarray:
        """0-based rows whose distance ``d`` (m) from their socket point
        exceeds the chi (3 dof) quantile of ``noise`` at a family-wise
        :data:`OUTLIER_ALPHA`."""
        import scipy.special

        # scipy.stats.chi(3).isf(a) as scipy computes it (the same bits),
        # without importing scipy.stats (1 s).
        limit = noise * np.sqrt(
            2.0 * scipy.special.gammainccinv(1.5, OUTLIER_ALPHA / d.size)
        )
        return np.flatnonzero(d > limit)

    def check(self) -> SanityReport:
        """The sanity checks of the fit: outlying rows (named by socket and
        row), corrections beyond physical bounds, ``drop_outliers`` over
        :data:`MAX_DROPPED_SHARE` of the rows, an estimated noise over
        :data:`~rmdrake.calibration.sanity.SOCKET_MAX_NOISE` and, with a
        declared noise, a residual above twice it."""
        problem, x, data = self._fitted, self._x, self.data_
        r = problem.residuals(x)
        e, noise, source = self._rows(problem, x)
        dof = int(r.size - x.size)
        rms = float(np.sqrt(r @ r / max(dof, 1)))
        bad = self._outliers(e, noise)
        gross = bad[e[bad] > GROSS_Z * noise]
        if self.dropped_.size == 0:  # data_ is the data: the robust fit's rows
            gross = np.union1d(gross, self._gross_rows)
            bad = np.union1d(bad, gross)
        mild = np.setdiff1d(bad, gross)

        def rows(idx: np.ndarray) -> str:
            shown = ", ".join(
                f"row {i + 1} (socket {int(data.socket[i])}, {e[i] * 1e3:.3g} mm)"
                for i in idx[:6]
            )
            return shown + (f" and {idx.size - 6} more" if idx.size > 6 else "")

        reasons, warns = [], []
        if gross.size:
            reasons.append(
                f"{gross.size} configuration(s) over {GROSS_Z:g} noise sigmas from "
                f"their socket (a row from another socket, or a ball not seated): "
                f"{rows(gross)}; --drop-outliers drops them"
            )
        if mild.size:
            warns.append(
                f"{mild.size} configuration(s) beyond the noise's 0.1 % quantile "
                f"from their socket: {rows(mild)} (kept; --drop-outliers drops them)"
            )
        bounds = CalibrationBounds()
        reach = robot_reach(self.model)
        wild = out_of_bounds_reason(
            self.names_,
            self.deltas_,
            bounds.length + bounds.length_fraction * reach,
            bounds.angle,
        )
        if wild:
            reasons.append(wild)
        if self._too_many:
            n = self._too_many
            rows_in = self.dropped_.size + data.n_rows
            reasons.append(
                f"--drop-outliers would drop {n} of {rows_in} configurations "
                f"({100 * n / rows_in:.3g} %, over {100 * MAX_DROPPED_SHARE:g} %): "
                "so many rows far from their socket are data that contradict "
                "each other (sockets mixed up?), not a few bad seatings"
            )
        if not self.noise and noise > SOCKET_MAX_NOISE:
            reasons.append(
                f"the seating noise estimated from the residuals, {noise * 1e3:.3g} "
                f"mm per coordinate, is over the {SOCKET_MAX_NOISE * 1e3:g} mm a "
                "ball seated in a socket scatters: not noise, but a model that "
                "misses errors (too few parameters) or data that contradict each "
                "other (sockets mixed up, a wrong known distance?)"
            )
        if self.noise and rms > 2 * self.noise:
            reasons.append(
                f"residual {rms * 1e3:.3g} mm per coordinate is over twice the "
                f"declared seating noise {self.noise * 1e3:.3g} mm: the model "
                "misses errors or the noise is understated"
            )
        return SanityReport(
            reasons=tuple(reasons),
            noise=noise,
            noise_source=source,
            residual_rms=rms,
            dof=dof,
            z=e / max(noise, 1e-300),
            outliers=bad,
            reference="calibrated",
            warnings=tuple(warns),
        )

    def record(self) -> dict[str, Any]:
        """The ``calibration`` record (m, rad; no wall time)."""
        report, data = self.identifiability_, self.data_
        after, before = self.metrics_, self.metrics_nominal_
        out: dict[str, Any] = {
            "kind": "socket kinematic calibration (a ball seated in fixed sockets)",
            "method": self.method,
            "parameters": {
                n: {"delta": float(d), "std": float(s)}
                for n, d, s in zip(self.names_, self.deltas_, self.std_, strict=True)
            },
            "units": "deltas and std in rad (dalpha, dtheta, dbeta) or m (dd, dr); "
            "socket points in m in the base frame; metrics in m",
            "sockets": {
                int(i): [float(v) for v in s]
                for i, s in zip(self.socket_ids_, self.sockets_, strict=True)
            },
            "metrics": {
                "consistency_mean": after.mean_abs,
                "consistency_rms": after.rms,
                "consistency_mean_nominal": before.mean_abs,
                "distortion": after.distortion.tolist(),
                "distortion_nominal": before.distortion.tolist(),
            },
            "residual_rms": self.residual_rms_,
            "rank": report.rank,
            "condition_number": report.condition_number,
            "dropped": dict(self.not_fitted_),
            "data": {
                "configurations": data.n_rows,
                "sockets": int(data.socket_ids.size),
                "placements": data.n_placements,
                "distances": data.distances.tolist(),
            },
            "base_model": self.model.name,
            "options": {
                "params": self.params
                if isinstance(self.params, str)
                else ",".join(self.params),
                "distance_noise": self.distance_noise,
            },
        }
        if self.noise:
            out["options"]["noise"] = self.noise
        if self.dropped_.size:
            out["dropped_rows"] = [int(i) for i in self.dropped_]
        if hasattr(self, "selection_"):
            out["selection"] = self.selection_.record()
        return out

    def summary(self) -> str:
        """Human-readable result (after fit)."""
        report, a, b = self.identifiability_, self.metrics_, self.metrics_nominal_
        lines = []
        if hasattr(self, "selection_"):
            lines += self.selection_.summary_lines()
        lines += [
            f"method lm on sockets: {len(self.names_)} parameters, rank "
            f"{report.rank}, condition number {report.condition_number:.3g}, "
            f"{self.fit_time_:.3f} s",
            f"training consistency (mean |p - socket mean|): {b.mean_abs * 1e3:.4g} "
            f"mm (nominal) -> {a.mean_abs * 1e3:.4g} mm (RMS {a.rms * 1e3:.4g} mm); "
            f"distortion max |.| {b.max_abs_distortion * 1e3:.4g} -> "
            f"{a.max_abs_distortion * 1e3:.4g} mm",
        ]
        if self.dropped_.size:
            lines.append(
                f"dropped {self.dropped_.size} outlying configuration(s): rows "
                f"{', '.join(str(i + 1) for i in self.dropped_[:10])}"
            )
        if self.data_.distances.shape[0] == 0:
            lines.append(
                "no known distance between sockets: the length scale is not fixed "
                "by the data (one length fewer is fitted; give --socket-distance "
                "or a distance file)"
            )
        for name, why in self.not_fitted_.items():
            lines.append(f"  {name}: not fitted, {why}")
        lines += delta_lines(self.names_, self.deltas_, self.std_)
        return "\n".join(lines)


def make_socket_calibrator(config: CalibrationConfig, model: RobotModel) -> SocketLM:
    """The :class:`SocketLM` of a config: its ``params`` (None = ``auto``),
    ``rtol`` and ``noise`` (the seating repeatability, m), and its
    :class:`~rmdrake.calibration.config.SocketLMConfig` (None = the
    defaults): ``distance_noise``, ``drop_outliers``, ``max_nfev``.

    Raises:
      ValueError: another method's config, options sockets do not have
        (``compliance``, a robust ``loss``), a ``noise`` not in (0,
        :data:`~rmdrake.calibration.sanity.SOCKET_MAX_NOISE`] or a
        ``distance_noise`` not in (0, :data:`~rmdrake.calibration.config.
        MAX_DISTANCE_NOISE`] (m), one line naming it.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import CalibrationConfig, SocketLMConfig
    >>> from rmdrake.calibration import make_socket_calibrator
    >>> config = CalibrationConfig(params="offsets", calibrator=SocketLMConfig())
    >>> type(make_socket_calibrator(config, load_robot("rv3sb"))).__name__
    'SocketLM'
    """
    method = config.calibrator
    if method is None:
        method = SocketLMConfig()
    if not isinstance(method, SocketLMConfig):
        raise ValueError(
            f"{type(method).__name__} (method '{method.method}') does not calibrate "
            "socket measurements; they are calibrated by SocketLMConfig"
        )
    if config.compliance:
        raise ValueError("compliance: not available for socket measurements")
    if config.loss != "linear":
        raise ValueError(
            f"loss '{config.loss}': socket measurements are fitted by linear least "
            "squares (--drop-outliers drops outlying configurations)"
        )
    noise = config.noise
    if noise is not None and not 0 < noise <= SOCKET_MAX_NOISE:
        raise ValueError(
            f"noise {noise:g} m: a ball seated in a socket scatters by more than 0 "
            f"and at most {SOCKET_MAX_NOISE * 1e3:g} mm per coordinate: mm? "
            "convert to m, or leave the noise out to estimate it"
        )
    if not 0 < method.distance_noise <= MAX_DISTANCE_NOISE:
        raise ValueError(
            f"distance noise {method.distance_noise:g} m: expected more than 0 and "
            f"at most {MAX_DISTANCE_NOISE * 1e3:g} mm: mm? convert to m"
        )
    return SocketLM(
        model,
        params="auto" if config.params is None else config.params,
        noise=config.noise,
        distance_noise=method.distance_noise,
        drop_outliers=method.drop_outliers,
        rtol=config.rtol,
        max_nfev=method.max_nfev,
    )
