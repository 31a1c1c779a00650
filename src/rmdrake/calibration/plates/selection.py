"""Cross-validation of plate calibrations over the plates, and the parameter
set chosen from the data (``params="auto"`` of
:class:`~rmdrake.calibration.plates.estimators.PlaneLM` and ``de+lm``).

Splits (:func:`plate_splits`) hold out whole plates: the readings of one plate
share its unknown pose, so a plate is fitted or tested, never both. The plate
ids are shuffled by ``numpy.random.default_rng(seed).permutation`` and dealt
into K folds (fold f holds the shuffled ids f, f + K, ...): deterministic for a
seed. K is at most the plate count and leaves at least 2 training plates.

Score of a held-out plate (:func:`plate_distances`): the kinematics fitted on
the training plates only (their readings alone enter the fit) give the
held-out readings' measured points p_BM = p_BE(q) + distance z_BE(q)
(:func:`rmdrake.kinematics.forward.tool_points`, the joints bent under each
reading's payload when the robot is elastic); the plate's own least-squares
plane is fitted to them (SVD of the centred points, 3 unknowns) and d_i is the
signed distance of each point to it (m). :func:`plate_cross_validate` pools
them over the held-out plates p: CV RMS = sqrt(sum d_i^2 / sum_p (m_p - 3)),
m_p the plate's readings (its degrees of freedom in the denominator, so a
correct model scores the reading noise); the RMS of each fold alike; the max
is max |d_i|.

The automatic choice (:func:`select_plate_parameters`) is the rule of
:func:`rmdrake.calibration.selection.stepwise_selection`, shared with the
points:

1. start: the paper's 17 parameters (Wang et al. 2016, Table 1) that the
   readings identify, labelled ``paper`` (a robot that is not a 6-joint arm,
   which has no paper set: its identifiable joint offsets, ``offsets``);
2. forward stepwise: add the one parameter of the identifiable ``full`` set
   that lowers the K-fold CV RMS most; stop when no addition lowers it by at
   least ``min_gain`` (1 %), or after ``max_steps`` (12); then the whole
   identifiable ``full`` set is a candidate too (labelled ``full``), unless
   the path reached it;
3. one-SE rule: SE = std(per-fold RMS, ddof 1) / sqrt(K) of the best (smallest
   CV RMS) candidate; the chosen set is the candidate with the fewest
   parameters whose CV RMS is at most the best's + SE;

a CV RMS below ``floor`` (1 nm, far below any range finder) counts as 1 nm:
on noise-free readings the start set is kept instead of additions that only
move round-off.

Why start at the paper's set rather than at the joint offsets, as the points
do: it was the plates' fixed default and is the model the paper validated on
this class of arm, so on readings it explains the choice is that set (no
addition beats its SE) and the paper's results stand; the offsets (4
identifiable on the RV-3SB) would need 13 accepted additions to reach it, more
than ``max_steps``, at about 18 candidates a step. Starting from the paper's
set the pool is small (5 parameters on the RV-3SB: dtheta2..5 and dbeta7), so
the whole choice costs at most 17 candidate sets x K LM fits (each converging
in at most 11 evaluations).

Why the whole ``full`` set is a candidate after the stepwise path: errors
outside the paper's set can be visible only together. On 60 readings of an
RV-3SB with 1 mrad / 0.5 mm errors on every parameter (``rmdrake perturb
--params full``) each single addition to the paper's set left a CV RMS of 41
to 90 um, and the path stopped at 19 parameters (41 um), while the 22 of
``full`` score 6 um (the noise is 2 um) and the one-SE rule takes them.

A candidate is not fitted (its CV RMS infinite, so never chosen) when it is
not identifiable on a training set or its LM on one stops at its budget of
evaluations (:data:`~rmdrake.calibration.plates.estimators.CANDIDATE_MAX_NFEV`).

The selection CV RMS is optimistic for the chosen set (it chose it): it is
reported as the *selection* CV.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from rmdrake.calibration.parameters import joint_offset_names
from rmdrake.calibration.plates.cost import fit_plane
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.identifiability import analyse_identifiability
from rmdrake.calibration.selection import StepwiseSelection, stepwise_selection
from rmdrake.dynamics.compliance import link_angles
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import error_parameter_names
from rmdrake.model.robot import RobotModel
from rmdrake.progress import progress_bar, progress_iter

__all__ = [
    "MIN_TRAINING_PLATES",
    "PLATE_CV_FLOOR",
    "PlateCrossValidation",
    "PlateSelection",
    "plate_cross_validate",
    "plate_distances",
    "plate_splits",
    "select_plate_parameters",
    "selection_start",
]

MIN_TRAINING_PLATES = 2
"""Fewest plates a split leaves to fit on."""

PLATE_CV_FLOOR = 1e-9
"""m: a CV RMS below it counts as it in the choice (round-off, see the module
docstring)."""


class _Estimator(Protocol):
    model: Any
    model_: RobotModel

    def fit(self, data: PlaneMeasurements) -> Any: ...


def plate_splits(
    data: PlaneMeasurements, *, folds: int, seed: int = 0
) -> list[np.ndarray]:
    """The held-out plate ids of each of K = ``folds`` folds (see the module
    docstring), each sorted.

    Raises:
      ValueError: K < 2, K above the plate count, or a fold leaving fewer than
        :data:`MIN_TRAINING_PLATES` plates to fit on.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import plate_splits, simulate_plates
    >>> data = simulate_plates(load_robot("rv3sb"), plates=4, per_plate=6, seed=0).data
    >>> [len(test) for test in plate_splits(data, folds=4)]
    [1, 1, 1, 1]
    """
    ids = np.random.default_rng(seed).permutation(data.plate_ids)
    P = ids.size
    if not 2 <= folds <= P:
        raise ValueError(f"folds: expected 2..{P} (the plate count), found {folds}")
    splits = [np.sort(ids[f::folds]) for f in range(folds)]
    if P - max(s.size for s in splits) < MIN_TRAINING_PLATES:
        raise ValueError(
            f"folds: {folds} folds of {P} plates leave fewer than "
            f"{MIN_TRAINING_PLATES} plates to fit on"
        )
    return splits


def plate_distances(
    model: RobotModel, data: PlaneMeasurements
) -> tuple[np.ndarray, np.ndarray]:
    """The readings' scatter about their own plates by ``model``.

    Each reading's measured point by ``model`` (its joints bent under the
    reading's payload when it is elastic), each plate's least-squares plane
    through its points (SVD, 3 unknowns), and the signed distances to it.

    Returns:
      (N,) signed point-to-plane distances, m, in the readings' order; (P,)
      degrees of freedom m_p - 3 of each plate (ascending plate id).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import plate_distances, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=3, per_plate=6, noise=0.0, seed=0).data
    >>> distances, dof = plate_distances(robot, data)
    >>> distances.shape, bool(abs(distances).max() < 1e-9)
    ((18,), True)
    """
    q = link_angles(model, data.q, data.payload_masses)
    pts = tool_points(model.table, q, data.distance, sigma=model.sigma)
    pi = data.plate_index
    d = np.empty(data.n_readings)
    dof = np.empty(data.plate_ids.size)
    for p in range(data.plate_ids.size):
        rows = pi == p
        normal, offset = fit_plane(pts[rows])
        d[rows] = pts[rows] @ normal - offset
        dof[p] = rows.sum() - 3
    return d, dof


@dataclasses.dataclass(frozen=True)
class PlateCrossValidation:
    """Pooled held-out point-to-plane distances (see the module docstring).

    Attributes:
      distances: (N,) signed distance of every held-out reading to its plate's
        own plane, m, split by split.
      dof: (H,) degrees of freedom (readings - 3) of each held-out plate.
      fold_rms: (S,) RMS per split, sqrt(sum d^2 / sum dof) over its plates, m.
      scheme: ``5-fold over plates``; seed: the split's seed.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, plate_cross_validate, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=5, per_plate=10, seed=0).data
    >>> cv = plate_cross_validate(lambda: PlaneLM(robot), data, folds=5)
    >>> cv.scheme, cv.fold_rms.shape
    ('5-fold over plates', (5,))
    """

    distances: np.ndarray
    dof: np.ndarray
    fold_rms: np.ndarray
    scheme: str
    seed: int

    @property
    def rms(self) -> float:
        """sqrt(sum d^2 / sum dof), m."""
        return float(np.sqrt(np.sum(self.distances**2) / np.sum(self.dof)))

    @property
    def max(self) -> float:
        """Largest held-out |distance|, m."""
        return float(np.max(np.abs(self.distances)))

    @property
    def se(self) -> float:
        """Standard error of the RMS: std(per-fold RMS, ddof 1) / sqrt(K), m."""
        return float(np.std(self.fold_rms, ddof=1) / np.sqrt(self.fold_rms.size))

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (m)."""
        return {
            "scheme": self.scheme,
            "seed": self.seed,
            "readings": int(self.distances.size),
            "rms": self.rms,
            "max": self.max,
        }


