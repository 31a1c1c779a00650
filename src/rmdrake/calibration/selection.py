"""The automatic choice of error parameters shared by the point and the plate
calibrations: forward stepwise selection on a cross-validated RMS, then the
one-standard-error rule (Hastie, Tibshirani and Friedman, *The Elements of
Statistical Learning*, section 7.10).

What is scored is the caller's: ``score(names) -> (CV RMS, CV max, SE of the
CV RMS)`` (m) of a parameter list, with infinities when the set cannot be
fitted (not identifiable, too few readings in a fold). The points score the
3-D errors of held-out poses (:mod:`rmdrake.calibration.points.selection`),
the plates the point-to-plane distances of held-out plates
(:mod:`rmdrake.calibration.plates.selection`). The rule
(:func:`stepwise_selection`), one place for both:

1. score the ``before`` candidates (the points' ``base``), then the ``start``
   set;
2. forward stepwise from ``start``: add the one name of ``pool`` that lowers
   the CV RMS most; stop when no addition lowers it by at least ``min_gain``
   (1 %: the new RMS must be below (1 - min_gain) times the current one), or
   after ``max_steps`` additions, or when the pool is empty; then score the
   ``after`` candidates not yet scored (the plates' whole identifiable set:
   parameters that help only together are missed by the one-at-a-time
   additions);
3. one-SE rule (:func:`one_se_choice`): the best candidate has the smallest CV
   RMS, SE its standard error (std of its per-fold RMS, ddof 1, / sqrt(K));
   the chosen set is the candidate with the fewest parameters whose CV RMS is
   at most the best's + SE (the earlier candidate on a tie).

A CV RMS below ``floor`` (m) counts as ``floor`` in steps 2 and 3: below it
differences are round-off (noise-free data), so no addition is accepted and the
smallest candidate is chosen. The points use no floor (0); the plates 1 nm.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from rmdrake.progress import progress_bar

__all__ = [
    "MAX_FOLDS",
    "Candidate",
    "Stepwise",
    "StepwiseSelection",
    "held_out_ids",
    "one_se_choice",
    "stepwise_selection",
]

MAX_FOLDS = 20
"""The most folds of a reported cross-validation (``--folds``): each fold
refits the whole calibration (with ``params`` ``auto`` the automatic choice
too, nested), so K folds cost K calibrations; 5 or 10 is the usual choice,
and 50 took a minute on 60 poses."""

Candidate = tuple[str, list[str], float, float, float]
"""(label, names, CV RMS in m, CV max in m, SE of the CV RMS in m)."""

Score = Callable[[list[str]], tuple[float, float, float]]
"""(CV RMS, CV max, SE of the CV RMS) of a parameter list, m."""


class Stepwise(NamedTuple):
    """The outcome of :func:`stepwise_selection` (the first fields of a
    :class:`StepwiseSelection`)."""

    candidates: list[Candidate]
    chosen: list[str]
    label: str
    threshold: float


def one_se_choice(
    candidates: Sequence[Candidate], floor: float = 0.0
) -> tuple[str, list[str], float]:
    """(label, names, threshold in m) of the one-SE rule (step 3 of the module
    docstring): the threshold is max(best CV RMS, ``floor``) + the best's SE;
    the choice the candidate with the fewest parameters whose max(CV RMS,
    ``floor``) is at or below it, the earlier one on a tie.

    Example:

    >>> from rmdrake.calibration import one_se_choice
    >>> small = ("small", ["a"], 1.05e-3, 2e-3, 1e-4)
    >>> big = ("big", ["a", "b"], 1.0e-3, 2e-3, 1e-4)
    >>> candidates = [small, big]
    >>> one_se_choice(candidates)[:2]
    ('small', ['a'])
    """
    rms = [max(c[2], floor) for c in candidates]
    top = int(np.argmin(rms))
    threshold = rms[top] + candidates[top][4]
    label, chosen = min(
        (c for c, r in zip(candidates, rms, strict=True) if r <= threshold),
        key=lambda c: len(c[1]),
    )[:2]
    return label, list(chosen), float(threshold)


def stepwise_selection(
    score: Score,
    start: Sequence[str],
    pool: Sequence[str],
    *,
    start_label: str,
    before: Sequence[tuple[str, Sequence[str]]] = (),
    after: Sequence[tuple[str, Sequence[str]]] = (),
    min_gain: float = 0.01,
    max_steps: int = 12,
    floor: float = 0.0,
    unit: tuple[str, float] = ("mm", 1e3),
    progress: bool = False,
) -> Stepwise:
    """The candidates and the choice of the module docstring.

    Args:
      score: (CV RMS, CV max, SE) in m of a list of names (inf: not fitted).
      start: the stepwise start (``start_label``); pool: the names it may add
        (those in ``start`` are skipped), in the order tried.
      before: (label, names) candidates scored first, before the start (the
        points' ``base``).
      after: (label, names) candidates scored after the stepwise ones, unless
        the same set was scored (the plates' ``full``).
      min_gain: smallest relative CV improvement of an addition (0.01 = 1 %).
      max_steps: most additions.
      floor: m, CV RMS values below it count as it (0: none).
      unit: (name, factor from m) of the progress bar's best CV.
      progress: show the candidate sets scored, with the step and the best CV
        RMS so far (their number is not known ahead: no time left is shown).

    Returns:
      :class:`Stepwise`: the candidates in the order tried (the stepwise ones:
      only the accepted additions, labelled ``+ name``; then ``after``), the
      chosen names and label, the one-SE threshold (m).

    Example:

    >>> from rmdrake.calibration import stepwise_selection
    >>> rms = {(): 5e-3, ("a",): 1e-3, ("b",): 4e-3, ("a", "b"): 0.99e-3}
    >>> score = lambda names: (rms[tuple(sorted(names))], 0.0, 1e-4)
    >>> path = stepwise_selection(score, [], ["a", "b"], start_label="none")
    >>> path.chosen
    ['a']
    """
    bar = progress_bar(total=None, desc="parameter sets scored", disable=not progress)

    def scored(names: list[str]) -> tuple[float, float, float]:
        bar.update(1)
        return score(names)

    candidates: list[Candidate] = [
        (lab, list(names), *scored(list(names))) for lab, names in before
    ]
    current = list(start)
    best = scored(current)
    candidates.append((start_label, list(current), *best))
    remaining = [n for n in pool if n not in current]
    name, factor = unit
    for step in range(max_steps):
        bar.set_postfix(
            {"step": step + 1, f"best_cv_{name}": f"{factor * best[0]:.4g}"}
        )
        if not remaining:
            break
        scores = [scored([*current, n]) for n in remaining]
        i = int(np.argmin([s[0] for s in scores]))
        if not max(scores[i][0], floor) < (1 - min_gain) * max(best[0], floor):
            break
        current = [*current, remaining.pop(i)]
        best = scores[i]
        candidates.append((f"+ {current[-1]}", current, *best))
    for lab, names in after:
        if all(set(names) != set(c[1]) for c in candidates):
            candidates.append((lab, list(names), *scored(list(names))))
    bar.close()
    label, chosen, threshold = one_se_choice(candidates, floor)
    return Stepwise(candidates, chosen, label, threshold)


@dataclasses.dataclass(frozen=True)
class StepwiseSelection:
    """What the points' and the plates' choices share (subclassed by each with
    its record and summary).

    Attributes:
      candidates: (label, names, CV RMS in m, CV max in m, SE of the CV RMS in
        m) in the order tried (the stepwise ones: only the accepted additions).
      chosen: the chosen names; label: its candidate's label.
      threshold: the best CV RMS + its SE (m): the chosen set is the smallest
        candidate at or below it.
      folds, seed, repeats: the selection CV (``repeats`` splits from
        ``seed``).

    Example:

    >>> from rmdrake.calibration import PlateSelection, Selection, StepwiseSelection
    >>> [issubclass(c, StepwiseSelection) for c in (Selection, PlateSelection)]
    [True, True]
    """

    candidates: list[Candidate]
    chosen: list[str]
    label: str
    threshold: float
    folds: int
    seed: int
    repeats: int = 1

    @property
    def cv_rms(self) -> float:
        """Selection CV RMS of the chosen set, m (optimistic: it chose it)."""
        return next(c[2] for c in self.candidates if c[0] == self.label)

    def candidate_records(self) -> list[dict[str, Any]]:
        """Every candidate for the YAML record: label, parameter count, CV RMS,
        max and SE (m)."""
        return [
            {
                "label": lab,
                "parameters": len(n),
                "cv_rms": r,
                "cv_max": m,
                "cv_rms_se": se,
            }
            for lab, n, r, m, se in self.candidates
        ]

    def candidate_lines(self, unit: str, factor: float) -> list[str]:
        """One line per candidate in ``unit`` (``factor`` from m), the chosen
        one marked."""
        lines = []
        for lab, names, rms, mx, se in self.candidates:
            mark = " <- chosen" if lab == self.label else ""
            lines.append(
                f"  {lab:<24} {len(names):>3} parameters: selection CV RMS "
                f"{rms * factor:.4g} +- {se * factor:.2g} {unit}, max "
                f"{mx * factor:.4g} {unit}{mark}"
            )
        return lines


def held_out_ids(
    ids: np.ndarray,
    *,
    folds: int | None = None,
    holdout: float | None = None,
    seed: int = 0,
    what: str = "reading",
) -> list[np.ndarray]:
    """The held-out ids of each split of ``ids`` (the readings, poses, ...
    a cross-validation leaves out together): K interleaved folds of a seeded
    permutation, or its first ``holdout`` fraction; each sorted.

    >>> splits = held_out_ids(np.arange(6), folds=3)
    >>> len(splits), sorted(int(i) for s in splits for i in s)
    (3, [0, 1, 2, 3, 4, 5])

    Args:
      what: the ids' noun in the messages (``pose``: ``the pose count``).

    Raises:
      ValueError: both or neither given, K < 2, above the id count or above
        :data:`MAX_FOLDS`, a fraction outside (0, 1) or leaving no id on
        either side (one line).
    """
    if (folds is None) == (holdout is None):
        raise ValueError("give either folds or holdout")
    ids = np.random.default_rng(seed).permutation(ids)
    N = ids.size
    if folds is not None:
        if folds > MAX_FOLDS:
            raise ValueError(
                f"folds: {folds} is over the cap of {MAX_FOLDS} (each fold refits "
                "the calibration); give 5 or 10"
            )
        if not 2 <= folds <= N:
            raise ValueError(
                f"folds: expected 2..{N} (the {what} count), found {folds}"
            )
        return [np.sort(ids[f::folds]) for f in range(folds)]
    n_test = round(holdout * N)
    if not 0 < holdout < 1 or not 1 <= n_test < N:
        raise ValueError(
            f"holdout: {holdout} of {N} {what}s leaves no {what} to fit or to test"
        )
    return [np.sort(ids[:n_test])]
