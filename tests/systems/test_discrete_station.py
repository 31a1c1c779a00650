"""The discrete station: Drake's own friction and a sampled controller.

Oracles: the continuous plant (mass matrix, tracking), and the SAP step itself:
with the sampled outputs a logged sample k holds the torque and acceleration of
the step from k-1 to k, so the rigid-body regressor evaluated at the step's
start (q - h qd, qd - h qdd) and qdd gives the logged torque to round-off
wherever the Coulomb term is saturated at both ends of the step.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.framework import LeafSystem

from rmdrake import RobotModel, load_robot, random_fourier_trajectory
from rmdrake.dynamics import SerialChain, regressor, standard_parameters
from rmdrake.model.plant import MakePlant, coulomb_levels
from rmdrake.systems import MakeStation, RunStation
from rmdrake.systems.station_config import (
    DEFAULT_LOG_PERIOD,
    DEFAULT_TIME_STEP,
    PidControllerConfig,
    StationConfig,
    discrete_time_step,
)
from rmdrake.systems.station_sources import setpoint_trajectory


def perturbed(model: RobotModel, seed: int) -> RobotModel:
    """Inertial parameters by one factor in [0.85, 1.15] per link, Ia, fv, fc
    by [0.8, 1.2] (physically valid)."""
    rng = np.random.default_rng(seed)
    d = np.array(model.dynamics)
    d[:, :10] *= rng.uniform(0.85, 1.15, (model.n_joints, 1))
    d[:, 10:] *= rng.uniform(0.8, 1.2, (model.n_joints, 3))
    return model.with_dynamics(d)


@pytest.fixture(scope="module")
def robots() -> tuple[RobotModel, RobotModel]:
    nominal = load_robot("rv3sb")
    return nominal, perturbed(nominal, 2)


@pytest.fixture(scope="module")
def runs(robots):
    """One excitation on the continuous and on the discrete station."""
    nominal, true = robots
    traj = random_fourier_trajectory(nominal, seed=1, fill=0.5)
    logs = {}
    for step in (0.0, DEFAULT_TIME_STEP):
        station = MakeStation(
            StationConfig(time_step=step),
            true_model=true,
            trajectory=traj,
            nominal_model=nominal,
        )
        logs[step] = RunStation(station, duration=3.0)
    return traj, logs


def test_time_step_divides_the_log_period() -> None:
    assert DEFAULT_TIME_STEP == pytest.approx(1.0 / 1050.0, rel=1e-12)
    assert discrete_time_step(0.01) == pytest.approx(1e-3, rel=1e-12)
    assert discrete_time_step(1.0 / 200.0) == pytest.approx(1e-3, rel=1e-12)
    assert discrete_time_step(0.0015) == pytest.approx(7.5e-4, rel=1e-12)
    for period in (DEFAULT_LOG_PERIOD, 0.01, 0.0015, 1 / 333):
        h = discrete_time_step(period)
        assert h <= 1e-3 + 1e-15
        assert abs(period / h - round(period / h)) < 1e-9


def test_a_step_that_does_not_divide_the_log_is_refused(robots) -> None:
    nominal, true = robots
    traj = random_fourier_trajectory(nominal, seed=1)
    with pytest.raises(ValueError, match=r"time_step: .*whole number.*0.000952381"):
        MakeStation(StationConfig(time_step=1e-3), true_model=true, trajectory=traj)


def test_exact_sign_is_refused_on_a_discrete_station(robots) -> None:
    # Its Coulomb friction is the plant's own (SAP, linear over v_eps): the
    # option would be silently ignored.
    nominal, true = robots
    traj = random_fourier_trajectory(nominal, seed=1)
    config = StationConfig(time_step=DEFAULT_TIME_STEP, exact_sign=True)
    with pytest.raises(ValueError, match="exact_sign: expected the continuous"):
        MakeStation(config, true_model=true, trajectory=traj)


def test_coulomb_actuators_keep_the_rotor_inertia(robots) -> None:
    # Drake gives a joint its last actuator's reflected inertia; the Coulomb
    # actuator repeats the motor's, so the mass matrix is the plain plant's.
    _, true = robots
    plain, _ = MakePlant(true, time_step=DEFAULT_TIME_STEP, visual=False)
    with_coulomb, _ = MakePlant(
        true, time_step=DEFAULT_TIME_STEP, visual=False, coulomb_width=1e-3
    )
    assert with_coulomb.num_actuators() == 2 * true.n_joints
    rng = np.random.default_rng(0)
    for q in rng.uniform(-1.0, 1.0, (3, true.n_joints)):
        M = []
        for plant in (plain, with_coulomb):
            context = plant.CreateDefaultContext()
            plant.SetPositions(context, q)
            M.append(plant.CalcMassMatrix(context))
        np.testing.assert_allclose(M[1], M[0], rtol=1e-14, atol=1e-14)
    levels = coulomb_levels(true)
    for j, level in enumerate(levels, start=1):
        actuator = with_coulomb.GetJointActuatorByName(f"joint{j}_coulomb")
        assert actuator.effort_limit() == pytest.approx(level)
        gains = actuator.get_controller_gains()
        assert gains.p == 0.0 and gains.d == pytest.approx(level / 1e-3)


def test_coulomb_width_needs_a_discrete_plant(robots) -> None:
    with pytest.raises(ValueError, match="coulomb_width: expected a discrete"):
        MakePlant(robots[1], time_step=0.0, visual=False, coulomb_width=1e-3)


@pytest.mark.parametrize("controller", ["default", "pid"])
def test_no_continuous_state_and_no_python_system_in_the_loop(robots, controller):
    nominal, true = robots
    traj = random_fourier_trajectory(nominal, seed=1)
    config = StationConfig(time_step=DEFAULT_TIME_STEP)
    if controller == "pid":
        config.controller = PidControllerConfig(friction_feedforward=False)
    station = MakeStation(
        config, true_model=true, trajectory=traj, nominal_model=nominal
    )
    # Nothing to integrate: the only continuous state (with the default
    # controller) is the friction feedforward law's constant, of derivative 0.
    context = station.diagram.CreateDefaultContext()
    derivatives = station.diagram.EvalTimeDerivatives(context).CopyToVector()
    assert context.num_continuous_states() == (controller == "default")
    assert np.all(derivatives == 0.0)
    assert station.friction is None
    python = {
        s.get_name()
        for s in station.diagram.GetSystems()
        if isinstance(s, LeafSystem) and type(s).__module__.startswith("rmdrake")
    }
    # Only the encoders are Python; the Fourier source, the plant's friction, the
    # friction feedforward and the feedback are not.
    assert python <= {"encoder"}


def test_log_is_the_steps_it_reports(runs, robots) -> None:
    _, true = robots
    traj, logs = runs
    log = logs[DEFAULT_TIME_STEP]
    continuous = logs[0.0]
    # Same sample count; the discrete log starts one period later (at t0 no
    # step has been taken yet).
    assert log.n_samples == continuous.n_samples == 450
    np.testing.assert_allclose(log.t, continuous.t + DEFAULT_LOG_PERIOD, atol=1e-12)
    h = DEFAULT_TIME_STEP
    Y = regressor(
        SerialChain.from_model(true),
        log.q - h * log.qd,
        log.qd - h * log.qdd,
        log.qdd,
        coulomb_width=0.0,
    )
    residual = np.abs(Y @ standard_parameters(true) - log.tau)
    start = log.qd - h * log.qdd
    saturated = np.all(
        (np.abs(log.qd) > 0.01) & (np.abs(start) > 0.01) & (log.qd * start > 0),
        axis=1,
    )
    assert saturated.mean() > 0.8
    scale = np.abs(log.tau).max(0)
    assert np.all(residual[saturated] / scale < 1e-6), (residual / scale).max()
    # Elsewhere the Coulomb term moves through its linear band: at most about
    # twice its level away from sign(qd).
    levels = coulomb_levels(true)
    assert np.all(residual <= 2.0 * levels + 1e-6 * scale)


def test_discrete_station_tracks_like_the_continuous(runs) -> None:
    traj, logs = runs
    for log in logs.values():
        err = np.abs(log.q - traj.q(log.t)).max(0)
        assert np.all(err < np.radians(0.5)), np.degrees(err)


def test_holds_settle_on_the_discrete_station(robots) -> None:
    # Point-to-point moves held still: what calibration readings and static
    # accuracy simulate; the sampled integral pulls the joints in through
    # Coulomb friction.
    nominal, true = robots
    rng = np.random.default_rng(0)
    lo, hi = nominal.limits.lower, nominal.limits.upper
    q_list = lo + (hi - lo) * (0.3 + 0.4 * rng.random((2, nominal.n_joints)))
    program = setpoint_trajectory(q_list, move_time=1.0, settle_time=1.5)
    station = MakeStation(
        StationConfig(time_step=DEFAULT_TIME_STEP),
        true_model=true,
        trajectory=program,
        nominal_model=nominal,
    )
    log = RunStation(station)
    assert np.abs(log.q[-1] - q_list[-1]).max() < 1e-3
    assert np.abs(log.qd[-1]).max() < 1e-2
