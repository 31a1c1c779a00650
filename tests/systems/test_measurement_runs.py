"""Plane-constraint readings taken in the station diagram: the true robot driven
point to point, read by its RangeFinders, encoders and ToolTracker at the end
of each hold. Oracles: the numpy readings and tool points at the encoder
angles, and the calibration recovering the true kinematic errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import LeafSystem

from rmdrake.calibration import (
    beam_readings,
    make_calibrator,
    range_readings,
    simulate_plates,
)
from rmdrake.calibration.plates.checks import MeasurementWarning
from rmdrake.kinematics.forward import tool_points, tool_poses
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot
from rmdrake.systems.measurement_runs import (
    MEASUREMENT_V_EPS,
    measure_plates_in_diagram,
    measurement_config,
    use_integration_scheme,
)
from rmdrake.systems.station_config import SensorConfig, StationConfig, check_times
from rmdrake.systems.station_sources import setpoint_times


@pytest.fixture(scope="module")
def campaign():
    """Nominal RV-3SB; a true robot with errors on the paper's 17 kinematic
    parameters (about 1 mm at the tool, same dynamics); 4 plates x 8 poses
    planned on the nominal; the run on the true robot with the true model as
    controller model (a perfect servo) and 0.5 s holds."""
    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    deltas = 4e-4 * np.random.default_rng(7).standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    plan = simulate_plates(nominal, plates=4, per_plate=8, noise=0.0, seed=11)
    poses = [plan.data.q[plan.data.plane == p] for p in range(4)]
    run = measure_plates_in_diagram(
        true_model=true, plates=plan.plates, poses=poses, settle_time=0.5
    )
    return nominal, true, deltas, plan, run


def test_readings_are_timed_at_the_ends_of_the_holds(campaign):
    *_, plan, run = campaign
    N = plan.data.n_readings
    assert run.t.shape == (N,) and run.move_time.shape == (N,)
    np.testing.assert_array_equal(
        run.t, setpoint_times(N, move_time=run.move_time, settle_time=0.5)
    )
    np.testing.assert_array_equal(run.q_desired, plan.data.q)
    np.testing.assert_array_equal(run.plane, plan.data.plane)
    assert np.all(run.move_time >= 0.2)
    assert run.log.t[-1] <= run.t[-1]  # the joint log covers the run
    # A perfect servo settles to 1e-6 rad within a 0.5 s hold (measured 4e-8:
    # integration error, corrected at the 40 rad/s bandwidth).
    assert np.all(run.settle_error < 1e-6), run.settle_error


def test_a_run_without_the_joint_log_reads_the_same(campaign):
    """The joint log's 150 Hz publish events bound the integrator's steps;
    without them the error control takes other steps, so the arm settles along
    a path that differs by the integration error: the encoder angles agree
    within the servo's settle bound (1e-6 rad; measured 4e-8) and the
    distances within 0.1 um (a twentieth of a 2 um range finder's noise;
    measured 4e-8 m). No log is returned."""
    nominal, true, _, plan, run = campaign
    poses = [plan.data.q[plan.data.plane == p] for p in range(4)]
    bare = measure_plates_in_diagram(
        true_model=true,
        plates=plan.plates,
        poses=poses,
        settle_time=0.5,
        joint_log=False,
    )
    assert bare.log is None and run.log is not None
    np.testing.assert_array_equal(bare.t, run.t)
    np.testing.assert_allclose(bare.q, run.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(bare.distance, run.distance, rtol=0, atol=1e-7)


def _read_at_rest(campaign, config, *, joint_log=False):
    """The campaign's first four plates read with 0.5 s holds under
    ``config`` (None: the default)."""
    _, true, _, plan, _ = campaign
    return measure_plates_in_diagram(
        config,
        true_model=true,
        plates=plan.plates,
        poses=[plan.data.q[plan.data.plane == p] for p in range(4)],
        settle_time=0.5,
        joint_log=joint_log,
    )


def test_holds_integrated_by_radau3_read_as_runge_kutta3_throughout(campaign):
    """Without joint logs the default config integrates each 0.5 s hold with
    Radau3 and the moves with RK3; with RK3 throughout
    (``hold_integration_scheme=""``) the arm settles along a path that
    differs by the integration error: encoder angles within the servo's
    settle bound (1e-6 rad; measured 2e-8) and distances within 0.1 um
    (measured 4e-11 m). A logged run keeps RK3 (a change of scheme would log
    a sample twice): the same bytes either way."""
    run = campaign[-1]
    assert measurement_config().hold_integration_scheme == "radau3"
    explicit = measurement_config()
    explicit.hold_integration_scheme = ""
    mixed, rk3 = _read_at_rest(campaign, None), _read_at_rest(campaign, explicit)
    assert not np.array_equal(mixed.q, rk3.q)  # the holds' scheme was used
    np.testing.assert_allclose(mixed.q, rk3.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(mixed.distance, rk3.distance, rtol=0, atol=1e-7)
    logged = _read_at_rest(campaign, explicit, joint_log=True)
    np.testing.assert_array_equal(logged.q, run.q)
    np.testing.assert_array_equal(logged.log.q, run.log.q)


def test_moves_at_the_move_accuracy_read_as_at_the_simulators(campaign):
    """The default config integrates the moves of a run read at rest at
    ``move_accuracy`` 1e-3 and the holds at the simulator's 1e-4; with the
    moves at 1e-4 too (``move_accuracy=0``) the 0.5 s holds absorb the
    difference: encoder angles within the servo's settle bound (1e-6 rad),
    distances within 0.1 um."""
    assert measurement_config().move_accuracy == 1e-3
    exact = measurement_config()
    exact.move_accuracy = 0.0
    fast, slow = _read_at_rest(campaign, None), _read_at_rest(campaign, exact)
    assert not np.array_equal(fast.q, slow.q)  # the moves' accuracy was used
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(fast.distance, slow.distance, rtol=0, atol=1e-7)


def test_a_scheme_changed_mid_run_keeps_the_context_and_the_events():
    """``use_integration_scheme`` between two ``AdvanceTo``: the time and the
    state go on, the initialization event ran once, the periodic events all
    ran, and the new integrator has the config's accuracy."""

    class Ramp(LeafSystem):
        def __init__(self):
            super().__init__()
            self.DeclareContinuousState(1)
            self.inits, self.ticks = 0, 0
            self.DeclareInitializationPublishEvent(self._init)
            self.DeclarePeriodicPublishEvent(0.3, 0.0, self._tick)

        def _init(self, context):
            self.inits += 1

        def _tick(self, context):
            self.ticks += 1

        def DoCalcTimeDerivatives(self, context, derivatives):
            derivatives.get_mutable_vector().SetFromVector([1.0])

    config = SimulatorConfig(accuracy=1e-5)
    ramp = Ramp()
    simulator = Simulator(ramp)
    ApplySimulatorConfig(config, simulator)
    simulator.Initialize()
    simulator.AdvanceTo(1.0)
    use_integration_scheme(simulator, config, "radau3")
    simulator.AdvanceTo(2.0)
    use_integration_scheme(simulator, config, "runge_kutta3")
    simulator.AdvanceTo(3.0)
    context = simulator.get_context()
    assert context.get_time() == 3.0
    assert context.get_continuous_state_vector()[0] == pytest.approx(3.0, abs=1e-12)
    assert ramp.inits == 1 and ramp.ticks == 11  # t = 0, 0.3, ..., 3.0
    assert simulator.get_integrator().get_target_accuracy() == 1e-5
    use_integration_scheme(simulator, config, "radau3", 1e-3)
    assert simulator.get_integrator().get_target_accuracy() == 1e-3
    fixed = SimulatorConfig(use_error_control=False, max_step_size=0.1)
    use_integration_scheme(simulator, fixed, "radau3")
    assert simulator.get_integrator().get_fixed_step_mode()
    with pytest.raises(ValueError, match="hold_integration_scheme: expected ''"):
        check_times(StationConfig(hold_integration_scheme="radau4"))
    with pytest.raises(ValueError, match="move_accuracy: expected 0"):
        check_times(StationConfig(move_accuracy=1.5))