def plate_cross_validate(
    make: Callable[[], _Estimator],
    data: PlaneMeasurements,
    *,
    folds: int,
    seed: int = 0,
    progress: bool = False,
) -> PlateCrossValidation:
    """Fits ``make()`` on the plates outside each split (the held-out readings
    never enter the fit) and scores the held-out plates by
    :func:`plate_distances` of the fitted ``model_`` (see the module
    docstring). ``make`` returns an unfitted estimator (a
    :class:`~rmdrake.calibration.plates.estimators.PlaneLM`). ``progress``
    shows the splits done and the time left.

    Raises:
      ValueError: bad ``folds`` (:func:`plate_splits`), or a training set the
        estimator cannot fit.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, plate_cross_validate, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=5, per_plate=10, seed=0).data
    >>> cv = plate_cross_validate(lambda: PlaneLM(robot), data, folds=5)
    >>> cv.distances.shape, bool(abs(cv.distances).max() < 1e-4)
    ((50,), True)
    """
    distances, dofs, fold_rms = [], [], []
    splits = plate_splits(data, folds=folds, seed=seed)
    for test_ids in progress_iter(
        splits, desc="cross-validation splits", lazy=not progress
    ):  # not shown (progress False) unless the process is silent an interval
        test = np.isin(data.plane, test_ids)
        est = make().fit(data.subset(~test))
        d, dof = plate_distances(est.model_, data.subset(test))
        distances.append(d)
        dofs.append(dof)
        fold_rms.append(float(np.sqrt(np.sum(d**2) / np.sum(dof))))
    return PlateCrossValidation(
        np.concatenate(distances),
        np.concatenate(dofs),
        np.array(fold_rms),
        f"{folds}-fold over plates",
        seed,
    )


