"""The studies' kinematic steps on a robot with prismatic joints (the boom arm:
joints 1 and 4 in m): the calibration study end to end, the compensation
study's ISO 9283 cube and held-out targets checked on the Drake plant, and the
simulated log's summary units."""

from __future__ import annotations

import types

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable

from rmdrake.model.plant import TOOL_FRAME, MakePlant
from rmdrake.pipelines.simulate import log_summary
from rmdrake.studies.calibration import run_calibration_study
from rmdrake.studies.compensation import cube_targets, held_out_configurations
from rmdrake.studies.scenarios import CalibrationStudyConfig


def test_calibration_study_on_the_boom_arm(boom, tmp_path):
    """One seed, LM on 4 plates x 10 readings, every MDH entry perturbed to a
    1.6 mm mean tool error: the held-out error drops more than tenfold, the
    figure and the scene (PrismaticJoint in Meshcat) are written."""
    config = CalibrationStudyConfig(
        seeds=1, params="full", plates=4, per_plate=10, n_validation=100,
        methods=["lm"], repeat_methods=["lm"], html=True,
    )  # fmt: skip
    lines: list[str] = []
    result = run_calibration_study(
        boom, config, tmp_path, progress=False, echo=lines.append
    )
    before, after = result.mean_before[0], result.mean_after["lm"][0]
    assert abs(before - 1.6e-3) < 1e-5 and after < 0.1 * before
    assert (tmp_path / "kinematic_calibration_fig3.png").stat().st_size > 10_000
    assert (tmp_path / "kinematic_calibration.html").stat().st_size > 10_000


def _drake(model):
    plant, _ = MakePlant(model, visual=False)
    return plant, plant.CreateDefaultContext(), plant.GetFrameByName(TOOL_FRAME)


def test_cube_and_held_out_targets_on_the_drake_plant(boom):
    """The cube's P1 is the Drake plant's tool position at cube_q (slides in m)
    and R_BE its orientation (1e-12); every held-out configuration lies in the
    margin-shrunk ranges and its Drake tool Jacobian has a smallest singular
    value >= min_singular."""
    plant, context, tool = _drake(boom)
    cube_q = np.array([0.4, 0.3, -1.0, 0.3, 0.8, 0.2])
    P, R = cube_targets(boom, cube_q, 0.1)
    plant.SetPositions(context, cube_q)
    X = plant.CalcRelativeTransform(context, plant.world_frame(), tool)
    np.testing.assert_allclose(P[0], X.translation(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(R, X.rotation().matrix(), rtol=0, atol=1e-12)
    q = held_out_configurations(boom, 10, margin=0.15, min_singular=0.05, seed=3)
    lo, hi = boom.limits.lower, boom.limits.upper
    assert np.all((q >= lo + 0.15 * (hi - lo)) & (q <= hi - 0.15 * (hi - lo)))
    world = plant.world_frame()
    for qk in q:
        plant.SetPositions(context, qk)
        J = plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kV, tool, [0, 0, 0], world, world
        )
        assert np.linalg.svd(J, compute_uv=False)[-1] >= 0.05 * (1 - 1e-9)


def test_log_summary_gives_slides_in_mm_and_newtons():
    """Tracking errors in deg (revolute) and mm (prismatic), peak efforts in
    N m and N, a saturated slide named with its limit in N."""
    t = np.linspace(0.0, 1.0, 11)
    q_ref = np.zeros((11, 3))
    q = q_ref + [0.01, 2e-3, 0.0]  # 0.573 deg, 2 mm, 0
    log = types.SimpleNamespace(t=t, q=q, tau=np.tile([5.0, 300.0, 1.0], (11, 1)))
    trajectory = types.SimpleNamespace(q=lambda _: q_ref)
    lines = log_summary(log, trajectory, np.array([10.0, 300.0, 9.0]), sigma=[0, 1, 0])
    assert lines[0] == "max tracking error: 0.573 deg, 2 mm, 0 deg"
    assert lines[1].split(": ")[1].strip() == "5 N m, 300 N, 1 N m"
    assert lines[2].startswith("warning: joint 2 saturated at its effort limit 300 N ")
    assert len(lines) == 3
