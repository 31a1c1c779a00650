"""Cartesian test paths and their joint programs: the geometry is exact, the
program puts the model's tool on the path, and the duration is the shortest
that keeps the joint velocities and accelerations within the asked fraction
of the limits."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.compensation.paths import PlanarPath, min_jerk, plan_path_program
from rmdrake.kinematics.forward import tool_jacobian, tool_poses
from rmdrake.model.loading import load_robot

Q_CUBE = np.array([0.0, 0.6, 1.0, 0.0, 1.0, 0.0])


def _plane(angle: float = 0.7) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@pytest.mark.parametrize("kind", ["circle", "rectangle"])
def test_path_is_a_closed_planar_curve_parametrised_by_arc_length(kind):
    centre, R = np.array([0.3, -0.1, 0.4]), _plane()
    path = PlanarPath(kind, centre, R, 0.2, aspect=0.6, corner=0.2)
    W, H = 0.2, 0.12
    r = 0.2 * H
    expected = np.pi * W if kind == "circle" else 2 * (W + H) - 8 * r + 2 * np.pi * r
    assert path.length == pytest.approx(expected, rel=1e-12)
    u = np.linspace(0.0, path.length, 20001)
    p = path.points(u)
    np.testing.assert_allclose((p - centre) @ R[:, 2], 0.0, atol=1e-15)  # planar
    np.testing.assert_allclose(p[0], p[-1], atol=1e-15)  # closed
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    # Unit speed in u: chords equal the arc step (to the curvature's second order).
    np.testing.assert_allclose(steps, u[1] - u[0], rtol=1e-6)
    xy = (p - centre) @ R[:, :2]
    assert np.abs(xy[:, 0]).max() == pytest.approx(0.1, abs=1e-12)


def test_bad_paths_are_refused():
    with pytest.raises(ValueError, match="path kind: expected one of circle"):
        PlanarPath("square", np.zeros(3), np.eye(3), 0.1)
    with pytest.raises(ValueError, match="path size"):
        PlanarPath("circle", np.zeros(3), np.eye(3), -0.1)
    with pytest.raises(ValueError, match="rotation matrix"):
        PlanarPath("circle", np.zeros(3), 2 * np.eye(3), 0.1)


def test_min_jerk_starts_and_ends_at_rest():
    s = np.array([0.0, 1e-4, 0.5, 1.0 - 1e-4, 1.0])
    f = min_jerk(s)
    assert f[0] == 0.0 and f[-1] == 1.0 and f[2] == pytest.approx(0.5)
    assert f[1] < 1e-10 and 1.0 - f[3] < 1e-10


# The boom arm (prismatic joints 1 and 4, m) mid-column, boom half out and
# 70 degrees off the column (sigma_min of the tool Jacobian 0.11).
Q_BOOM = np.array([0.4, 0.3, -1.0, 0.3, 0.8, 0.2])


def _setup(robot: str, request) -> tuple:
    """(model, q_seed, plane R_BP) of a test: the RV-3SB's tilted plane; on the
    boom arm the plane of its two slide axes z_1 and z_4 at Q_BOOM, where the
    path needs the slides only (the revolute joints keep their angles)."""
    if robot == "rv3sb":
        return load_robot("rv3sb"), Q_CUBE, _plane()
    model = request.getfixturevalue(robot)
    J = tool_jacobian(model.table, Q_BOOM[None], sigma=model.sigma)[0]
    e1, e2 = np.linalg.qr(J[3:, [0, 3]])[0].T  # prismatic columns: [0; z_j]
    return model, Q_BOOM, np.column_stack([e1, e2, np.cross(e1, e2)])


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
@pytest.mark.parametrize("kind", ["circle", "rectangle"])
def test_program_follows_the_path_within_the_limits(kind, robot, request):
    """The tool follows the path (position and fixed orientation) between the
    knots; the duration uses exactly half of the limits (rad/s or m/s,
    rad/s^2 or m/s^2 for the boom arm's prismatic joints)."""
    model, q_seed, R_BP = _setup(robot, request)
    X = tool_poses(model.table, q_seed[None], sigma=model.sigma)[0]
    path = PlanarPath(kind, X[:3, 3], R_BP, 0.2)
    program = plan_path_program(model, path, X[:3, :3], q_seed=q_seed, speed=0.5)
    if robot == "boom":  # in the slides' plane only the slides move
        revolute = model.sigma == 0
        knots = program.knots[:, revolute]
        assert np.abs(knots - q_seed[revolute]).max() <= 1e-8
        assert np.ptp(program.knots[:, ~revolute], axis=0).min() > 0.05
    T = program.duration
    t = np.linspace(0.0, T, 3001)
    q = program.trajectory.vector_values(t).T
    assert np.all((q >= model.limits.lower) & (q <= model.limits.upper))
    X_t = tool_poses(model.table, q, sigma=model.sigma)
    # The spline between knots: within 1 um of the path (0.3 um measured).
    e = np.linalg.norm(X_t[:, :3, 3] - program.tool_points(t), axis=1)
    assert e.max() < 1e-6
    R_err = np.einsum("ij,kil->kjl", X[:3, :3], X_t[:, :3, :3])
    angle = np.arccos(np.clip((np.trace(R_err, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert angle.max() < 1e-5
    # The duration is the shortest within half the limits: one bound is active.
    qd = program.trajectory.MakeDerivative(1).vector_values(t).T
    qdd = program.trajectory.MakeDerivative(2).vector_values(t).T
    lim = model.limits
    use = max((np.abs(qd) / lim.velocity).max(), (np.abs(qdd) / lim.acceleration).max())
    assert 0.49 < use <= 0.5 * (1 + 1e-3)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)
    assert program.peak_tool_speed == pytest.approx(1.875 * path.length / T)


def test_unreachable_path_and_bad_speed_are_named():
    model = load_robot("rv3sb")
    X = tool_poses(model.table, Q_CUBE[None])[0]
    far = PlanarPath("circle", X[:3, 3], _plane(), 3.0)
    with pytest.raises(ValueError, match="path circle: .* unreachable"):
        plan_path_program(model, far, X[:3, :3], q_seed=Q_CUBE, speed=0.5)
    near = PlanarPath("circle", X[:3, 3], _plane(), 0.1)
    with pytest.raises(ValueError, match=r"speed: expected a fraction in \(0, 1\]"):
        plan_path_program(model, near, X[:3, :3], q_seed=Q_CUBE, speed=1.5)