@dataclasses.dataclass(frozen=True)
class PlateSelection(StepwiseSelection):
    """The outcome of :func:`select_plate_parameters`.

    Attributes:
      candidates: (label, names, CV RMS in m, CV max |distance| in m, SE of the
        CV RMS in m) in the order tried: the start, then the accepted
        additions.
      chosen: the chosen names; label: its candidate's label.
      threshold: max(best CV RMS, floor) + its SE (m): the chosen set is the
        smallest candidate at or below it.
      folds, seed: the selection CV (K folds over the plates).
      floor: m, CV RMS values below it counted as it.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, PlateSelection, select_plate_parameters
    >>> from rmdrake.calibration import simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, seed=0).data
    >>> make = lambda names: PlaneLM(robot, params=list(names))
    >>> choice = select_plate_parameters(make, data, folds=4, max_steps=1)
    >>> isinstance(choice, PlateSelection), choice.label
    (True, 'paper')
    """

    floor: float = PLATE_CV_FLOOR

    def record(self) -> dict[str, Any]:
        """For the YAML calibration record (m)."""
        return {
            "rule": "one-standard-error rule on the K-fold CV RMS over plates of "
            "the held-out point-to-plane distances (each held-out plate's plane "
            "fitted to its points by the kinematics of the training plates; sum "
            "d^2 / sum (readings - 3)): start at the identifiable paper set (or "
            "the joint offsets), forward stepwise additions from the identifiable "
            "full set while one lowers the CV RMS by >= 1 %; the chosen set is the "
            "candidate with the fewest parameters whose CV RMS is at most the "
            "best's + its SE (std of the per-fold RMS / sqrt(K)); CV RMS below "
            "the floor counts as the floor",
            "folds": self.folds,
            "seed": self.seed,
            "floor": self.floor,
            "chosen": self.label,
            "selection_cv_rms": self.cv_rms,
            "threshold": self.threshold,
            "note": "selection_cv_rms chose the set, so it is optimistic",
            "candidates": self.candidate_records(),
        }

    def summary_lines(self) -> list[str]:
        """The candidates and the choice, in um."""
        return [
            f"automatic parameter choice ({self.folds}-fold CV over plates, "
            f"one-SE rule: the smallest set with CV RMS <= "
            f"{self.threshold * 1e6:.4g} um):",
            *self.candidate_lines("um", 1e6),
        ]


