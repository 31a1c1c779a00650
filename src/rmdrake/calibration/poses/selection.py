"""Cross-validation of pose calibrations over the readings, and the parameter
set chosen from the data.

Splits (:func:`reading_splits`): the row indices are shuffled by
``numpy.random.default_rng(seed).permutation`` and dealt into K folds (fold f
holds the shuffled rows f, f + K, ...), or the first ``round(fraction N)`` of
them are the one hold-out set: deterministic for a seed. Each row is one robot
pose, so a fold holds whole poses. :func:`cross_validate` fits on the other
rows only and pools the held-out errors: position |p_pred - p_meas| (m) and
angle |Log(R_meas^T R_pred)| (rad) of every held-out reading, and their
normalised combination sqrt((|e_p|^2 / sigma_p^2 + |e_r|^2 / sigma_r^2) / 6)
(1 at the noise level), the criterion of the automatic choice.

The automatic choice (:func:`select_parameters`) is the points' one
(:mod:`rmdrake.calibration.points.selection`: candidates ``base``, ``offsets``,
forward stepwise additions from the identifiable ``full`` set while one lowers
the CV criterion by >= 1 %, then the one-standard-error rule,
:func:`rmdrake.calibration.selection.stepwise_selection`) on the normalised
criterion, with the noises fixed for every candidate.

Example::

    from rmdrake.calibration.poses.lm import PoseLM
    from rmdrake.calibration.poses.selection import cross_validate
    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    data = simulate_poses(model, poses=30, seed=1).data
    cv = cross_validate(lambda: PoseLM(model, params="offsets",
                        noise_p=2e-5, noise_r=5e-5), data, folds=3)
    print(cv.rms_p, cv.rms_r)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from rmdrake.calibration.parameters import joint_offset_names
from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.identifiability import analyse_pose_identifiability
from rmdrake.calibration.selection import (
    StepwiseSelection,
    held_out_ids,
    stepwise_selection,
)
from rmdrake.model.error_parameters import error_parameter_names
from rmdrake.progress import progress_iter

__all__ = [
    "PoseCrossValidation",
    "PoseSelection",
    "cross_validate",
    "reading_splits",
    "select_parameters",
]


class _Estimator(Protocol):
    model: Any

    def fit(self, data: PoseMeasurements) -> Any: ...

    def pose_errors(self, data: PoseMeasurements) -> tuple[np.ndarray, np.ndarray]: ...


def reading_splits(
    data: PoseMeasurements,
    *,
    folds: int | None = None,
    holdout: float | None = None,
    seed: int = 0,
) -> list[np.ndarray]:
    """The held-out row indices of each split (see the module docstring).

    Raises:
      ValueError: both or neither given, K < 2 or above the row count, a
        fraction outside (0, 1) or leaving no row on either side.
    """
    return held_out_ids(
        np.arange(data.n_rows), folds=folds, holdout=holdout, seed=seed, what="reading"
    )


@dataclasses.dataclass(frozen=True)
class PoseCrossValidation:
    """Pooled held-out pose errors.

    Attributes:
      errors_p: (N,) position errors of every held-out reading, m.
      errors_r: (N,) angle errors, rad.
      normalised: (N,) sqrt((e_p^2 / sigma_p^2 + e_r^2 / sigma_r^2) / 6).
      fold_rms: (S,) RMS of ``normalised`` per split.
      scheme: ``5-fold`` or ``hold-out 0.2``; seed: the split's seed.
    """

    errors_p: np.ndarray
    errors_r: np.ndarray
    normalised: np.ndarray
    fold_rms: np.ndarray
    scheme: str
    seed: int

    @property
    def rms_p(self) -> float:
        """sqrt(mean |e_p|^2), m."""
        return float(np.sqrt(np.mean(self.errors_p**2)))

    @property
    def rms_r(self) -> float:
        """sqrt(mean |e_r|^2), rad."""
        return float(np.sqrt(np.mean(self.errors_r**2)))

    @property
    def rms(self) -> float:
        """RMS of the normalised errors (1 at the noise level)."""
        return float(np.sqrt(np.mean(self.normalised**2)))

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (m, rad)."""
        return {
            "scheme": self.scheme,
            "seed": self.seed,
            "readings": int(self.errors_p.size),
            "rms_position": self.rms_p,
            "max_position": float(self.errors_p.max()),
            "rms_angle": self.rms_r,
            "max_angle": float(self.errors_r.max()),
            "rms_normalised": self.rms,
        }


