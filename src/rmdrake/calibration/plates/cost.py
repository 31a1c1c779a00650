"""Plane-constraint costs: the paper's tetrahedron volumes and signed
point-to-plane residuals.

Both work on the predicted measurement points ``p_BM = p_BE(q) + distance *
z_BE(q)`` (B = robot base, E = tool frame, m) of a kinematic model whose MDH table
is the nominal table plus error parameters ("deltas", rad or m) at flat indices
into ``table.ravel()`` (see
:func:`rmdrake.model.error_parameters.error_parameter_indices`).

* :class:`VolumeCost` is paper eq. 1 and 5: the sum over plates of |V_t| of a
  fixed set of point quadruples, evaluated for a whole population of delta
  vectors in one call (for Differential Evolution).
* :class:`PlaneProblem` is the least-squares form: one signed distance
  ``n_p . p_BM - h_p`` per reading, with each plate's unit normal n_p (two
  angles about an initial normal) and offset h_p (m) as extra unknowns, and its
  analytic Jacobian.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from rmdrake.calibration.elastostatic import ElasticJoints
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.kinematics.forward import pose_chunks, tool_points

__all__ = [
    "PlaneProblem",
    "VolumeCost",
    "fit_plane",
    "fit_planes",
    "plate_quadruples",
    "tetrahedron_volumes",
]


def plate_quadruples(
    plate_index: np.ndarray, max_per_plate: int | None = None
) -> np.ndarray:
    """The fixed set of point quadruples of the volume cost.

    For each plate (readings taken in file order), the quadruples are all
    C(m, 4) 4-subsets of its m readings in lexicographic order
    (:func:`itertools.combinations`); if ``max_per_plate`` is given and
    C(m, 4) exceeds it, ``max_per_plate`` of them evenly spaced along that
    lexicographic list (``numpy.linspace`` rounded down; exact integer
    division once C(m, 4) passes 2^53, where floats lose the rank), found by
    their rank (:func:`_unrank_combination`) without listing the C(m, 4): the
    cap keeps the work per plate O(cap log m) however many readings it has.
    No randomness: the cost is a fixed function of the data. For 12 readings
    per plate this is all 495 quadruples unless capped.

    Args:
      plate_index: (N,) plate index (any integers) of each reading.
      max_per_plate: cap on quadruples per plate, or None for all.

    Returns:
      (Q, 4) reading indices (int), plates in increasing id order.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import plate_quadruples
    >>> plate_quadruples(np.array([0, 0, 0, 0, 0, 1, 1, 1, 1])).shape
    (6, 4)
    """
    plate_index = np.asarray(plate_index)
    out = []
    order = np.argsort(plate_index, kind="stable")  # each plate's rows, in order
    plates, starts = np.unique(plate_index[order], return_index=True)
    for rows in np.split(order, starts[1:]) if plates.size else []:
        m = rows.size
        total = math.comb(m, 4)
        if total == 0:
            continue
        if max_per_plate is not None and total > max_per_plate:
            cap = int(max_per_plate)
            if total - 1 < 2**53:  # the float ranks of numpy.linspace, exact
                ranks = np.linspace(0, total - 1, cap).astype(np.intp).tolist()
            else:
                ranks = [i * (total - 1) // max(cap - 1, 1) for i in range(cap)]
            combos = np.array(
                [_unrank_combination(m, 4, k) for k in ranks], dtype=np.intp
            ).reshape(-1, 4)
        else:
            combos = np.array(list(itertools.combinations(range(m), 4)), np.intp)
        out.append(rows[combos])
    if not out:
        return np.zeros((0, 4), dtype=np.intp)
    return np.concatenate(out)


def _unrank_combination(m: int, k: int, rank: int) -> list[int]:
    """The ``rank``-th (0-based) k-subset of range(m) in lexicographic order
    (that of :func:`itertools.combinations`), by exact integer counts: the
    subsets whose first element is below x number C(m - lo, k) - C(m - x, k)
    (lo the smallest allowed element), found by bisection for each place."""
    out, lo = [], 0
    for left in range(k, 0, -1):
        ahead = math.comb(m - lo, left)
        a, b = lo, m - left  # the element of this place is in [a, b]
        while a < b:
            x = (a + b + 1) // 2
            if ahead - math.comb(m - x, left) <= rank:
                a = x
            else:
                b = x - 1
        rank -= ahead - math.comb(m - a, left)
        out.append(a)
        lo = a + 1
    return out


def tetrahedron_volumes(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Signed tetrahedron volumes V_t = AD . (AB x AC) / 6 (paper eq. 1), m^3.

    Args:
      points: (..., N, 3) points, m.
      quads: (Q, 4) indices of A, B, C, D.

    Returns:
      (..., Q) signed volumes.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import tetrahedron_volumes
    >>> corners = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> tetrahedron_volumes(corners, np.array([[0, 1, 2, 3]])).round(6)
    array([0.166667])
    """
    A = points[..., quads[:, 0], :]
    AB = points[..., quads[:, 1], :] - A
    AC = points[..., quads[:, 2], :] - A
    AD = points[..., quads[:, 3], :] - A
    # Scalar triple product written out: avoids np.cross's temporaries.
    cx = AB[..., 1] * AC[..., 2] - AB[..., 2] * AC[..., 1]
    cy = AB[..., 2] * AC[..., 0] - AB[..., 0] * AC[..., 2]
    cz = AB[..., 0] * AC[..., 1] - AB[..., 1] * AC[..., 0]
    return (AD[..., 0] * cx + AD[..., 1] * cy + AD[..., 2] * cz) / 6.0


