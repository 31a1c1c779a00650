"""Socket calibration (a ball on the tool seated in sockets at unknown places,
MUKCa's method) on simulated data, against known truth: the simulator's
geometry, the analytic Jacobian against finite differences, exact recovery of
the ball's positions from noise-free data, the held-out error against the
seating noise, the reported std against the spread over noise draws; the file
format, MUKCa's folder layout and the data the fit refuses.

Robots: the RV-3SB and MUKCa's 7-joint Panda (its tool point the ball's
centre); the true robot is the nominal perturbed by 0.3 mm / 0.3 mrad.
Sockets cannot see the base frame's pose (the socket points absorb it), so a
model's ball positions are compared with the truth's after the best rigid
alignment of one set onto the other."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import SHARED_DATA

from rmdrake.calibration.points.simulate import random_point_poses
from rmdrake.calibration.sockets.data import (
    SocketMeasurements,
    read_mukca_sockets,
    read_socket_measurements,
    write_socket_measurements,
)
from rmdrake.calibration.sockets.lm import SocketLM, analyse_socket_identifiability
from rmdrake.calibration.sockets.problem import SocketProblem
from rmdrake.calibration.sockets.simulate import simulate_sockets
from rmdrake.kinematics.compare import rigid_alignment
from rmdrake.kinematics.forward import tool_points
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.model.error_parameters import (
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.model.urdf.importer import robot_from_urdf

MUKCA = SHARED_DATA / "mukca_panda"
NO_MUKCA = f"the MUKCa Panda data are not in {MUKCA}"
NOISE = 2e-5
"""Seating noise of the issue's target, m per coordinate."""
ROBOTS = [
    "rv3sb",
    pytest.param(
        "panda", marks=pytest.mark.skipif(not MUKCA.is_dir(), reason=NO_MUKCA)
    ),
]


def _nominal(name: str):
    if name == "rv3sb":
        return load_robot("rv3sb")
    with warnings.catch_warnings():  # lumped fingers, no masses: expected
        warnings.simplefilter("ignore")
        return robot_from_urdf(
            MUKCA / "panda.urdf", base="panda_link0", tip="ball_link",
            exclude=["panda_leftfinger", "panda_rightfinger"],
        )  # fmt: skip


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    """(nominal, the names the ``full`` preset keeps on noise-free data of
    seed 3, true robot perturbed on every MDH parameter, true robot perturbed
    on those names only, 200 held-out configurations)."""
    nominal = _nominal(request.param)
    probe = simulate_sockets(nominal, noise=0, seed=3).data
    names = SocketLM(nominal, params="full").fit(probe).names_
    errors = {"length_std": 3e-4, "angle_std": 3e-4, "seed": 1}
    true, _ = perturb_robot(nominal, params="full", **errors)
    true_id, _ = perturb_robot(nominal, params=names, **errors)
    held = random_point_poses(nominal, 200, np.random.default_rng(99))
    return nominal, names, true, true_id, held


def _aligned_errors(model, true, q) -> np.ndarray:
    """(len(q),) 3-D distances between ``model``'s ball positions, rigidly
    aligned onto ``true``'s, and ``true``'s, m."""
    a = tool_points(model.table, q, sigma=model.sigma)
    b = tool_points(true.table, q, sigma=true.sigma)
    X = rigid_alignment(a, b)
    return np.linalg.norm(a @ X[:3, :3].T + X[:3, 3] - b, axis=1)


def _aligned_rms(model, true, q) -> float:
    """RMS over q of :func:`_aligned_errors`, m."""
    return float(np.sqrt(np.mean(_aligned_errors(model, true, q) ** 2)))