def selection_start(
    model: RobotModel, data: PlaneMeasurements, *, rtol: float = 1e-6
) -> tuple[str, list[str], list[str]]:
    """(label, start names, identifiable full set) of the choice on ``data``:
    the identifiable paper set (``paper``; the identifiable joint offsets,
    ``offsets``, on a robot that is not a 6-joint arm) and the identifiable
    ``full`` set in its preference order
    (:mod:`rmdrake.calibration.identifiability`). Each analysis takes 15 s
    on 200 000 readings: a lazy bar over the two
    (:func:`rmdrake.progress.progress_bar`) shows them when the process has
    been silent for the progress interval."""
    if model.n_joints == 6:
        label, names = "paper", error_parameter_names(model, "paper")
    else:
        label, names = "offsets", joint_offset_names(model)
    sets = [names, error_parameter_names(model, "full")]
    bar = progress_bar(total=len(sets), desc="identifiability of the parameter sets",
                       lazy=True)  # fmt: skip
    found = []
    try:
        for names in sets:
            report = analyse_identifiability(model, data, names, rtol=rtol)
            found.append(list(report.identifiable))
            bar.update(1)
    finally:
        bar.close()
    return label, found[0], found[1]


def select_plate_parameters(
    make_with: Callable[[Sequence[str]], _Estimator],
    data: PlaneMeasurements,
    *,
    folds: int = 5,
    seed: int = 0,
    min_gain: float = 0.01,
    max_steps: int = 12,
    floor: float = PLATE_CV_FLOOR,
    rtol: float = 1e-6,
    progress: bool = False,
) -> PlateSelection:
    """The parameter set chosen by cross-validation over the plates and the
    one-SE rule (the module docstring).

    Args:
      make_with: an unfitted estimator for a list of parameter names (its
        ``model`` is the robot; its ``fit`` must use only the readings given).
      data: the readings (checked by the caller); folds, seed: the K-fold split
        over the plates, K = min(``folds``, plate count).
      min_gain: smallest relative CV improvement of a stepwise addition (0.01).
      max_steps: most stepwise additions.
      floor: m, a CV RMS below it counts as it.
      rtol: identifiability threshold of the start and the pool.
      progress: show the candidate sets scored, the step and the best CV RMS
        so far (um).

    Raises:
      ValueError: fewer than 3 plates (a fold would leave fewer than
        :data:`MIN_TRAINING_PLATES` to fit on).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, select_plate_parameters
    >>> from rmdrake.calibration import simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, seed=0).data
    >>> make = lambda names: PlaneLM(robot, params=list(names))
    >>> choice = select_plate_parameters(make, data, folds=4, max_steps=1)
    >>> len(choice.chosen) >= 17
    True
    """
    model = make_with([]).model
    folds = min(folds, int(data.plate_ids.size))
    plate_splits(data, folds=folds, seed=seed)  # fails early on too few plates

    def score(names: list[str]) -> tuple[float, float, float]:
        try:
            cv = plate_cross_validate(
                lambda: make_with(names), data, folds=folds, seed=seed
            )
        except ValueError:  # not identifiable or too few readings in a fold
            return np.inf, np.inf, np.inf
        return cv.rms, cv.max, cv.se

    label, start, full = selection_start(model, data, rtol=rtol)
    result = stepwise_selection(
        score,
        start,
        full,
        start_label=label,
        after=[("full", full)],
        min_gain=min_gain,
        max_steps=max_steps,
        floor=floor,
        unit=("um", 1e6),
        progress=progress,
    )
    return PlateSelection(*result, folds, seed, floor=floor)