class VolumeCost:
    """Paper eq. 5: sum over plates and quadruples of |V_t|, in m^3.

    Callable on a population: ``cost(deltas)`` with deltas (S, k) returns (S,)
    costs, evaluating all S models with one batched forward-kinematics call
    (:func:`rmdrake.kinematics.forward.tool_points` on an (S, n+1, 5) table stack).
    A single (k,) vector returns a scalar.

    Args:
      table: (n+1, 5) nominal MDH table (rad, m).
      data: the readings.
      indices: (k,) flat table indices of the error parameters.
      max_per_plate: cap on quadruples per plate (:func:`plate_quadruples`).
      chunk: evaluate at most this many candidates at a time; default: as
        many as keep each (candidates, quadruples, 3) temporary near 50 MB.
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.

    Attributes:
      quads: (Q, 4) the quadruples' reading indices (:func:`plate_quadruples`).
      q: the joints of the readings some quadruple uses (the others do not
        enter the cost), in reading order.
      distance: the readings of those readings, in the same order.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import VolumeCost, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, noise=0.0, seed=0).data
    >>> cost = VolumeCost(robot.table, data, np.array([], dtype=int))
    >>> cost.volumes(np.zeros(0)).shape, float(cost(np.zeros(0))) < 1e-12
    ((1, 280), True)
    """

    def __init__(
        self,
        table: np.ndarray,
        data: PlaneMeasurements,
        indices: np.ndarray,
        *,
        max_per_plate: int | None = None,
        chunk: int | None = None,
        sigma: np.ndarray | None = None,
    ) -> None:
        self.table = np.array(table, dtype=np.float64)
        self.sigma = sigma
        self.indices = np.asarray(indices, dtype=np.intp)
        self.quads = plate_quadruples(data.plate_index, max_per_plate)
        # Only the readings of some quadruple enter the cost: their points
        # alone are computed (a capped cost does not grow with the readings).
        used, local = np.unique(self.quads, return_inverse=True)
        self.q = np.asarray(data.q)[used]
        self.distance = np.asarray(data.distance)[used]
        self._local = local.reshape(self.quads.shape)
        q_count = max(1, self.quads.shape[0], used.size)
        self.chunk = int(chunk) if chunk else max(1, 2_000_000 // q_count)

    def tables(self, deltas: np.ndarray) -> np.ndarray:
        """(S, n+1, 5) tables of (S, k) deltas."""
        deltas = np.atleast_2d(deltas)
        flat = np.broadcast_to(self.table.ravel(), (deltas.shape[0], self.table.size))
        flat = flat.copy()
        flat[:, self.indices] += deltas
        return flat.reshape(deltas.shape[0], *self.table.shape)

    def volumes(self, deltas: np.ndarray) -> np.ndarray:
        """(S, Q) signed volumes of (S, k) deltas, m^3."""
        points = tool_points(
            self.tables(deltas), self.q, self.distance, sigma=self.sigma
        )
        return tetrahedron_volumes(points, self._local)

    def __call__(self, deltas: np.ndarray) -> np.ndarray | float:
        d = np.asarray(deltas, dtype=np.float64)
        single = d.ndim == 1
        d = np.atleast_2d(d)
        out = np.empty(d.shape[0])
        for s in range(0, d.shape[0], self.chunk):
            out[s : s + self.chunk] = np.abs(self.volumes(d[s : s + self.chunk])).sum(
                axis=-1
            )
        return float(out[0]) if single else out


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane through points (SVD of the centred points).

    Returns:
      (unit normal n (3,), offset h in m) with n . p = h on the plane.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import fit_plane
    >>> points = np.array([[0.0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]])
    >>> normal, offset = fit_plane(points)
    >>> np.abs(normal).round(6), round(abs(offset), 6)
    (array([0., 0., 1.]), 1.0)
    """
    points = np.asarray(points, dtype=np.float64)
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    normal = vt[-1]
    return normal, float(normal @ centre)


def fit_planes(
    points: np.ndarray, plate_index: np.ndarray, n_plates: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`fit_plane` per plate: (P, 3) normals and (P,) offsets (m).

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import fit_planes
    >>> square = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1]])
    >>> points = np.vstack([np.c_[square, np.ones(4)], np.c_[np.zeros(4), square]])
    >>> normals, offsets = fit_planes(points, np.repeat([0, 1], 4), 2)
    >>> np.abs(normals).round(6)
    array([[0., 0., 1.],
           [1., 0., 0.]])
    """
    normals = np.empty((n_plates, 3))
    offsets = np.empty(n_plates)
    for p in range(n_plates):
        normals[p], offsets[p] = fit_plane(points[plate_index == p])
    return normals, offsets


def _tangent_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors u, v per normal with (u, v, n) orthonormal."""
    helper = np.where(
        np.abs(normals[:, [0]]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    )
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    return u, v


class PlaneProblem:
    """Signed point-to-plane residuals with plate poses as unknowns.

    The unknown vector is ``x = [deltas (k), a_1, b_1, h_1, ..., a_P, b_P, h_P]``.
    Plate p's unit normal is ``n_p = (n0_p + a_p u_p + b_p v_p) / |...|`` with
    (u_p, v_p) a fixed tangent basis of the initial normal n0_p (a minimal,
    singularity-free parametrisation near n0_p) and its offset h_p (m): the
    plane is {p : n_p . p = h_p}. Residual of reading i on plate p:
    ``n_p . p_BM,i - h_p`` (m).

    Elastic joints (:class:`~rmdrake.calibration.elastostatic.ElasticJoints`):
    with ``torques`` tau (N, n) the chain turns the link angles
    ``q_l = q + c * tau`` (q the readings' motor angles), with c the fixed
    ``compliance`` (n,) except on ``compliance_joints``, whose compliances are
    unknowns after the deltas: ``x = [deltas (k_g), c (k_c), plates]``. tau is
    held fixed here (the caller updates it between fits), so the column of c_j
    is that of joint j's offset (``dtheta<j>``, ``dr<j>`` on a slide) times
    tau_j of each reading: no new kinematics.

    Args:
      table: (n+1, 5) nominal MDH table.
      data: the readings.
      indices: (k_g,) flat table indices of the error parameters.
      normals0: (P, 3) initial unit normals (e.g. from :func:`fit_planes`).
      sigma: (n,) joint types (0 revolute, 1 prismatic); None = all revolute.
      torques: (N, n) generalized gravity force on each joint at each reading,
        N m or N (Drake's sign); None: rigid joints (q_l = q).
      compliance: (n,) fixed compliances, rad/(N m) or m/N; default 0.
      compliance_joints: (k_c,) 0-based joints whose compliance is unknown.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, PlaneProblem, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, seed=0).data
    >>> lm = PlaneLM(robot, params="paper").fit(data)
    >>> len(lm.names_), lm.normals_.shape
    (17, (4, 3))
    """

    def __init__(
        self,
        table: np.ndarray,
        data: PlaneMeasurements,
        indices: np.ndarray,
        normals0: np.ndarray,
        *,
        sigma: np.ndarray | None = None,
        torques: np.ndarray | None = None,
        compliance: np.ndarray | None = None,
        compliance_joints: np.ndarray | None = None,
    ) -> None:
        self.table = np.array(table, dtype=np.float64)
        self.sigma = sigma
        self.q = np.asarray(data.q)
        self.distance = np.asarray(data.distance)
        self.indices = np.asarray(indices, dtype=np.intp)
        self.plate = data.plate_index
        self.n_plates = int(data.plate_ids.size)
        self.normals0 = np.asarray(normals0, dtype=np.float64)
        self.u, self.v = _tangent_basis(self.normals0)
        self.elastic = ElasticJoints(
            self.q,
            self.indices.size,
            sigma=sigma,
            torques=torques,
            compliance=compliance,
            compliance_joints=compliance_joints,
        )
        self.k_geometric = self.indices.size
        self.k = self.elastic.k

    @property
    def n_unknowns(self) -> int:
        """k + 3 P (k = k_g + k_c)."""
        return self.k + 3 * self.n_plates

    def pack(self, deltas: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """x for the given deltas and offsets with the normals at n0."""
        plates = np.zeros((self.n_plates, 3))
        plates[:, 2] = offsets
        return np.concatenate([np.asarray(deltas, dtype=np.float64), plates.ravel()])

    def table_of(self, deltas: np.ndarray) -> np.ndarray:
        """(n+1, 5) MDH table of the nominal plus ``deltas`` (its first k_g
        entries; compliances after them are ignored)."""
        flat = self.table.ravel().copy()
        flat[self.indices] += deltas[: self.k_geometric]
        return flat.reshape(self.table.shape)

    def link_angles(self, x: np.ndarray) -> np.ndarray:
        """(N, n) joint positions the chain turns at x: q + c * tau (q without
        torques), rad or m."""
        return self.elastic.link_angles(x)

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(deltas (k,), unit normals (P, 3), offsets (P,)) of x."""
        deltas = x[: self.k]
        ab = x[self.k :].reshape(self.n_plates, 3)
        m = self.normals0 + ab[:, [0]] * self.u + ab[:, [1]] * self.v
        return deltas, m / np.linalg.norm(m, axis=1, keepdims=True), ab[:, 2]

    def points(self, x: np.ndarray) -> np.ndarray:
        """(N, 3) predicted measurement points p_BM at x, m."""
        table = self.table_of(x[: self.k])
        q = self.link_angles(x)
        return tool_points(table, q, self.distance, sigma=self.sigma)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """(N,) signed point-to-plane distances, m."""
        _, normals, offsets = self.unpack(x)
        pts = self.points(x)
        return np.einsum("ij,ij->i", normals[self.plate], pts) - offsets[self.plate]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(N, k + 3P) analytic d residual / d x (dense: linear in N for a
        given plate count; the point Jacobian is built chunk by chunk)."""
        deltas = x[: self.k]
        ab = x[self.k :].reshape(self.n_plates, 3)
        m = self.normals0 + ab[:, [0]] * self.u + ab[:, [1]] * self.v
        s = np.linalg.norm(m, axis=1, keepdims=True)
        n = m / s
        table = self.table_of(deltas)
        q = self.link_angles(x)
        pts = tool_points(table, q, self.distance, sigma=self.sigma)
        nr = n[self.plate]
        J = np.zeros((self.q.shape[0], self.n_unknowns))
        # The (N, 3, k) point Jacobian chunk by chunk: only J stays.
        for rows in pose_chunks(1, self.q.shape[0]):
            J_pts = self.elastic.point_jacobian(
                table,
                q[rows],
                self.indices,
                rows,
                distance=self.distance[rows],
                sigma=self.sigma,
            )
            J[rows, : self.k] = np.einsum("ij,ijk->ik", nr[rows], J_pts)
        # d n / d a = (u - n (n . u)) / |m|, likewise for b.
        dn_da = (self.u - n * np.sum(n * self.u, axis=1, keepdims=True)) / s
        dn_db = (self.v - n * np.sum(n * self.v, axis=1, keepdims=True)) / s
        rows = np.arange(self.q.shape[0])
        col = self.k + 3 * self.plate
        J[rows, col] = np.einsum("ij,ij->i", dn_da[self.plate], pts)
        J[rows, col + 1] = np.einsum("ij,ij->i", dn_db[self.plate], pts)
        J[rows, col + 2] = -1.0
        return J