def cross_validate(
    make: Callable[[], _Estimator],
    data: PoseMeasurements,
    *,
    folds: int | None = None,
    holdout: float | None = None,
    seed: int = 0,
    scales: tuple[float, float] | None = None,
    progress: bool = False,
) -> PoseCrossValidation:
    """Fits ``make()`` on the rows outside each split and measures the
    held-out ones (see the module docstring). ``scales`` (sigma_p in m,
    sigma_r in rad) normalise the errors; None: those each fit used."""
    ep, er, en, fold_rms = [], [], [], []
    splits = reading_splits(data, folds=folds, holdout=holdout, seed=seed)
    for test in progress_iter(
        splits, desc="cross-validation splits", lazy=not progress
    ):  # not shown (progress False) unless the process is silent an interval
        train = np.ones(data.n_rows, bool)
        train[test] = False
        est = make().fit(data.subset(train))
        e_p, e_r = est.pose_errors(data.subset(test))
        sp, sr = scales or (est.sigma_p_, est.sigma_r_)
        norm = np.sqrt((e_p**2 / sp**2 + e_r**2 / sr**2) / 6)
        ep.append(e_p)
        er.append(e_r)
        en.append(norm)
        fold_rms.append(float(np.sqrt(np.mean(norm**2))))
    scheme = f"{folds}-fold" if folds is not None else f"hold-out {holdout:g}"
    return PoseCrossValidation(
        np.concatenate(ep),
        np.concatenate(er),
        np.concatenate(en),
        np.array(fold_rms),
        scheme,
        seed,
    )


@dataclasses.dataclass(frozen=True)
class PoseSelection(StepwiseSelection):
    """The outcome of :func:`select_parameters`; CV figures are normalised
    (1 at the noise level), not m."""

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (normalised CV errors)."""
        return {
            "rule": "one-standard-error rule on the K-fold CV RMS of the "
            "normalised pose error sqrt((|e_p|^2/sigma_p^2 + |e_r|^2/sigma_r^2)/6): "
            "candidates base, offsets, then forward stepwise additions from the "
            "identifiable full set while one lowers it by >= 1 %",
            "folds": self.folds,
            "seed": self.seed,
            "repeats": self.repeats,
            "chosen": self.label,
            "selection_cv_rms": self.cv_rms,
            "threshold": self.threshold,
            "candidates": self.candidate_records(),
        }

    def summary_lines(self) -> list[str]:
        """The candidates and the choice (normalised errors)."""
        return [
            f"automatic parameter choice ({self.folds}-fold CV over readings, "
            f"one-SE rule: the smallest set with normalised CV RMS <= "
            f"{self.threshold:.4g}):",
            *self.candidate_lines("x noise", 1.0),
        ]


def select_parameters(
    make_with: Callable[[Sequence[str]], _Estimator],
    data: PoseMeasurements,
    scales: tuple[float, float],
    *,
    folds: int = 5,
    seed: int = 0,
    min_gain: float = 0.01,
    max_steps: int | None = None,
    repeats: int = 1,
    progress: bool = False,
) -> PoseSelection:
    """The parameter set chosen by cross-validation and the one-SE rule (the
    module docstring); ``scales`` = (sigma_p m, sigma_r rad) normalise every
    candidate's errors alike; ``max_steps``: most stepwise additions (None:
    no limit but the gain rule)."""
    model = make_with([]).model
    folds = min(folds, data.n_rows)

    def score(names: list[str]) -> tuple[float, float, float]:
        try:
            cvs = [
                cross_validate(
                    lambda: make_with(names), data, folds=folds, seed=s, scales=scales
                )
                for s in range(seed, seed + repeats)
            ]
        except ValueError:  # not identifiable or too few readings in a fold
            return np.inf, np.inf, np.inf
        e = np.concatenate([cv.normalised for cv in cvs])
        fold_rms = np.concatenate([cv.fold_rms for cv in cvs])
        se = float(np.std(fold_rms, ddof=1) / np.sqrt(folds))
        return float(np.sqrt(np.mean(e**2))), float(e.max()), se

    sp, sr = scales
    full = analyse_pose_identifiability(
        model, data, error_parameter_names(model, "full"), sigma_p=sp, sigma_r=sr
    ).identifiable
    offsets = analyse_pose_identifiability(
        model, data, joint_offset_names(model), sigma_p=sp, sigma_r=sr
    ).identifiable
    result = stepwise_selection(
        score,
        offsets,
        full,
        start_label="offsets",
        before=[("base", [])],
        min_gain=min_gain,
        max_steps=len(full) if max_steps is None else max_steps,
        unit=("x noise", 1.0),
        progress=progress,
    )
    return PoseSelection(*result, folds, seed, repeats)
