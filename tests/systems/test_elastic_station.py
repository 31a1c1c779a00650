"""The station with an elastic true robot: rest start, link-side output, and the
controller bandwidth rule (below the lowest structural mode)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake.dynamics.compliance import link_angles, lowest_structural_mode
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Compliance, RobotModel
from rmdrake.systems import (
    InverseDynamicsControllerConfig,
    MakeStation,
    PidControllerConfig,
    RunStation,
    StationConfig,
    setpoint_trajectory,
)

K = np.array([1e8, 5e7, 2.5e7, 1e7, 1e7, 5e6])  # N m/rad, as demo_rh_elastic
Q0 = np.array([0.0, 0.3, 0.5, 0.0, 0.6, 0.0])
Q1 = np.array([0.1, 0.4, 0.4, 0.1, 0.5, 0.1])


@pytest.fixture(scope="module")
def demo() -> RobotModel:
    return dataclasses.replace(
        load_robot("demo_rh"), compliance=Compliance(K, 0.005 * K)
    )


@pytest.fixture(scope="module")
def move():
    """Hold Q0 for 4 s, move to Q1 in 3 s, hold 3 s."""
    return setpoint_trajectory(
        np.array([Q0, Q1]), move_time=[1.0, 3.0], settle_time=3.0
    )


def _config(bandwidth: float) -> StationConfig:
    return StationConfig(
        controller=InverseDynamicsControllerConfig(bandwidth=bandwidth)
    )


def test_slow_move_settles_at_the_static_deflection(demo, move) -> None:
    mode = lowest_structural_mode(demo, Q0)
    station = MakeStation(_config(mode / 4), true_model=demo, trajectory=move)
    assert station.structural_mode == pytest.approx(mode)
    context = station.CreateDefaultContext()
    q_link = station.diagram.GetOutputPort("q_link")
    np.testing.assert_allclose(q_link.Eval(context), link_angles(demo, Q0), atol=1e-14)
    assert np.all(np.abs(q_link.Eval(context) - Q0)[[1, 2, 4]] > 1e-4)  # bent
    other = {}
    log = RunStation(station, other_logs=other)
    q_l = other["q_link"]
    assert q_l.shape == log.q.shape
    # The first hold: the link side stays at rest for the motor side (a start
    # with the links undeflected would ring with the deflection's amplitude,
    # 8 mrad); the motor drifts a little, as the rigid controller's gravity
    # model at q_m differs from the true load at q_l until its integral has
    # caught up.
    hold = log.t < 4.0
    bend = np.max(np.abs(link_angles(demo, Q0) - Q0))
    assert np.max(np.abs(q_l[hold] - link_angles(demo, log.q[hold]))) < 0.01 * bend
    assert np.max(np.abs(log.q[hold] - Q0)) < 2e-3
    # the end: motor side settled on Q1, link side at rest for it
    np.testing.assert_allclose(log.q[-1], Q1, atol=3e-4)
    assert np.max(np.abs(log.qd[-1])) < 3e-4
    np.testing.assert_allclose(q_l[-1], link_angles(demo, log.q[-1]), atol=1e-6)


def test_bandwidth_above_the_structural_mode_is_refused(demo, move) -> None:
    mode = lowest_structural_mode(demo, Q0)
    for controller in (
        InverseDynamicsControllerConfig(),  # 40 rad/s default
        PidControllerConfig(bandwidth=1.01 * mode),
    ):
        with pytest.raises(
            ValueError, match=r"controller\.bandwidth: .*structural mode"
        ):
            MakeStation(
                StationConfig(controller=controller), true_model=demo, trajectory=move
            )
    station = MakeStation(_config(0.99 * mode), true_model=demo, trajectory=move)
    assert set(station.loggers) == {"q", "qd", "qdd", "tau", "q_link"}


def test_rigid_robot_q_link_is_the_true_q(move) -> None:
    rigid = load_robot("demo_rh")
    station = MakeStation(_config(40.0), true_model=rigid, trajectory=move)
    assert station.structural_mode is None
    assert "q_link" not in station.loggers
    context = station.CreateDefaultContext()
    np.testing.assert_array_equal(
        station.diagram.GetOutputPort("q_link").Eval(context),
        station.plant.GetPositions(station.plant.GetMyContextFromRoot(context)),
    )
