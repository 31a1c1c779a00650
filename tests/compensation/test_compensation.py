"""Joint-target correction on a calibrated model: convergence, the Drake plant as
the oracle, program filtering, unreachable targets, joint limits, bad inputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from rmdrake.compensation.correction import (
    correct_path,
    correct_targets,
    filter_program,
    rotation_from_rpy,
    rpy_from_rotation,
)
from rmdrake.kinematics.forward import point_jacobian, tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import TOOL_FRAME, MakePlant
from rmdrake.model.robot import JointLimits, RobotModel

TOL = 1e-9  # m and rad: what every correction below must reach
MAX_ITERATIONS_FROM_5MM = 5  # Newton steps from a 5 mm error (3 are typical)


def lever_points(model: RobotModel, q: np.ndarray) -> np.ndarray:
    """(N, 9) points p_E, p_E + 0.1 z_E, p_E + 0.1 x_E in B, m."""
    X = tool_poses(model.table, q)
    p = X[:, :3, 3]
    return np.hstack([p, p + 0.1 * X[:, :3, 2], p + 0.1 * X[:, :3, 0]])


def lever_jacobian(model: RobotModel, q: np.ndarray) -> np.ndarray:
    """(N, 9, n) d lever_points / dq: theta columns of point_jacobian (the x
    point from a table with one more row Rot_y(pi/2), whose z axis is x_E)."""
    n = model.n_joints
    theta = np.arange(n) * 5 + 2
    x_table = np.vstack([model.table, [0.0, 0.0, 0.0, 0.0, np.pi / 2]])
    q_x = np.hstack([q, np.zeros((q.shape[0], 1))])
    return np.concatenate(
        [
            point_jacobian(model.table, q, theta),
            point_jacobian(model.table, q, theta, 0.1),
            point_jacobian(x_table, q_x, theta, 0.1),
        ],
        axis=1,
    )


def well_conditioned_poses(model, rng, count, sigma_min=0.02):
    """Joint angles in the middle 80 % of the ranges whose pose Jacobian has a
    smallest singular value >= sigma_min (m/rad): away from singularities,
    where a mm of calibration error can take a pose out of reach."""
    lo, hi = model.limits.lower, model.limits.upper
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (20 * count, 6))
    sigma = np.linalg.svd(lever_jacobian(model, q), compute_uv=False)[:, -1]
    q = q[sigma >= sigma_min][:count]
    assert q.shape[0] == count
    return q


def calibrated_robot(nominal, rng, q, rms_error):
    """Nominal + random deltas on the paper's 17 parameters, scaled so that the
    RMS tool position error over the poses q is ``rms_error`` (m)."""
    names = error_parameter_names(nominal, "paper")
    deltas = rng.standard_normal(len(names))
    p_nom = tool_poses(nominal.table, q)[:, :3, 3]

    def rms(scale):
        p = tool_poses(apply_deltas(nominal, names, scale * deltas).table, q)
        return np.sqrt(np.mean(np.sum((p[:, :3, 3] - p_nom) ** 2, axis=1)))

    return apply_deltas(nominal, names, rms_error / rms(1e-3) * 1e-3 * deltas)


@pytest.fixture
def case(rv3sb, rng):
    """Nominal RV-3SB, 40 well-conditioned poses, a calibrated robot 5 mm RMS
    away from the nominal at those poses."""
    q = well_conditioned_poses(rv3sb, rng, 40)
    return rv3sb, calibrated_robot(rv3sb, rng, q, 5e-3), q


def initial_error(nominal, calibrated, q):
    X_nom, X_cal = tool_poses(nominal.table, q), tool_poses(calibrated.table, q)
    return np.linalg.norm(X_cal[:, :3, 3] - X_nom[:, :3, 3], axis=1)


@pytest.mark.parametrize("pose", [False, True], ids=["position", "pose"])
def test_converges_from_5mm_in_a_few_iterations(case, pose):
    nominal, calibrated, q = case
    e0 = initial_error(nominal, calibrated, q)
    assert 4e-3 < np.sqrt(np.mean(e0**2)) < 6e-3  # the scenario: 5 mm RMS
    X = tool_poses(nominal.table, q)
    c = correct_targets(
        calibrated, X[:, :3, 3], q_seed=q, orientation=X[:, :3, :3] if pose else None
    )
    assert c.reachable.all() and not c.at_limit.any()
    assert c.position_residual.max() <= TOL
    assert (c.orientation_residual is None) == (not pose)
    if pose:
        assert c.orientation_residual.max() <= TOL
    assert c.iterations.max() <= MAX_ITERATIONS_FROM_5MM


@pytest.mark.parametrize("pose", [False, True], ids=["position", "pose"])
def test_perfect_calibration_puts_the_true_drake_tool_on_the_targets(case, pose):
    """Oracle: calibrated == true; the joints are checked on the true robot's
    Drake plant (CalcRelativeTransform of the tool frame), not our kinematics."""
    nominal, true, q = case
    q = q[:15]
    X = tool_poses(nominal.table, q)
    R = X[:, :3, :3]
    c = correct_targets(true, X[:, :3, 3], q_seed=q, orientation=R if pose else None)
    plant, _ = MakePlant(true, visual=False)
    context = plant.CreateDefaultContext()
    tool = plant.GetFrameByName(TOOL_FRAME)
    for k in range(q.shape[0]):
        plant.SetPositions(context, c.q[k])
        X_drake = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
        assert np.linalg.norm(X_drake.translation() - X[k, :3, 3]) <= TOL
        if pose:
            R_err = RotationMatrix(R[k]).inverse() @ X_drake.rotation()
            assert abs(R_err.ToAngleAxis().angle()) <= TOL


def test_filtering_reproduces_the_nominal_tool_poses(case):
    """Calibrated tool at the filtered program == nominal tool at the nominal
    program. The corrections dq are of the size of the calibration error e (the
    lever points' offset at q_nominal): J dq = -e up to the Taylor remainder,
    at most sqrt(3)/2 (reach + lever) |dq|_1^2 for the 3 points, since every
    second derivative d2p/dq_i dq_j = z_i x (z_j x (p - o_j)) is bounded by
    the point's distance from the axes."""
    nominal, calibrated, q = case
    f = filter_program(nominal, calibrated, q)
    X_nom = tool_poses(nominal.table, q)
    X_cal = tool_poses(calibrated.table, f.q)
    assert np.linalg.norm(X_cal[:, :3, 3] - X_nom[:, :3, 3], axis=1).max() <= TOL
    for k in range(q.shape[0]):
        R_err = RotationMatrix(X_nom[k, :3, :3]).inverse() @ RotationMatrix(
            X_cal[k, :3, :3]
        )
        assert abs(R_err.ToAngleAxis().angle()) <= TOL
    assert f.correction.reachable.all()
    assert np.array_equal(f.dq, f.q - q)
    assert np.array_equal(f.max_dq, np.abs(f.dq).max(axis=0))
    e = lever_points(calibrated, q) - lever_points(nominal, q)
    linear = np.einsum("mij,mj->mi", lever_jacobian(calibrated, q), f.dq) + e
    reach = np.abs(calibrated.table[:, [1, 3]]).sum() + 0.1
    bound = np.sqrt(3) / 2 * reach * np.abs(f.dq).sum(axis=1) ** 2
    assert np.all(np.linalg.norm(linear, axis=1) <= bound)
    # and dq is no larger than the error through the smallest gain of J (no
    # jump to another branch): |J dq| ~ |e| and |J dq| >= sigma_min |dq|.
    J = lever_jacobian(nominal, q)
    sigma_min = np.linalg.svd(J, compute_uv=False)[:, -1]
    size = np.linalg.norm(f.dq, axis=1)
    assert np.all(size <= 2 * np.linalg.norm(e, axis=1) / sigma_min)


def test_unreachable_target_is_named_and_the_others_are_solved(case):
    nominal, calibrated, q = case
    X = tool_poses(nominal.table, q[:10])
    p = X[:, :3, 3].copy()
    reach = np.abs(nominal.table[:, [1, 3]]).sum()  # every point is within this
    p[4] *= (reach + 0.3) / np.linalg.norm(p[4])
    for R in (None, X[:, :3, :3]):
        c = correct_targets(calibrated, p, q_seed=q[:10], orientation=R)
        assert c.unreachable.tolist() == [4]
        assert c.position_residual[4] >= 0.3
        others = np.arange(10) != 4
        assert c.position_residual[others].max() <= TOL
        line = c.summary().splitlines()[1]
        assert (
            "target 5 of 10 (index 4): unreachable" in line
            and f"{c.position_residual[4]:.6g} m" in line
        )


def test_joint_limits_are_respected(case):
    """Targets that need a joint 0.15 rad past a limit: the solution stays on
    the limit, is flagged, and the target is reported unreachable."""
    nominal, calibrated, q = case
    lo, hi = calibrated.limits.lower, calibrated.limits.upper
    q_out = np.repeat(q[:1], 4, axis=0)
    for k, (j, past) in enumerate([(1, hi[1] + 0.15), (2, lo[2] - 0.15)]):
        q_out[k, j] = past
    X = tool_poses(calibrated.table, q_out)
    c = correct_targets(
        calibrated, X[:, :3, 3], q_seed=np.clip(q_out, lo, hi), orientation=X[:, :3, :3]
    )
    assert np.all((c.q >= lo) & (c.q <= hi))
    assert c.at_limit.tolist() == [True, True, False, False]
    assert c.unreachable.tolist() == [0, 1]
    assert c.position_residual[2:].max() <= TOL


def test_path_is_warm_started_and_continuous(case):
    """A 200-target tool path (0.3 mm steps): seeded by the extrapolation of
    the two previous solutions, each target from the third on converges in at
    most two steps (one, mostly), and the joints move smoothly."""
    nominal, calibrated, _ = case
    qa = np.array([0.3, 0.2, 1.2, 0.4, 0.9, 0.1])
    qb = np.array([0.1, 0.3, 1.1, 0.2, 1.0, 0.3])
    q_nom = qa + np.linspace(0.0, 1.0, 200)[:, None] * (qb - qa)
    X = tool_poses(nominal.table, q_nom)
    c = correct_path(calibrated, X[:, :3, 3], q_start=qa, orientation=X[:, :3, :3])
    assert c.reachable.all() and c.position_residual.max() <= TOL
    assert c.orientation_residual.max() <= TOL
    assert c.iterations[2:].max() <= 2
    step = np.abs(np.diff(c.q, axis=0)).max()
    assert step <= 2 * np.abs(np.diff(q_nom, axis=0)).max()
    batch = correct_targets(
        calibrated, X[:, :3, 3], q_seed=q_nom, orientation=X[:, :3, :3]
    )
    np.testing.assert_allclose(c.q, batch.q, rtol=0, atol=1e-8)


def test_one_target_agrees_with_the_batch(case):
    """M = 1 runs on the plain-float kinematics; it must agree with the batch."""
    nominal, calibrated, q = case
    X = tool_poses(nominal.table, q[:5])
    batch = correct_targets(
        calibrated, X[:, :3, 3], q_seed=q[:5], orientation=X[:, :3, :3]
    )
    for k in range(5):
        one = correct_targets(
            calibrated,
            X[k : k + 1, :3, 3],
            q_seed=q[k : k + 1],
            orientation=X[k : k + 1, :3, :3],
        )
        np.testing.assert_allclose(one.q[0], batch.q[k], rtol=0, atol=1e-10)
        assert one.position_residual[0] <= TOL and one.orientation_residual[0] <= TOL


def test_point_motion_map_agrees_with_the_batch(case):
    """A controller's one-point map (plain floats, no report) equals motion_map
    on the same points: joints to 1e-10 rad, rate maps to 1e-9."""
    from rmdrake.compensation.correction import motion_map, point_motion_map

    nominal, calibrated, q = case
    filtered, A = motion_map(nominal, calibrated, q[:5])
    assert np.abs(filtered.dq).max() > 1e-3  # a real, 5 mm-sized correction
    for k in range(5):
        q_c, A_k = point_motion_map(nominal, calibrated, q[k], q[k])
        np.testing.assert_allclose(q_c, filtered.q[k], rtol=0, atol=1e-10)
        np.testing.assert_allclose(A_k, A[k], rtol=0, atol=1e-9)


def test_roll_pitch_yaw_is_drakes(rng):
    rpy = rng.uniform(-np.pi, np.pi, (50, 3))
    rpy[:, 1] /= 2.2  # pitch inside (-pi/2, pi/2), away from gimbal lock
    R = rotation_from_rpy(rpy)
    for k in range(50):
        R_drake = RollPitchYaw(rpy[k]).ToRotationMatrix().matrix()
        # numpy against Drake, each with its own libm: a few ulp of 1.
        np.testing.assert_allclose(R[k], R_drake, rtol=0, atol=1e-14)
        back = RollPitchYaw(RotationMatrix(R[k])).vector()
        np.testing.assert_allclose(rpy_from_rotation(R[k : k + 1])[0], back, atol=1e-12)
    np.testing.assert_allclose(rpy_from_rotation(R), rpy, rtol=0, atol=1e-12)
    # Orientation given as roll-pitch-yaw == given as matrices.
    X = RigidTransform(RollPitchYaw(rpy[0]), [0.3, 0.1, 0.5]).GetAsMatrix4()
    assert np.allclose(rotation_from_rpy(rpy[:1])[0], X[:3, :3], atol=1e-14)


def five_joint(model: RobotModel) -> RobotModel:
    keys = ("lower", "upper", "velocity", "acceleration", "effort")
    limits = JointLimits(**{k: getattr(model.limits, k)[:5] for k in keys})
    return dataclasses.replace(
        model, mdh=model.mdh[:5], limits=limits, dynamics=None, sigma=model.sigma[:5]
    )


def test_bad_inputs_are_one_line_errors(case):
    nominal, cal, q = case
    X = tool_poses(nominal.table, q[:3])
    p, R, q3 = X[:, :3, 3], X[:, :3, :3], q[:3]
    nan_p, nan_q = p.copy(), q3.copy()
    nan_p[1, 2], nan_q[2, 0] = np.nan, np.nan
    bad_R = R.copy()
    bad_R[0] *= 1.01
    fix, one = correct_targets, correct_path
    cases = [
        (lambda: filter_program(nominal, five_joint(cal), q), "5 joints"),
        (lambda: filter_program(nominal, cal, nan_q), "q_nominal: expected finite"),
        (lambda: filter_program(nominal, cal, q[:0]), "q_nominal: expected at least"),
        (lambda: fix(cal, nan_p, q_seed=q3), "targets: expected finite"),
        (lambda: fix(cal, p, q_seed=nan_q), "q_seed: expected finite"),
        (lambda: fix(cal, p[:, :2], q_seed=q3), "targets: expected shape"),
        (lambda: fix(cal, p, q_seed=q[:4]), r"q_seed: expected shape \(3, 6\)"),
        (lambda: fix(cal, p[:0], q_seed=q[:0]), "at least one target"),
        (lambda: fix(cal, p, q_seed=q3, orientation=R[:, :2]), "orientation: exp"),
        (lambda: fix(cal, p, q_seed=q3, orientation=bad_R), "0 is not a rotation"),
        (lambda: one(cal, p, q_start=q[:2]), r"q_start: expected shape \(6,\)"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message) as info:
            call()
        assert "\n" not in str(info.value)


def test_corrected_motion_moves_the_calibrated_tool_as_the_nominal_one():
    """Away from singularities: the calibrated tool pose at q_c equals the
    nominal tool pose at q (1e-9 m, rad), the tool twists are equal (1e-9), and
    qd_c is the time derivative of q_c along a path (finite differences)."""
    from rmdrake.compensation.correction import correct_joint_motion
    from rmdrake.kinematics.forward import tool_jacobian

    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    rng = np.random.default_rng(7)
    calibrated = apply_deltas(nominal, names, 1e-3 * rng.standard_normal(len(names)))
    h = 1e-3
    t = np.arange(0.0, 0.5, h)
    q0 = np.array([0.2, 0.3, 0.8, 0.4, 0.9, -0.3])  # wrist well away from q5 = 0
    q = q0 + 0.2 * np.sin(np.outer(t, [1.0, 1.3, 0.7, 1.1, 0.9, 1.7]))
    qd = (
        0.2
        * np.cos(np.outer(t, [1.0, 1.3, 0.7, 1.1, 0.9, 1.7]))
        * [1.0, 1.3, 0.7, 1.1, 0.9, 1.7]
    )
    filtered, qd_c, qdd_c = correct_joint_motion(nominal, calibrated, q, qd, 0 * qd)
    X_n, X_c = tool_poses(nominal.table, q), tool_poses(calibrated.table, filtered.q)
    assert np.abs(X_c[:, :3, 3] - X_n[:, :3, 3]).max() < 1e-9
    assert np.abs(X_c[:, :3, :3] - X_n[:, :3, :3]).max() < 1e-9
    twist_n = np.einsum("mij,mj->mi", tool_jacobian(nominal.table, q), qd)
    twist_c = np.einsum("mij,mj->mi", tool_jacobian(calibrated.table, filtered.q), qd_c)
    assert np.abs(twist_c - twist_n).max() < 1e-9
    fd = np.gradient(filtered.q, h, axis=0)[1:-1]
    assert np.abs(fd - qd_c[1:-1]).max() < 1e-6  # O(h^2) central differences
    assert 1e-4 < np.abs(filtered.q - q).max() < 1e-2  # a real, mm-sized correction


def test_multistart_inverse_kinematics_needs_no_seed():
    """Poses of random configurations within the limits are reached from the
    fixed seeds alone (1e-9 m, rad), within the limits, the same on every call."""
    from rmdrake.compensation.correction import inverse_kinematics

    model = load_robot("rv3sb")
    rng = np.random.default_rng(11)
    lo, hi = model.limits.lower, model.limits.upper
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (20, 6))
    q[:, 4] = np.where(np.abs(q[:, 4]) < 0.3, 0.6, q[:, 4])  # wrist not singular
    X = tool_poses(model.table, q)
    ik = inverse_kinematics(model, X[:, :3, 3], orientation=X[:, :3, :3])
    assert ik.reachable.all()
    X_ik = tool_poses(model.table, ik.q)
    assert np.abs(X_ik[:, :3, 3] - X[:, :3, 3]).max() < 1e-9
    assert np.abs(X_ik[:, :3, :3] - X[:, :3, :3]).max() < 1e-9
    assert np.all((ik.q >= lo) & (ik.q <= hi))
    again = inverse_kinematics(model, X[:, :3, 3], orientation=X[:, :3, :3])
    np.testing.assert_array_equal(again.q, ik.q)