def test_readings_equal_numpy_at_the_encoder_angles(campaign):
    _, true, _, plan, run = campaign
    assert np.all(run.valid) and run.data.n_readings == plan.data.n_readings
    # The reading, the encoder angles and p_WM are outputs of one state at one
    # instant, so the diagram's readings and the numpy MDH kinematics at the
    # encoder angles agree to round-off (measured 4e-16 m); how well the servo
    # settled does not enter (see the settle error above).
    numpy_t = range_readings(true.table, run.q, plan.plates, run.plane)
    np.testing.assert_allclose(run.distance, numpy_t, rtol=0, atol=1e-12)
    X_BE = tool_poses(true.table, run.q)
    for p, plate in enumerate(plan.plates):
        mine = run.plane == p
        t, _, valid = beam_readings(X_BE[mine], plate.X_BP)
        np.testing.assert_allclose(run.distance[mine], t, rtol=0, atol=1e-12)
        assert np.all(valid)
    np.testing.assert_allclose(
        run.p_WM, tool_points(true.table, run.q), rtol=0, atol=1e-12
    )
    np.testing.assert_array_equal(run.data.q, run.q)
    # The true robot's readings differ from the nominal plan's by the ~1 mm
    # kinematic error: the diagram measured the true kinematics.
    assert np.abs(run.distance - plan.true_distance).max() > 1e-4