# ---- the simulator ------------------------------------------------------------
@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_simulated_geometry(noise):
    """Sockets numbered 2p, 2p+1 and exactly ``distance`` apart; each row's
    ball (forward kinematics of the recorded q, an independent evaluation) is
    off its socket by the seating noise: a sample std within 10 % of it (600
    coordinates), or below the IK tolerance without noise; q within the
    limits; the same seed gives the same bytes, another seed other data."""
    model = load_robot("rv3sb")
    sim = simulate_sockets(model, placements=4, per_socket=25, noise=noise, seed=4)
    d = sim.data
    assert d.n_rows == 200 and d.n_placements == 4
    np.testing.assert_array_equal(d.socket, np.repeat(np.arange(8), 25))
    np.testing.assert_array_equal(d.distances[:, :2], [[0, 1], [2, 3], [4, 5], [6, 7]])
    gaps = np.linalg.norm(sim.sockets[0::2] - sim.sockets[1::2], axis=1)
    np.testing.assert_allclose(gaps, 0.05, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(d.distances[:, 2], 0.05)
    offsets = tool_points(model.table, d.q, sigma=model.sigma) - sim.sockets[d.socket]
    if noise:
        assert abs(np.std(offsets) / noise - 1) < 0.1
    else:
        assert np.abs(offsets).max() < 1e-9
    assert np.all((d.q >= model.limits.lower) & (d.q <= model.limits.upper))
    again = simulate_sockets(model, placements=4, per_socket=25, noise=noise, seed=4)
    assert again.data.q.tobytes() == d.q.tobytes()
    assert again.sockets.tobytes() == sim.sockets.tobytes()
    other = simulate_sockets(model, placements=4, per_socket=25, noise=noise, seed=5)
    assert np.abs(other.sockets - sim.sockets).max() > 0.01
    assert "200 configurations: 4 placements x 2 sockets" in sim.summary()


def test_unreachable_socket_is_one_line():
    """Joint ranges of +-0.01 rad: the plate's second socket, 50 mm away, is
    out of reach in every direction from every plate drawn (the first socket,
    the ball's position at a random configuration, is seated: the
    conditioning is off, the ranges are too small for it)."""
    model = load_robot("rv3sb")
    mid = 0.5 * (model.limits.lower + model.limits.upper)
    limits = dataclasses.replace(model.limits, lower=mid - 0.01, upper=mid + 0.01)
    small = dataclasses.replace(model, limits=limits)
    with pytest.raises(ValueError) as e:
        simulate_sockets(small, placements=1, per_socket=5, seed=0, min_singular=0)
    assert str(e.value).startswith(
        "placement 0: socket 1, 0.05 m from socket 0: at most 0 of 5 seated"
    )
    assert "\n" not in str(e.value)


# ---- the fit -----------------------------------------------------------------
@pytest.mark.parametrize("robot_name", ROBOTS)
def test_jacobian_matches_finite_differences(robot_name):
    """SocketProblem.jacobian against central differences (h = 1e-6, every
    parameter and socket coordinate), distances included, away from the
    start (random deltas of 1e-2, socket points moved by 1 cm)."""
    model = _nominal(robot_name)
    data = simulate_sockets(model, placements=2, per_socket=6, noise=1e-4, seed=2)
    idx = error_parameter_indices(model, error_parameter_names(model, "full"))
    problem = SocketProblem(model.table, data.data, idx, sigma=model.sigma, weight=3.0)
    rng = np.random.default_rng(0)
    x = problem.start(1e-2 * rng.standard_normal(idx.size))
    x[idx.size :] += 1e-2 * rng.standard_normal(x.size - idx.size)
    J = problem.jacobian(x)
    assert J.shape == (3 * data.data.n_rows + 2, x.size)
    h, fd = 1e-6, np.empty_like(J)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        fd[:, i] = (problem.residuals(x + e) - problem.residuals(x - e)) / (2 * h)
    assert np.abs(J - fd).max() <= 1e-6 * np.abs(J).max()
    assert np.abs(J[-2:]).max() > 1.0  # the distance rows are there


def test_noise_free_recovers_the_ball_positions(robot):
    """Noise-free seating, ``full``: the calibrated model's ball positions at
    200 held-out configurations equal the truth's to 1e-8 m after rigid
    alignment. The truth is perturbed on the parameters ``full`` keeps: the
    others are absorbed only to first order, or not at all when ``full``
    leaves a weakly seen one out (perturbed on all, the RV-3SB is left 2e-7 m
    off, the Panda 1e-6 m)."""
    nominal, names, _, true_id, held = robot
    sim = simulate_sockets(true_id, noise=0, seed=3)
    est = SocketLM(nominal, params="full").fit(sim.data)
    assert est.names_ == names
    assert _aligned_rms(est.model_, true_id, held) < 1e-8
    assert _aligned_rms(nominal, true_id, held) > 1e-4  # there was an error


def test_held_out_error_meets_the_target(robot):
    """The issue's target: 4 placements x 2 sockets x 25 configurations, 0.02
    mm seating noise per coordinate, ``full``: the held-out 3-D ball error
    after rigid alignment, averaged over the held-out configurations and over
    5 simulations (seeds 0-4: the placements and the noise differ), <= 2x the
    noise (the points' target is stated the same way); no simulation over 5x
    (a tail: with 4 placements one draw in 20 reaches 4x on the Panda); the
    nominal is far beyond it."""
    nominal, _, true, _, held = robot
    means = []
    for seed in range(5):
        sim = simulate_sockets(true, noise=NOISE, seed=seed)
        est = SocketLM(nominal, params="full", noise=NOISE).fit(sim.data)
        assert est.sanity_.reasons == ()
        means.append(_aligned_errors(est.model_, true, held).mean())
    assert np.mean(means) <= 2 * NOISE and max(means) <= 5 * NOISE, means
    assert _aligned_errors(nominal, true, held).mean() > 10 * NOISE


def test_std_matches_the_spread_over_noise_draws(robot):
    """60 noise draws on the same placements and configurations (each row
    seated again by IK from its noise-free configuration at the socket plus a
    new seating error): for every identifiable parameter, the std of its
    estimate over the draws / the RMS of its reported std_ is in 0.7-1.4 (the
    parameters ``full`` keeps, named: the same for every draw).
    (With 20 draws the ratio's own sampling error is 16 %: 'every parameter
    in 0.7-1.4' then fails by chance on most blocks of 20 draws; with 60 it
    is 9 %.)"""
    nominal, names, true, _, _ = robot
    clean = simulate_sockets(true, noise=0, seed=3)
    d = clean.data
    rng = np.random.default_rng(11)
    values, stds = [], []
    for _ in range(60):
        target = clean.p_B + NOISE * rng.standard_normal(clean.p_B.shape)
        ik = solve_tool_ik(true, d.q, target)
        assert ik.residual.max() < 1e-9
        data = SocketMeasurements(d.socket, ik.q, d.distances)
        est = SocketLM(nominal, params=names).fit(data)
        values.append(est.deltas_)
        stds.append(est.std_)
    ratio = np.std(values, axis=0, ddof=1) / np.sqrt(np.mean(np.square(stds), 0))
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio.round(2)


# ---- data --------------------------------------------------------------------
def test_write_read_round_trip(tmp_path):
    sim = simulate_sockets(load_robot("rv3sb"), placements=2, per_socket=5, seed=1)
    path = write_socket_measurements(tmp_path / "s.csv", sim.data)
    assert (tmp_path / "s_distances.csv").is_file()
    back = read_socket_measurements(path, 6)
    assert back.q.tobytes() == sim.data.q.tobytes()
    np.testing.assert_array_equal(back.socket, sim.data.socket)
    assert back.distances.tobytes() == sim.data.distances.tobytes()


@pytest.mark.skipif(not MUKCA.is_dir(), reason=NO_MUKCA)
def test_read_mukca_folder():
    data, names = read_mukca_sockets(MUKCA / "panda_2_clean")
    assert len(names) == 8 and names == sorted(names) and names[0] == "back_left"
    assert data.n_placements == 8 and data.n_rows == 497 and data.n_joints == 7
    np.testing.assert_array_equal(data.socket_ids, np.arange(16))
    np.testing.assert_array_equal(data.distances[:, 2], 0.05)
    np.testing.assert_array_equal(data.distances[:, :2], np.arange(16).reshape(8, 2))


def test_too_few_rows_are_refused():
    """A socket with one row; a placement with 4 rows for its 6 unknowns."""
    model = load_robot("rv3sb")
    data = simulate_sockets(model, placements=3, per_socket=6, seed=2).data
    one = np.flatnonzero(data.socket == 3)[1:]
    with pytest.raises(ValueError, match="^socket 3 has 1 row"):
        SocketLM(model, params="offsets").fit(data.subset(~np.isin(np.arange(36), one)))
    few = np.flatnonzero(data.placement == 1)
    few = few[~np.isin(few, few[[0, 1, 6, 7]])]  # 2 rows left per socket
    with pytest.raises(ValueError, match="sockets 2, 3 has 4 configurations for the 6"):
        SocketLM(model, params="offsets").fit(data.subset(~np.isin(np.arange(36), few)))


def _moved_row(robot):
    """(nominal, data with one row of socket 2 seated 5 mm off it, the row)."""
    nominal, _, true, _, _ = robot
    sim = simulate_sockets(true, noise=NOISE, seed=0)
    d = sim.data
    row = int(np.flatnonzero(d.socket == 2)[7])
    ik = solve_tool_ik(true, d.q[[row]], sim.p_B[[row]] + [[3e-3, 0.0, 4e-3]])
    assert ik.residual[0] < 1e-9
    q = d.q.copy()
    q[row] = ik.q[0]
    return nominal, SocketMeasurements(d.socket, q, d.distances), row


def test_row_moved_5_mm_is_refused_as_gross(robot):
    """One row of socket 2 seated 5 mm off it (as a row recorded at another
    socket): the fit's sanity refuses it, naming it."""
    nominal, bad, row = _moved_row(robot)
    est = SocketLM(nominal, params="full", noise=NOISE).fit(bad)
    assert len(est.sanity_.reasons) >= 1
    assert est.sanity_.reasons[0].startswith("1 configuration(s) over 20 noise")
    assert f"row {row + 1} (socket 2, " in est.sanity_.reasons[0]


def test_drop_outliers_drops_the_moved_row_only(robot):
    nominal, bad, row = _moved_row(robot)
    est = SocketLM(nominal, params="full", noise=NOISE, drop_outliers=True).fit(bad)
    np.testing.assert_array_equal(est.dropped_, [row])
    assert est.sanity_.reasons == ()


def test_what_sockets_cannot_see_is_named():
    """The base frame's pose is absorbed by the socket points (dd1, dr1 and
    the rotations of row 1: columns exactly in their span once the rotation
    nuisance is added); without a known distance one length more goes, as the
    length scale; with the distances, it is kept."""
    model = load_robot("rv3sb")
    data = simulate_sockets(model, noise=0, seed=2).data
    names = error_parameter_names(model, "full")
    seen = analyse_socket_identifiability(model, data, names)
    for name in ("dd1", "dr1", "dtheta1"):
        assert "absorbed by the unknown socket points" in seen.dropped[name]
    blind = SocketMeasurements(data.socket, data.q)  # no known distance
    unscaled = analyse_socket_identifiability(model, blind, names)
    assert unscaled.rank == seen.rank - 1
    lost = set(seen.identifiable) - set(unscaled.identifiable)
    assert len(lost) == 1 and next(iter(lost))[:2] in ("dd", "dr")
    assert "length scale" in unscaled.dropped[next(iter(lost))]
