"""Which error parameters can the readings identify? The analysis every kind
shares (:func:`analyse_columns`, :class:`Candidates`); each kind builds its
Jacobian: the plates in :mod:`rmdrake.calibration.plates.identifiability`,
the points in :mod:`rmdrake.calibration.points.identifiability`, the sockets
in :mod:`rmdrake.calibration.sockets.lm`. Below, the plates' case.

The identification Jacobian is d residual / d (deltas, plate unknowns) of the
signed point-to-plane residuals (:class:`~rmdrake.calibration.plates.cost.PlaneProblem`)
at the measured poses. The plate unknowns (normal and offset of every plate) are
part of it because the plates are at unknown places: any parameter change that
moves all measured points rigidly (the base frame's pose, for instance) is
absorbed by the plate poses and cannot be seen.

Procedure (columns scaled to unit norm so that m and rad compare):

1. columns that are zero: parameters with no effect on the measured point (the
   rotation of the tool about its own beam, for instance);
2. project the kinematic columns onto the orthogonal complement of the plate
   columns: what remains is what the plates cannot explain; a column that
   vanishes there is absorbed by the plate poses;
3. a greedy pass in the fixed **preference order** keeps a parameter when its
   projected column still has a residual norm above ``rtol`` after removing its
   projection onto the parameters already kept (twice-orthogonalised
   Gram-Schmidt); the others are linear combinations of the kept ones (the
   report names which);
4. SVD of the projected columns: the right singular vectors of the near-zero
   singular values are the unidentifiable combinations.

Preference order: the MDH table's order, rows from the base to the tool
(j = 1..n+1), and inside a row ``alpha, d, theta, r, beta``; joint compliances
``c<j>`` (an elastostatic calibration, :mod:`.elastostatic`) after every MDH
entry, in joint order: a compliance whose joint torque does not vary over the
readings acts as its joint's offset, and the offset is kept. Where parameters
act alike (dr2 and dr3 on the parallel axes 2 and 3 of an RV-3SB), the one
earlier in this order is kept, whatever order the names are given in and
whatever the data, as long as the data see the same combinations. This is the
convention of the dynamic base parameters too (the earlier link absorbs the
later), and it keeps the paper's choice for its Table 1 (dr2 over dr3). A
pivoted QR would instead keep whichever column round-off favours, so two
calibrations of one robot could carry different names.

The dependencies in a kinematic chain are structural: on the RV-3SB ``full``
preset the residual of a kept column is above 2e-2 and that of a dependent one
below 1e-15 for every plate set tried, so the choice does not depend on
``rtol`` anywhere in between. The report keeps both margins
(:attr:`IdentifiabilityReport.weakest_kept`, ``strongest_dropped``) so a narrow
gap (a nearly unidentifiable parameter) is visible.

Point data (:func:`analyse_point_identifiability`): the nuisance unknowns are
the instrument pose and the markers instead of the plates; the same order.

The rank is the number of identifiable kinematic parameters; the condition number
is that of the column-scaled Jacobian of the identifiable parameters together with
the plate unknowns.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from rmdrake.calibration.elastostatic import JointLoads
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    split_error_parameters,
)
from rmdrake.model.robot import RobotModel

__all__ = [
    "Candidates",
    "IdentifiabilityReport",
    "analyse_columns",
]


@dataclasses.dataclass(frozen=True)
class IdentifiabilityReport:
    """Result of :func:`analyse_identifiability`.

    Attributes:
      names: the candidate error parameters, in the order given.
      identifiable: the identifiable subset, in the order of ``names``.
      dropped: name -> reason for each candidate not identifiable.
      rank: number of identifiable kinematic parameters.
      n_plate_unknowns: the nuisance unknowns projected out first: 3 per
        plate (two normal angles and an offset), or 6 + 3 per marker (the
        instrument pose and the markers of point data).
      condition_number: of the column-scaled Jacobian [identifiable | plates].
      residuals: name -> norm of the parameter's unit column left after
        projecting out the plates and the parameters kept before it in the
        preference order (1 = fully visible, 0 = invisible), for every candidate.
      combinations: unidentifiable directions, each a mapping name -> weight
        (unit vector in column-scaled units, weights below 0.05 left out).
      rtol: the threshold on the residuals.
      nuisance: what the nuisance unknowns are (``plate poses``, ``instrument
        pose and markers``).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import analyse_point_identifiability, simulate_points
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=12, seed=0).data
    >>> names = ["dtheta2", "dtheta3", "dr2"]
    >>> report = analyse_point_identifiability(robot, data, names)
    >>> report.rank, report.identifiable
    (3, ['dtheta2', 'dtheta3', 'dr2'])
    """

    names: list[str]
    identifiable: list[str]
    dropped: dict[str, str]
    rank: int
    n_plate_unknowns: int
    condition_number: float
    residuals: dict[str, float]
    combinations: list[dict[str, float]]
    rtol: float
    nuisance: str = "plate poses"

    @property
    def weakest_kept(self) -> float:
        """Smallest residual of a kept parameter (1 when none is kept)."""
        kept = [self.residuals[n] for n in self.identifiable]
        return float(min(kept, default=1.0))

    @property
    def strongest_dropped(self) -> float:
        """Largest residual of a dropped parameter (0 when none is dropped)."""
        dropped = [self.residuals[n] for n in self.dropped]
        return float(max(dropped, default=0.0))

    @property
    def full_rank(self) -> bool:
        """True when every candidate is identifiable."""
        return self.rank == len(self.names)

    def summary(self) -> str:
        """A few human-readable lines."""
        lines = [
            f"identifiability: rank {self.rank} of {len(self.names)} parameters "
            f"(+{self.n_plate_unknowns} unknowns of the {self.nuisance}), condition "
            f"number "
            f"{self.condition_number:.3g}"
        ]
        for name, why in self.dropped.items():
            lines.append(f"  dropped {name}: {why}")
        return "\n".join(lines)


def _describe(weights: dict[str, float], limit: int = 3) -> str:
    items = sorted(weights.items(), key=lambda kv: -abs(kv[1]))[:limit]
    return " ".join(f"{w:+.2f}*{n}" for n, w in items)


def _greedy_in_order(
    J: np.ndarray, order: np.ndarray, rtol: float
) -> tuple[np.ndarray, np.ndarray]:
    """(residual per column, kept columns ascending) of a greedy pass over the
    unit-or-zero columns of ``J`` in ``order`` (see the module docstring)."""
    k = J.shape[1]
    residuals = np.zeros(k)
    basis = np.zeros((J.shape[0], 0))
    kept = []
    for j in order:
        c = J[:, j].copy()
        for _ in range(2):  # twice is enough (Kahan-Parlett)
            c -= basis @ (basis.T @ c)
        r = float(np.linalg.norm(c))
        residuals[j] = r
        if r > rtol:
            kept.append(j)
            basis = np.column_stack([basis, c / r])
    return residuals, np.array(sorted(kept), dtype=np.intp)


class Candidates:
    """The candidates of an identifiability analysis: MDH names first, then
    the compliances (``names``), their flat MDH indices ``idx``, the values
    ``deltas`` (default the nominal's), the joint ``loads`` and ``torques`` at
    them, the problem's elastic ``options``, and the preference ``order`` and
    unit ``groups`` of :func:`analyse_columns`."""

    def __init__(
        self,
        model: RobotModel,
        data: Any,
        names: list[str],
        deltas: np.ndarray | None,
    ) -> None:
        geometric, joints = split_error_parameters(model, names)
        self.names = geometric + [f"c{j + 1}" for j in joints]
        self.idx = error_parameter_indices(model, geometric)
        self.loads = JointLoads(model, data, self.names)
        if deltas is None:
            deltas = np.concatenate([np.zeros(self.idx.size), self.loads.start()])
        self.deltas = np.asarray(deltas, dtype=np.float64)
        self.torques = self.loads.torques(self.deltas)
        self.options = self.loads.problem_options(self.torques)
        self.order = np.concatenate([self.idx, model.table.size + joints])
        self.groups = np.concatenate([np.zeros(self.idx.size), np.ones(joints.size)])


_NUISANCE = {
    "plate": (
        "plate poses",
        "absorbed by the unknown plate poses (it moves every measured point "
        "rigidly, like a base-frame change)",
    ),
    "instrument": (
        "instrument pose and markers",
        "absorbed by the unknown instrument pose and markers (a fixed change "
        "of the base frame or of the tool frame)",
    ),
    "socket": (
        "socket points",
        "absorbed by the unknown socket points (a fixed change of the base "
        "frame moves every socket alike; a turn of the tool about the ball "
        "moves none)",
    ),
    "socket_unscaled": (
        "socket points and the length scale",
        "absorbed by the unknown socket points or the length scale (no known "
        "distance between sockets fixes it)",
    ),
}


def analyse_columns(
    J: np.ndarray,
    names: list[str],
    idx: np.ndarray,
    rtol: float,
    nuisance: str,
    *,
    groups: np.ndarray | None = None,
) -> IdentifiabilityReport:
    """The analysis of the module docstring on a Jacobian whose first
    ``len(names)`` columns are the error parameters (flat MDH indices ``idx``,
    which fix the preference order; compliances past the table) and whose other
    columns are nuisance unknowns of the kind ``nuisance`` (``plate``,
    ``instrument``, ``socket`` or ``socket_unscaled``). ``groups`` (k,)
    labels columns of different units (MDH entries, compliances): a column is
    zero against its group's largest."""
    k = len(names)
    what, absorbed = _NUISANCE[nuisance]
    norms = np.linalg.norm(J, axis=0)
    groups = np.zeros(k) if groups is None else np.asarray(groups)
    zero = np.zeros(k, dtype=bool)
    for g in np.unique(groups):
        cols = groups == g
        scale = np.max(norms[:k][cols])
        zero[cols] = norms[:k][cols] <= 1e-12 * max(scale, 1e-300)
    Js = J / np.where(norms > 0, norms, 1.0)
    Js[:, :k][:, zero] = 0.0
    Q_plates, _ = np.linalg.qr(Js[:, k:])
    Jk = Js[:, :k]
    J_perp = Jk - Q_plates @ (Q_plates.T @ Jk)

    dropped: dict[str, str] = {}
    order = np.argsort(idx, kind="stable")  # preference: table order
    residuals, kept_cols = _greedy_in_order(J_perp, order, rtol)
    residuals[zero] = 0.0
    rank = int(kept_cols.size)
    residual_of = {names[j]: float(residuals[j]) for j in range(k)}
    kept = set(kept_cols.tolist())
    for j in range(k):
        if j in kept:
            continue
        if zero[j]:
            dropped[names[j]] = "has no effect on the measured points"
        elif np.linalg.norm(J_perp[:, j]) <= rtol:
            dropped[names[j]] = absorbed
        else:
            coef, *_ = np.linalg.lstsq(J_perp[:, kept_cols], J_perp[:, j], rcond=None)
            # Back to physical units: J_j = sum_i coef_i (norm_j / norm_i) J_i.
            phys = coef * norms[j] / norms[kept_cols]
            w = {names[c]: float(v) for c, v in zip(kept_cols, phys, strict=True)}
            w = {n: v for n, v in w.items() if abs(v) > 1e-6}
            dropped[names[j]] = (
                "not separable from the other parameters (same effect as "
                f"{_describe(w)}, up to the {what})"
            )

    combos: list[dict[str, float]] = []
    if k:
        # vt must span all k directions: (k, k) from the economic SVD when
        # N >= k; the full one only when N < k (then it is small). A full SVD
        # of a tall J_perp would build an N x N U (298 GiB at N = 200 000).
        short = J_perp.shape[0] < k
        _, s, vt = np.linalg.svd(J_perp, full_matrices=short)
        s = np.concatenate([s, np.zeros(k - s.size)])  # fewer readings than k
        for i in np.flatnonzero(s <= rtol):
            v = vt[i] / np.max(np.abs(vt[i]))
            combos.append({names[j]: float(v[j]) for j in range(k) if abs(v[j]) > 0.05})
    sv = np.linalg.svd(np.hstack([Js[:, kept_cols], Js[:, k:]]), compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else float("inf")
    return IdentifiabilityReport(
        names=names,
        identifiable=[names[j] for j in kept_cols],
        dropped=dropped,
        rank=rank,
        n_plate_unknowns=J.shape[1] - k,
        nuisance=what,
        condition_number=cond,
        residuals=residual_of,
        combinations=combos,
        rtol=float(rtol),
    )
