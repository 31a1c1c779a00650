"""The DEMO-class arm (4.5 t payload) in measurement runs: what a planned motion
asks of the true robot's actuators, and a run refused up front when they cannot
deliver it (the robot would give way under its load and the servo flail) rather
than simulated into garbage. Oracles: Drake's inverse dynamics of the plant,
and the servo settling where the load is within the effort limits."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces

from rmdrake.calibration import simulate_plates
from rmdrake.dynamics import standard_parameters
from rmdrake.model.dynamic_parameters import perturb_standard_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.studies.closed_loop import TargetDrive, drive_to_targets
from rmdrake.systems.measurement_runs import (
    MEASUREMENT_V_EPS,
    measure_plates_in_diagram,
    measurement_config,
)
from rmdrake.systems.station_sources import (
    motion_effort,
    setpoint_move_times,
    setpoint_trajectory,
)


@pytest.fixture(scope="module")
def heavy():
    """Nominal demo_rh; one plate and two poses: a planned one, then one
    0.44 rad away where the payload loads J4 to 0.58 x its effort limit."""
    nominal = load_robot("demo_rh")
    plan = simulate_plates(nominal, plates=1, per_plate=1, noise=0.0, seed=11)
    q1 = np.array([-1.26, -0.68, 1.12, -1.59, -1.24, 4.05])
    return nominal, plan.plates, np.array([plan.data.q[0], q1])


def _twice_the_payload(model):
    """``model`` with its payload folded into link n AND still welded on: the
    true robot that made seed 1 of demo_rh_closed_loop diverge."""
    return model.with_dynamics(standard_parameters(model).reshape(-1, 13))


def _move_times(model, q):
    """Moves through the poses q from q[0] at half the joint limits, >= 0.2 s."""
    limits = model.limits
    return np.maximum(
        setpoint_move_times(
            q, velocity=0.5 * limits.velocity, acceleration=0.5 * limits.acceleration
        ),
        0.2,
    )


def _trajectory(model, q):
    return setpoint_trajectory(q, move_time=_move_times(model, q), settle_time=0.5)


def test_motion_effort_is_the_plants_inverse_dynamics_plus_friction(heavy):
    nominal, _, q = heavy
    traj = _trajectory(nominal, q)
    peak, t_peak = motion_effort(nominal, traj, v_eps=MEASUREMENT_V_EPS)
    # Independent oracle: the MultibodyPlant's inverse dynamics (rotor inertia,
    # welded payload, gravity) plus the JointFriction law, on a dense grid.
    plant, _ = MakePlant(nominal, visual=False)
    context = plant.CreateDefaultContext()
    fv, fc = nominal.dynamics[:, 11], nominal.dynamics[:, 12]
    ratios = []
    for t in np.linspace(traj.start_time(), traj.end_time(), 400):
        qt, vt, at = (traj.EvalDerivative(t, k)[:, 0] for k in range(3))
        plant.SetPositions(context, qt)
        plant.SetVelocities(context, vt)
        gravity = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, gravity)
        tau = plant.CalcInverseDynamics(context, at, gravity)
        tau += fv * vt + fc * np.tanh(vt / MEASUREMENT_V_EPS)
        ratios.append(np.abs(tau) / nominal.limits.effort)
    dense = np.max(ratios, axis=0)
    # The same peaks to 1e-4 of the effort limits (measured 3e-5: the two
    # samplings, 0.01 rad steps and 400 times), far below the margin that
    # matters (a joint over its limit).
    np.testing.assert_allclose(peak, dense, rtol=0, atol=1e-4)
    assert 0.5 < peak[3] < 0.6  # J4 holding the payload at the second pose
    assert traj.start_time() <= t_peak.min() and t_peak.max() <= traj.end_time()


def test_a_robot_that_cannot_hold_its_load_is_refused_before_simulating(
    heavy, monkeypatch
):
    """With its payload counted twice, demo_rh needs 1.15 x J4's effort to hold
    the second pose. Simulated, J4 gave way and the servo drove every joint to
    its effort limits; now the run refuses it, naming the joint, at once."""
    nominal, plates, q = heavy
    true = _twice_the_payload(nominal)
    peak, _ = motion_effort(true, _trajectory(true, q), v_eps=MEASUREMENT_V_EPS)
    assert peak[3] > 1.1 and np.all(np.delete(peak, 3) < 1.0)

    def no_simulation(*args, **kwargs):
        raise AssertionError("the station was simulated")

    monkeypatch.setattr("rmdrake.systems.station.Simulator", no_simulation)
    with pytest.raises(ValueError, match=r"joint 4 needs 1\.1\d x its effort"):
        measure_plates_in_diagram(
            true_model=true, nominal_model=nominal, plates=plates, poses=[q]
        )


def test_a_drive_the_actuators_cannot_deliver_is_refused_before_simulating(
    heavy, monkeypatch
):
    """The static-accuracy drives refuse the same overloaded robot as the
    plate runs: before, a drive to these poses returned, with no error, the
    encoder angles of an arm whose joint 4 had given way. The same drive of
    the robot that carries its payload once runs (the check does not refuse a
    robot within its limits)."""
    nominal, _, q = heavy
    true = _twice_the_payload(nominal)
    # the moves of _trajectory, read at each hold's end
    drive = TargetDrive(q, _move_times(nominal, q), settle_time=0.5, q_start=q[0])
    config = measurement_config()
    q_read, _, _ = drive_to_targets(
        config, drive, true_model=nominal, nominal_model=nominal
    )
    assert np.abs(q_read - q).max() < 1e-3

    def no_simulation(*args, **kwargs):
        raise AssertionError("the station was simulated")

    monkeypatch.setattr("rmdrake.systems.measurement_runs.Simulator", no_simulation)
    with pytest.raises(ValueError, match=r"joint 4 needs 1\.1\d x its effort"):
        drive_to_targets(config, drive, true_model=true, nominal_model=nominal)


def test_a_heavy_arm_within_its_effort_limits_settles(heavy):
    """A true demo_rh with its dynamics perturbed 10-30 % per link (payload
    counted once), driven by the controller on the nominal model: the same
    poses run, no actuator saturates and the arm settles."""
    nominal, plates, q = heavy
    chi = perturb_standard_parameters(
        standard_parameters(nominal), np.random.default_rng(3)
    )
    true = dataclasses.replace(nominal.with_dynamics(chi.reshape(-1, 13)), payload=None)
    run = measure_plates_in_diagram(
        true_model=true, nominal_model=nominal, plates=plates, poses=[q]
    )
    assert np.all(np.abs(run.log.tau) < 0.9 * nominal.limits.effort)
    assert np.all(run.settle_error < 1e-6), run.settle_error
