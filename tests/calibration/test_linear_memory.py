"""Calibration, its checks and identifiability, linear in the readings: each
place that built an N x N array or an over-large batch is checked against a
direct dense oracle on small data (explicit tolerances), and with a memory
bound (tracemalloc peak) or a chunk size small enough that the old path
would show."""

from __future__ import annotations

import contextlib
import itertools
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import rmdrake.calibration.d_optimal as d_optimal
import rmdrake.calibration.plates.sanity as sanity
import rmdrake.io.atomic as atomic
import rmdrake.kinematics.forward as forward
from rmdrake.calibration.identifiability import analyse_columns
from rmdrake.calibration.plates.cost import PlaneProblem, VolumeCost, plate_quadruples
from rmdrake.calibration.plates.data import (
    PlaneMeasurements,
    read_plane_measurements,
    write_plane_measurements,
)
from rmdrake.calibration.plates.estimators import PlaneLM
from rmdrake.calibration.plates.sanity import check_calibration
from rmdrake.calibration.points.data import (
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.calibration.points.problem import PointProblem, initial_alignment
from rmdrake.calibration.points.simulate import random_point_poses
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot

DATA = Path(__file__).parent / "data"
MB = 2**20


@contextlib.contextmanager
def traced_peak():
    """Yields a list that holds, after the block, the peak bytes numpy and
    Python allocated in it above what was live at its start."""
    out: list[int] = []
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        yield out
        out.append(tracemalloc.get_traced_memory()[1] - start)
    finally:
        tracemalloc.stop()


@pytest.fixture(scope="module")
def plates():
    """The RV-3SB, the 60 reference readings (5 plates) and an LM fit."""
    model = load_robot("rv3sb")
    data = read_plane_measurements(DATA / "plates_rv3sb_seed3.csv")
    return model, data, PlaneLM(model, params="paper").fit(data)


def _tiled(data: PlaneMeasurements, times: int) -> PlaneMeasurements:
    """The readings repeated ``times`` times (plates keep their ids)."""
    return PlaneMeasurements(
        np.tile(data.plane, times),
        np.tile(data.q, (times, 1)),
        np.tile(data.distance, times),
    )


def _problem(est: PlaneLM, data: PlaneMeasurements) -> tuple[PlaneProblem, np.ndarray]:
    idx = error_parameter_indices(est.model, est.names_)
    problem = PlaneProblem(est.model.table, data, idx, est.normals_)
    return problem, problem.pack(est.deltas_, est.offsets_)


# ---- identifiability: no N x N left singular vectors ------------------------------
def _columns(rng: np.random.Generator, N: int, k: int, nuisance: int) -> np.ndarray:
    """(N, k + nuisance) columns whose last parameter column is a combination
    of two others plus nuisance columns: one unidentifiable direction."""
    J = rng.standard_normal((N, k + nuisance))
    J[:, k - 1] = 0.5 * J[:, 0] - 2.0 * J[:, 1] + 3.0 * J[:, k]
    return J


def _check_combinations(J: np.ndarray, k: int, report, tol: float) -> None:
    """Oracle: the dense rank of [params | nuisance] less the nuisance's is the
    rank; each reported combination v (weights over 0.05 kept, the largest
    1), in the column-scaled units, is cancelled by some nuisance columns to
    ``tol``."""
    Js = J / np.linalg.norm(J, axis=0)
    dense_rank = np.linalg.matrix_rank(Js) - np.linalg.matrix_rank(Js[:, k:])
    assert report.rank == dense_rank
    assert len(report.combinations) == k - dense_rank
    for combo in report.combinations:
        v = np.array([combo.get(n, 0.0) for n in report.names])
        target = Js[:, :k] @ v
        w, *_ = np.linalg.lstsq(Js[:, k:], -target, rcond=None)
        residual = np.linalg.norm(target + Js[:, k:] @ w) / np.linalg.norm(v)
        assert residual < tol


@pytest.mark.parametrize(("N", "tol"), [(4, 0.05 * 8), (40, 1e-9)])
def test_identifiability_combinations_match_the_dense_oracle(N, tol):
    """Short (N < k: the full SVD of a small matrix; a 7-dimensional null
    space whose basis has weights under 0.05 left out: tolerance 0.05 k) and
    tall (the economic SVD; the one planted direction, exactly sparse: 1e-9)
    Jacobians give the rank and null directions of the dense oracle."""
    rng = np.random.default_rng(N)
    k = 8
    J = _columns(rng, N, k, 3)
    names = [f"dtheta{j + 1}" for j in range(k)]
    report = analyse_columns(J, names, np.arange(k) * 5 + 2, 1e-6, "plate")
    _check_combinations(J, k, report, tol)


def test_identifiability_never_builds_n_by_n():
    """12 000 readings: an N x N U would be 1.07 GiB; the analysis stays
    under 64 MB above its inputs."""
    rng = np.random.default_rng(0)
    N, k = 12_000, 8
    J = _columns(rng, N, k, 9)
    names = [f"dtheta{j + 1}" for j in range(k)]
    with traced_peak() as peak:
        report = analyse_columns(J, names, np.arange(k) * 5 + 2, 1e-6, "plate")
    assert N * N * 8 > 2**30
    assert peak[0] < 64 * MB, peak[0] / MB
    assert report.rank == k - 1 and len(report.combinations) == 1


# ---- the checks after a fit: leverages from the economic U ------------------------
def test_studentized_residuals_match_the_dense_hat_matrix(plates):
    """Oracle: h_ii = diag(J (J^T J)^-1 J^T) of the column-scaled Jacobian,
    e_i = r_i / sqrt(1 - h_ii), z_i = e_i / s_(i) with s_(i)^2 = (RSS - e_i^2)
    / (dof - 1): the report's z equals it to 1e-9 relative."""
    model, data, est = plates
    problem, x = _problem(est, data)
    report = check_calibration(data, problem, x, est.names_)
    assert report.reference == "calibrated" and report.ok
    r, J = problem.residuals(x), problem.jacobian(x)
    Js = J / np.linalg.norm(J, axis=0)
    H = Js @ np.linalg.solve(Js.T @ Js, Js.T)
    e = r / np.sqrt(1.0 - np.diag(H))
    dof = report.dof
    s_i = np.sqrt((r @ r - e**2) / (dof - 1))
    np.testing.assert_allclose(report.z, e / s_i, rtol=1e-9, atol=0)


def test_calibration_checks_stay_linear(plates):
    """12 000 readings (the 60 repeated): the checks at the calibrated model
    stay under 48 MB above their inputs (an N x N hat matrix: 1.07 GiB)."""
    model, data, est = plates
    big = _tiled(data, 200)
    problem, x = _problem(est, big)
    with traced_peak() as peak:
        report = check_calibration(big, problem, x, est.names_)
    assert report.reference == "calibrated"
    assert peak[0] < 48 * MB, peak[0] / MB


def test_robust_plates_chunked_equal_one_block(plates, monkeypatch):
    """The nominal-model check (deltas out of bounds): the robust plane fits
    drawn and scored in blocks of 1000 values equal those of one block (the
    same triples from the same stream), to 1e-12 m."""
    model, data, est = plates
    big = _tiled(data, 10)  # 120 readings per plate: random triples
    problem, x = _problem(est, big)
    x = x.copy()
    x[0] = 1.0  # 57 deg: beyond the bounds, so the nominal model is used
    one = check_calibration(big, problem, x, est.names_)
    monkeypatch.setattr(sanity, "CHUNK_VALUES", 1000)
    chunked = check_calibration(big, problem, x, est.names_)
    assert one.reference == chunked.reference == "nominal"
    np.testing.assert_allclose(chunked.z, one.z, rtol=0, atol=1e-12)
    assert chunked.reasons == one.reasons


def test_robust_plates_memory_is_bounded(plates):
    """60 000 readings on one plate at the nominal model: the 400 random
    triples' keys, their order and the distances to the 400 planes in one
    block took 390 MB above the inputs; in blocks the whole check stays under
    160 MB (70 MB measured)."""
    model, data, est = plates
    first = data.plane == data.plate_ids[0]
    one = _tiled(data.subset(first), 5000)
    idx = error_parameter_indices(model, est.names_)
    problem = PlaneProblem(model.table, one, idx, est.normals_[:1])
    x = problem.pack(est.deltas_, est.offsets_[:1])
    x[0] = 1.0  # 57 deg: beyond the bounds, so the nominal model is used
    with traced_peak() as peak:
        report = check_calibration(one, problem, x, est.names_)
    assert report.reference == "nominal"
    assert peak[0] < 160 * MB, peak[0] / MB


# ---- the plane and point Jacobians, chunk by chunk --------------------------------
def test_plane_jacobian_chunked_equals_one_block(plates, monkeypatch):
    model, data, est = plates
    problem, x = _problem(est, data)
    one = problem.jacobian(x)
    monkeypatch.setattr(forward, "CHUNK_POSES", 7)
    np.testing.assert_allclose(problem.jacobian(x), one, rtol=0, atol=1e-15)


def test_point_jacobian_chunked_equals_one_block(monkeypatch):
    model = load_robot("rv3sb")
    data = read_point_measurements(DATA / "points_rv3sb_seed1_p20_m2.csv")
    R, p, markers = initial_alignment(model.table, data)
    idx = error_parameter_indices(model, error_parameter_names(model, "paper"))
    problem = PointProblem(model.table, data, idx, R)
    x = problem.pack(1e-3 * np.ones(idx.size), p, markers)
    one = problem.jacobian(x)
    monkeypatch.setattr(forward, "CHUNK_POSES", 7)
    np.testing.assert_allclose(problem.jacobian(x), one, rtol=0, atol=1e-15)


# ---- the volume cost of the DE: only the readings its quadruples use --------------
def test_volume_cost_equals_the_all_readings_oracle(plates):
    """Oracle: the points of every reading, the quadruples' volumes by their
    reading indices; equal to 1e-12 relative for a population of 5."""
    model, data, _ = plates
    idx = error_parameter_indices(model, error_parameter_names(model, "paper"))
    cost = VolumeCost(model.table, data, idx, max_per_plate=30)
    deltas = 1e-3 * np.random.default_rng(1).standard_normal((5, idx.size))
    expected = []
    for d in deltas:
        table = model.table.ravel().copy()
        table[idx] += d
        pts = tool_points(table.reshape(-1, 5), data.q, data.distance)
        A, B, C, D = (pts[cost.quads[:, c]] for c in range(4))
        vol = np.einsum("ij,ij->i", D - A, np.cross(B - A, C - A)) / 6
        expected.append(np.abs(vol).sum())
    np.testing.assert_allclose(cost(deltas), expected, rtol=1e-12, atol=0)


def test_capped_quadruples_are_the_listed_ones_without_the_list():
    """Oracle: itertools' lexicographic list at numpy.linspace's ranks; a
    plate of 10^6 readings (C(m, 4) = 4e22, never listed) takes well under a
    second and its last quadruple is the lexicographic last."""
    m = 40
    listed = np.array(list(itertools.combinations(range(m), 4)))
    pick = np.linspace(0, len(listed) - 1, 30).astype(np.intp)
    plate = np.zeros(m, dtype=int)
    np.testing.assert_array_equal(plate_quadruples(plate, 30), listed[pick])
    big = plate_quadruples(np.zeros(10**6, dtype=int), 30)
    assert big.shape == (30, 4)
    np.testing.assert_array_equal(big[0], [0, 1, 2, 3])
    np.testing.assert_array_equal(big[-1], [999_996, 999_997, 999_998, 999_999])
    assert np.all(np.diff(big, axis=1) > 0)


# ---- greedy D-optimal choice: lazy evaluation, the same choice --------------------
def _eager(B, count, group, quota, regularisation):
    """Oracle: every candidate's gain at every step (the method before the
    lazy evaluation), first candidate on a tie."""
    C, r, u = B.shape
    _, label = np.unique(group, return_inverse=True)
    Minv = np.eye(u) / regularisation
    chosen = np.zeros(C, dtype=bool)
    taken = np.zeros(label.max() + 1, dtype=int)
    for _ in range(count):
        BM = (B.reshape(C * r, u) @ Minv).reshape(C, r, u)
        G = BM @ B.transpose(0, 2, 1)
        gain = np.linalg.slogdet(np.eye(r) + G)[1]
        gain[chosen | (taken[label] >= quota)] = -np.inf
        i = int(np.argmax(gain))
        chosen[i] = True
        taken[label[i]] += 1
        Minv -= BM[i].T @ np.linalg.solve(np.eye(r) + G[i], BM[i])
    return np.flatnonzero(chosen)


@pytest.mark.parametrize(("C", "rows", "chunk"), [(2000, 1, 4096), (300, 3, 5)])
def test_lazy_d_optimal_is_the_eager_choice(C, rows, chunk, monkeypatch):
    """The same chosen set as evaluating every gain at every step; with 5
    candidates per evaluation block too."""
    monkeypatch.setattr(d_optimal, "CHUNK_CANDIDATES", chunk)
    rng = np.random.default_rng(C)
    B = rng.standard_normal((C, rows, 12)) * rng.uniform(0.2, 1.0, (C, 1, 1))
    group = rng.integers(0, 5, C)
    count, quota = C // 8, C // 30
    lazy = d_optimal.greedy_d_optimal(B, count, group=group, quota=quota)
    np.testing.assert_array_equal(lazy, _eager(B, count, group, quota, 1e-6))


# ---- files: written chunk by chunk, the same bytes --------------------------------
def test_measurement_files_are_the_joined_lines(plates, tmp_path, monkeypatch):
    """Oracle: the lines joined by newlines (the writers before the chunks),
    written with 4 lines per chunk; both files read back bit for bit."""
    _, data, _ = plates
    monkeypatch.setattr(atomic, "CHUNK_LINES", 4)
    path = write_plane_measurements(tmp_path / "p.csv", data)
    lines = ["plane,q1,q2,q3,q4,q5,q6,distance"] + [
        ",".join([str(int(p)), *map(repr, q.tolist()), repr(float(d))])
        for p, q, d in zip(data.plane, data.q, data.distance, strict=True)
    ]
    assert path.read_bytes() == ("\n".join(lines) + "\n").encode()
    back = read_plane_measurements(path)
    np.testing.assert_array_equal(back.q, data.q)
    points = read_point_measurements(DATA / "points_rv3sb_seed1_p20_m2.csv")
    monkeypatch.setattr("rmdrake.calibration.points.data.CHUNK_LINES", 3)
    path = write_point_measurements(tmp_path / "m.csv", points)
    again = read_point_measurements(path)
    np.testing.assert_array_equal(again.p_I, points.p_I)
    np.testing.assert_array_equal(again.pose, points.pose)


def test_tracker_poses_chunked_are_the_same_draw(monkeypatch):
    """random_point_poses scores its draws chunk by chunk: the same poses."""
    model = load_robot("rv3sb")
    one = random_point_poses(model, 50, np.random.default_rng(3))
    monkeypatch.setattr(forward, "CHUNK_POSES", 9)
    chunked = random_point_poses(model, 50, np.random.default_rng(3))
    np.testing.assert_array_equal(chunked, one)