def test_calibration_from_diagram_readings_recovers_true_errors(campaign):
    nominal, _, deltas, _, run = campaign
    with warnings.catch_warnings():
        # A pose planned on a joint limit settles a few 1e-8 rad beyond it.
        warnings.simplefilter("ignore", MeasurementWarning)
        fit = make_calibrator("lm", nominal).fit(run.data)
    # Noise-free, consistent readings: the 17 errors (about 4e-4 rad or m)
    # come back to round-off (measured 2e-14).
    assert np.abs(fit.deltas_ - deltas).max() < 1e-9
    assert fit.residual_rms_ < 1e-12


def test_default_config_and_noise_are_seeded():
    nominal = load_robot("rv3sb")
    assert measurement_config().v_eps == MEASUREMENT_V_EPS
    plan = simulate_plates(
        nominal, plates=1, per_plate=3, noise=0.0, seed=2, selection="first"
    )

    def run(seed: int):
        config = measurement_config()
        config.sensors = SensorConfig(seed=seed)
        return measure_plates_in_diagram(
            config,
            true_model=nominal,
            plates=plan.plates,
            poses=[plan.data.q],
            settle_time=0.3,
            reading_noise=1e-5,
            tracker_noise=1e-4,
            p_EM=(0.0, 0.0, 0.05),
        )

    a, b = run(0), run(0)
    np.testing.assert_array_equal(a.distance, b.distance)
    np.testing.assert_array_equal(a.p_WM, b.p_WM)
    exact_t = range_readings(nominal.table, a.q, plan.plates, a.plane)
    X_BE = tool_poses(nominal.table, a.q)
    exact_p = X_BE[:, :3, 3] + 0.05 * X_BE[:, :3, 2]  # marker 5 cm along z_E
    dt, dp = a.distance - exact_t, a.p_WM - exact_p
    assert 1e-8 < np.abs(dt).max() < 5e-5 and len(set(dt)) == dt.size  # 10 um
    assert 1e-7 < np.abs(dp).max() < 5e-4 and len(set(dp.ravel())) == dp.size
    c = run(1)
    assert not np.array_equal(a.distance, c.distance)


def test_bad_input():
    nominal = load_robot("rv3sb")
    plan = simulate_plates(
        nominal, plates=1, per_plate=2, noise=0.0, seed=2, selection="first"
    )
    kwargs = dict(true_model=nominal, plates=plan.plates)
    with pytest.raises(ValueError, match="one array of joint angles per plate"):
        measure_plates_in_diagram(**kwargs, poses=[plan.data.q, plan.data.q])
    with pytest.raises(ValueError, match=r"poses\[0\]"):
        measure_plates_in_diagram(**kwargs, poses=[plan.data.q[:, :5]])
    with pytest.raises(ValueError, match="reading_noise: expected a std >= 0 m"):
        measure_plates_in_diagram(**kwargs, poses=[plan.data.q], reading_noise=-1)
    with pytest.raises(ValueError, match="settle_time: expected > 0 s"):
        measure_plates_in_diagram(**kwargs, poses=[plan.data.q], settle_time=0.0)
    with pytest.raises(ValueError, match="move_time: expected one value or 2"):
        measure_plates_in_diagram(**kwargs, poses=[plan.data.q], move_time=[1.0])
