"""The station on an arm with prismatic joints (the ``boom`` test arm: a lifting
column, joint 1, and a telescopic boom, joint 4, in m; forces in N).

One simulated period (4 s, 600 samples at 150 Hz, about 0.4 s of CPU) of the
true boom arm (inertial parameters off by up to 15 %, friction by 20 %) under the
default inverse-dynamics controller on the nominal arm, then the oracles:
tracking, the logged efforts against the regressor, identification of the base
parameters from the log, and the effort check of planned moves against Drake.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces
from test_station import perturbed

from rmdrake import random_fourier_trajectory
from rmdrake.dynamics import regressor, standard_parameters
from rmdrake.dynamics.data import prepare_samples
from rmdrake.dynamics.friction import friction_torque
from rmdrake.dynamics.identification import identify
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import JointLimits
from rmdrake.systems import MakeStation, RunStation
from rmdrake.systems.station_config import PidControllerConfig, StationConfig
from rmdrake.systems.station_sources import (
    motion_effort,
    require_effort,
    setpoint_trajectory,
)

V_EPS = 1e-3  # rad/s or m/s, the station default


@pytest.fixture(scope="module")
def boom_run():
    from conftest import boom_arm

    nominal = boom_arm()
    true = perturbed(nominal, seed=2)
    traj = random_fourier_trajectory(nominal, seed=1, base_frequency=0.25)
    station = MakeStation(
        StationConfig(), true_model=true, trajectory=traj, nominal_model=nominal
    )
    return nominal, true, traj, RunStation(station, periods=1)


def test_boom_follows_the_trajectory(boom_run):
    """Within 3e-4 (rad or m) on every joint (observed 1e-4), 1/100 of the
    smallest travel, although the controller's model is off by up to 15 %."""
    nominal, _, traj, log = boom_run
    assert log.n_samples == 600
    travel = np.ptp(log.q, axis=0)
    assert travel[[0, 3]].min() > 0.03 and travel[[1, 2, 4, 5]].min() > 0.15
    err = np.abs(log.q - traj.q(log.t)).max(axis=0)
    assert np.all(err < 3e-4), err


def test_logged_efforts_equal_the_regressor(boom_run):
    """tau_logged == Y(q, qd, qdd) @ chi_true (forces on joints 1 and 4) to 1e-9
    of each joint's peak: the plant's acceleration output and net actuation are
    evaluated in the same Context as q and qd, and the friction system's
    tanh(qd / v_eps) acts on the slides as on the revolute joints."""
    _, true, _, log = boom_run
    pred = regressor(true, log.q, log.qd, log.qdd, coulomb_width=V_EPS)
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(pred @ standard_parameters(true) - log.tau) <= 1e-9 * scale)


def test_identify_the_station_log(boom_run):
    """Noise-free station log -> the true base parameters to 1e-6 of the
    largest (observed 4e-14; cond(A) about 2e3)."""
    nominal, true, _, log = boom_run
    samples = prepare_samples(log.t, log.q, log.tau, log.qd, log.qdd)
    ident = identify(nominal, samples, method="ols", coulomb_width=V_EPS)
    assert ident.base.count == 45  # 33 inertial + Ia, + fv, fc of 6 joints
    truth = ident.base.regroup(standard_parameters(true))
    assert np.abs(ident.params - truth).max() < 1e-6 * np.abs(truth).max()


def test_pid_with_gravity_compensation_tracks(boom):
    """The PID's default gains scale by the mass-matrix diagonal, a mass (kg)
    on a slide: 2 s of the slow trajectory within 3e-3 (rad or m)."""
    traj = random_fourier_trajectory(boom, seed=1, base_frequency=0.25)
    config = StationConfig(controller=PidControllerConfig())
    log = RunStation(
        MakeStation(config, true_model=boom, trajectory=traj), duration=2.0
    )
    assert np.abs(log.q - traj.q(log.t)).max() < 3e-3


def _moves(boom):
    lim = boom.limits
    q = lim.lower + np.array([[0.2], [0.8], [0.4]]) * (lim.upper - lim.lower)
    return setpoint_trajectory(q, move_time=1.5, settle_time=0.2)


def test_motion_effort_matches_drake(boom):
    """Each joint's peak |tau_j| / effort_j, recomputed at its own peak time
    with Drake's CalcInverseDynamics on MakePlant(boom) plus the friction law,
    to 1e-9 (forces in N on the slides)."""
    traj = _moves(boom)
    peak, t_peak = motion_effort(boom, traj, v_eps=V_EPS)
    plant, _ = MakePlant(boom, visual=False)
    ctx = plant.CreateDefaultContext()
    dyn = boom.dynamics
    for j, t in enumerate(t_peak):
        q, v, a = (traj.derivative(k).value(t).ravel() for k in range(3))
        plant.SetPositions(ctx, q)
        plant.SetVelocities(ctx, v)
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, forces)
        tau = plant.CalcInverseDynamics(ctx, a, forces)
        tau += friction_torque(v, dyn[:, 11], dyn[:, 12], V_EPS)
        assert abs(tau[j]) / boom.limits.effort[j] == pytest.approx(peak[j], rel=1e-9)
    assert peak[0] > 0.1  # the column holds the weight of the arm


def test_effort_check_names_a_slide_in_newtons(boom):
    lim = boom.limits
    weak = JointLimits(
        lower=lim.lower, upper=lim.upper, velocity=lim.velocity,
        acceleration=lim.acceleration, effort=np.r_[10.0, lim.effort[1:]],
    )  # fmt: skip
    weak = dataclasses.replace(boom, limits=weak)
    with pytest.raises(ValueError, match=r"joint 1 needs .* its effort limit \(10 N\)"):
        require_effort(weak, _moves(boom), v_eps=V_EPS)
