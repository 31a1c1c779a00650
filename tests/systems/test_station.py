"""The true-robot station: friction, sensors, torque oracle, configuration, CLI."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    PrismaticJoint,
    RevoluteJoint,
    SpatialInertia,
    WeldJoint,
)
from pydrake.systems.analysis import SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

import rmdrake.systems.station as station_module
from rmdrake import (
    FourierTrajectory,
    RobotModel,
    load_robot,
    random_fourier_trajectory,
    read_joint_log,
)
from rmdrake.cli.commands import main
from rmdrake.dynamics import SerialChain, regressor, standard_parameters
from rmdrake.dynamics.friction import friction_torque
from rmdrake.model.plant import MakePlant
from rmdrake.systems import EncoderQuantizer, JointFriction, MakeStation, RunStation
from rmdrake.systems.joint_sensors import AddTorqueSensorNoise
from rmdrake.systems.station import joint_state_selector
from rmdrake.systems.station_config import (
    DEFAULT_TIME_STEP,
    InverseDynamicsControllerConfig,
    PidControllerConfig,
    SensorConfig,
    StationConfig,
)
from rmdrake.systems.station_sources import (
    JointTrajectorySource,
    setpoint_move_times,
    setpoint_times,
    setpoint_trajectory,
)

V_EPS = 1e-3  # rad/s, the station default


def perturbed(model: RobotModel, seed: int) -> RobotModel:
    """A 'true' robot: each link's 10 inertial parameters scaled by one factor
    in [0.85, 1.15] (stays physically valid), Ia, fv, fc each by [0.8, 1.2]."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    d = np.array(model.dynamics)
    d[:, :10] *= rng.uniform(0.85, 1.15, (n, 1))
    d[:, 10:] *= rng.uniform(0.8, 1.2, (n, 3))
    return model.with_dynamics(d)


@pytest.fixture(scope="module")
def rv3sb() -> RobotModel:
    return load_robot("rv3sb")


@pytest.fixture(scope="module")
def traj(rv3sb: RobotModel) -> FourierTrajectory:
    return random_fourier_trajectory(rv3sb, seed=1, fill=0.5)


@pytest.fixture(scope="module")
def clean_run(rv3sb: RobotModel, traj: FourierTrajectory):
    """3 s (0.3 period) of the RV-3SB with a +-15 % / +-20 % perturbed truth."""
    true = perturbed(rv3sb, seed=2)
    station = MakeStation(
        StationConfig(), true_model=true, trajectory=traj, nominal_model=rv3sb
    )
    return true, RunStation(station, periods=0.3)


# ---- friction ---------------------------------------------------------------------
def test_joint_friction_outputs_documented_force() -> None:
    fv, fc = np.array([2.0, 0.5, 1.0]), np.array([3.0, 1.0, 0.0])
    v = np.array([0.3, -2e-3, 0.0])
    smooth = JointFriction(fv=fv, fc=fc, v_eps=V_EPS)
    ctx = smooth.CreateDefaultContext()
    smooth.get_input_port().FixValue(ctx, np.r_[np.ones(3), v])  # [q; v]
    want = -(fv * v + fc * np.tanh(v / V_EPS))
    # Drake's system against numpy (each its own tanh): a few ulp.
    np.testing.assert_allclose(smooth.get_output_port().Eval(ctx), want, atol=1e-14)
    np.testing.assert_allclose(want, -friction_torque(v, fv, fc, V_EPS), atol=0)

    exact = JointFriction(fv=fv, fc=fc, exact_sign=True, input="v")
    ctx = exact.CreateDefaultContext()
    exact.get_input_port().FixValue(ctx, v)
    np.testing.assert_allclose(
        exact.get_output_port().Eval(ctx), -(fv * v + fc * np.sign(v)), atol=1e-14
    )
    # Parameters live in the Context.
    exact.SetFriction(ctx, fc=[1.0, 1.0, 1.0])
    assert exact.GetFriction(ctx)[1].tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_allclose(
        exact.get_output_port().Eval(ctx), -(fv * v + np.sign(v)), atol=1e-14
    )
    with pytest.raises(ValueError, match="fc: expected >= 0 .* joint 2"):
        JointFriction(fv=fv, fc=[1.0, -1.0, 0.0])
    with pytest.raises(ValueError, match="v_eps"):
        JointFriction(fv=fv, fc=fc, v_eps=0.0)


def test_encoder_quantizer() -> None:
    enc = EncoderQuantizer(resolution=[1e-3, 0.0])
    ctx = enc.CreateDefaultContext()
    enc.get_input_port().FixValue(ctx, [0.12345, 0.12345])
    np.testing.assert_allclose(enc.get_output_port().Eval(ctx), [0.123, 0.12345])
    with pytest.raises(ValueError, match="encoder resolution: expected >= 0"):
        EncoderQuantizer(resolution=[-1.0])


# ---- the torque oracle ------------------------------------------------------------
def test_logged_torque_equals_regressor(clean_run) -> None:
    """tau_logged == Y(q, qd, qdd) @ chi_true at every logged sample.

    Tolerance 1e-9 of each joint's peak torque: with a continuous plant the
    logged qdd is the plant's acceleration output evaluated in the same Context
    as the logged q, qd and tau, so the identity holds to round-off whatever the
    integrator's error; 1e-9 is the regressor-vs-Drake agreement of the dynamics
    tests. The simulated friction uses tanh(qd / v_eps), so the regressor uses
    the same smooth sign (``coulomb_width=v_eps``); with the exact
    sign the identity holds where |qd| > 10 v_eps (|sign - tanh| < 4e-9 there).
    """
    true, log = clean_run
    assert log.n_samples == 450 and log.qd is not None and log.qdd is not None
    chain = SerialChain.from_model(true)
    chi = standard_parameters(true)
    scale = np.abs(log.tau).max(axis=0)
    exact = regressor(chain, log.q, log.qd, log.qdd) @ chi
    smooth = regressor(chain, log.q, log.qd, log.qdd, coulomb_width=V_EPS) @ chi
    assert np.all(np.abs(smooth - log.tau) <= 1e-9 * scale)
    away = np.abs(log.qd) > 10 * V_EPS
    assert away.mean() > 0.9
    assert np.all(
        np.abs(exact - log.tau)[away] <= 1e-8 * np.broadcast_to(scale, away.shape)[away]
    )


def test_tracking_error_small(clean_run, traj: FourierTrajectory) -> None:
    # Nominal model off by up to 15 % (inertia) and 20 % (friction): the default
    # 40 rad/s loop keeps every joint within 0.3 deg of the reference.
    _, log = clean_run
    err = np.abs(log.q - traj.q(log.t)).max(axis=0)
    assert np.all(err < np.radians(0.3)), np.degrees(err)
    np.testing.assert_allclose(log.t, np.arange(450) / 150.0, atol=1e-12)


def test_payload_robot_oracle() -> None:
    # demo_rh carries a 4.5 t payload, folded into link 6 by standard_parameters.
    model = load_robot("demo_rh")
    true = perturbed(model, seed=5)
    tr = random_fourier_trajectory(model, seed=4, fill=0.5)
    st = MakeStation(
        StationConfig(), true_model=true, trajectory=tr, nominal_model=model
    )
    log = RunStation(st, periods=0.1)
    Y = regressor(
        SerialChain.from_model(true), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(true) - log.tau) <= 1e-9 * scale)


def test_sensor_effects_seeded(rv3sb, traj, clean_run) -> None:
    true, clean = clean_run
    sigma, res = 0.05, 1e-4

    def run(seed: int):
        sensors = SensorConfig(torque_noise=sigma, encoder_resolution=res, seed=seed)
        st = MakeStation(
            StationConfig(sensors=sensors), true_model=true, trajectory=traj,
            nominal_model=rv3sb,
        )  # fmt: skip
        return RunStation(st, periods=0.15)

    a, b, c = run(11), run(11), run(12)
    M = a.n_samples
    clean = dataclasses.replace(
        clean, t=clean.t[:M], q=clean.q[:M], tau=clean.tau[:M], qd=clean.qd[:M],
        qdd=clean.qdd[:M],
    )  # fmt: skip
    np.testing.assert_array_equal(a.tau, b.tau)  # same seed, same noise
    assert not np.allclose(a.tau, c.tau)
    # Sensor effects do not feed back: the motion is the clean run's (to the
    # integrator's round-off), so the differences are the sensor errors.
    noise = a.tau - clean.tau
    assert abs(noise.std() / sigma - 1) < 0.1  # 1350 samples: 1.9 % std error
    assert abs(noise.mean()) < 4 * sigma / np.sqrt(noise.size)
    assert abs(np.corrcoef(noise[1:].ravel(), noise[:-1].ravel())[0, 1]) < 0.1
    np.testing.assert_allclose(a.q / res, np.round(a.q / res), atol=1e-6)
    assert np.abs(a.q - clean.q).max() <= 0.5 * res + 1e-9
    np.testing.assert_allclose(a.qd, clean.qd, atol=1e-9)


# ---- bad input --------------------------------------------------------------------
def _five_joints(model: RobotModel) -> RobotModel:
    lim = model.limits
    return RobotModel(
        name="five",
        mdh=model.mdh[:5],
        tool=model.tool,
        limits=type(lim)(*(getattr(lim, k)[:5] for k in (
            "lower", "upper", "velocity", "acceleration", "effort"))),
        dynamics=model.dynamics[:5],
    )  # fmt: skip


def test_station_bad_input(rv3sb, traj) -> None:
    def make(model=rv3sb, trajectory=traj, nominal_model=None, **config):
        return MakeStation(
            StationConfig(**config), true_model=model, trajectory=trajectory,
            nominal_model=nominal_model,
        )  # fmt: skip

    with pytest.raises(ValueError, match="nominal robot 'five' has 5 joints"):
        make(nominal_model=_five_joints(rv3sb))
    tr5 = FourierTrajectory(
        base_frequency=0.1, q0=traj.q0[:5], a=traj.a[:5], b=traj.b[:5]
    )
    with pytest.raises(ValueError, match="trajectory has 5 joints but robot"):
        make(trajectory=tr5)
    d = np.array(rv3sb.dynamics)
    d[2, 0] = -0.1  # XX3 < 0: no mass distribution has this inertia
    with pytest.raises(ValueError, match="link 3: pseudo-inertia PSD fails"):
        make(model=rv3sb.with_dynamics(d))
    d = np.array(rv3sb.dynamics)
    d[4, 12] = -1.0
    with pytest.raises(ValueError, match="link 5: fc >= 0 fails"):
        make(nominal_model=rv3sb.with_dynamics(d))
    with pytest.raises(ValueError, match="expected a 'dynamics' section"):
        make(model=rv3sb.with_dynamics(None))
    with pytest.raises(ValueError, match="sensors.torque_noise: expected finite"):
        make(sensors=SensorConfig(torque_noise=np.nan))
    with pytest.raises(ValueError, match="sensors.encoder_resolution: expected >= 0"):
        make(sensors=SensorConfig(encoder_resolution=[1e-4] * 5 + [-1e-4]))
    with pytest.raises(ValueError, match="controller.kp: expected shape"):
        make(controller=InverseDynamicsControllerConfig(kp=[1.0, 2.0]))
    with pytest.raises(ValueError, match="controller.bandwidth: expected a positive"):
        make(controller=PidControllerConfig(bandwidth=0.0))
    with pytest.raises(ValueError, match="log_period"):
        make(log_period=0.0)
    with pytest.raises(ValueError, match="time_step"):
        make(time_step=-1e-3)
    with pytest.raises(TypeError, match="controller: expected one of"):
        make(controller=SensorConfig())
    with pytest.raises(TypeError, match="config: expected a StationConfig"):
        MakeStation(rv3sb, true_model=rv3sb, trajectory=traj)
    bare = MakeStation(
        StationConfig(), true_model=rv3sb, trajectory=traj, joint_logs=False
    )
    assert bare.loggers == {}
    with pytest.raises(ValueError, match="built without one .*joint_logs=False"):
        RunStation(bare, duration=0.1)


# ---- CLI --------------------------------------------------------------------------
def test_cli_simulate_round_trip(tmp_path, rv3sb, traj, capsys) -> None:
    true_path = perturbed(rv3sb, seed=2).save(tmp_path / "true.yaml")
    traj_path = traj.save(tmp_path / "traj.yaml")
    out = tmp_path / "log.csv"
    rc = main([
        "simulate", "--robot", str(true_path), "--trajectory", str(traj_path),
        "--out", str(out), "--periods", "0.1", "--noise", "0.01", "--seed", "3",
    ])  # fmt: skip
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "controller model 'rv3sb'" in text and "150 samples x 6 joints" in text
    log = read_joint_log(out, n_joints=6)
    assert log.n_samples == 150 and log.qd is not None and log.qdd is not None
    header = out.read_text().splitlines()[0].split(",")
    assert header[:3] == ["t", "q1", "q2"] and header[-1] == "qdd6"
    rc = main([
        "simulate", "--robot", str(true_path), "--trajectory", str(traj_path),
        "--out", str(tmp_path / "q_only.npz"), "--periods", "0.05",
        "--rate", "100", "--no-derivatives",
    ])  # fmt: skip
    assert rc == 0
    q_only = read_joint_log(tmp_path / "q_only.npz")
    assert q_only.n_samples == 50 and q_only.qd is None


def _bad_cli(tmp_path, capsys, args: list[str], message: str) -> None:
    out = tmp_path / "never.csv"
    rc = main(["simulate", *args, "--out", str(out), "--periods", "0.01"])
    err = capsys.readouterr().err.strip()
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


def test_cli_simulate_bad_input(tmp_path, rv3sb, traj, capsys) -> None:
    good = str(traj.save(tmp_path / "traj.yaml"))
    tr5 = FourierTrajectory(
        base_frequency=0.1, q0=traj.q0[:5], a=traj.a[:5], b=traj.b[:5]
    )
    _bad_cli(
        tmp_path, capsys,
        ["--robot", "rv3sb", "--trajectory", str(tr5.save(tmp_path / "t5.yaml"))],
        "trajectory has 5 joints but robot 'rv3sb' has 6",
    )  # fmt: skip
    nan = tmp_path / "nan.yaml"
    text = (tmp_path / "traj.yaml").read_text()
    nan.write_text(text.replace("base_frequency: 0.1", "base_frequency: .nan"))
    _bad_cli(
        tmp_path, capsys, ["--robot", "rv3sb", "--trajectory", str(nan)],
        "base_frequency: expected a finite number",
    )  # fmt: skip
    fast = dataclasses.replace(traj, a=traj.a * 4, b=traj.b * 4)
    _bad_cli(
        tmp_path, capsys,
        ["--robot", "rv3sb", "--trajectory", str(fast.save(tmp_path / "f.yaml"))],
        "trajectory violates the limits of robot 'rv3sb': joint",
    )  # fmt: skip
    d = np.array(rv3sb.dynamics)
    d[1, 9] = -2.0  # negative mass of link 2
    bad_robot = rv3sb.with_dynamics(d).save(tmp_path / "bad_robot.yaml")
    _bad_cli(
        tmp_path, capsys, ["--robot", str(bad_robot), "--trajectory", good],
        "dynamics[1] (link 2): mass M = -2 kg is negative",
    )  # fmt: skip
    _bad_cli(
        tmp_path, capsys,
        ["--robot", "rv3sb", "--trajectory", good, "--noise", "0.1,x"],
        "--noise: expected a number or a comma-separated list",
    )  # fmt: skip


def test_context_parameters_change_the_run(rv3sb, traj) -> None:
    # Friction and trajectory live in the Context: a run with other values needs
    # no rebuild, and the oracle follows the new truth. The given context is
    # copied, so it can be reused.
    st = MakeStation(StationConfig(), true_model=rv3sb, trajectory=traj)
    ctx = st.CreateDefaultContext()
    fv = 2.0 * rv3sb.dynamics[:, 11]
    st.friction.SetFriction(st.friction.GetMyMutableContextFromRoot(ctx), fv=fv)
    log = RunStation(st, periods=0.03, context=ctx)
    again = RunStation(st, periods=0.03, context=ctx)
    np.testing.assert_array_equal(log.tau, again.tau)
    d = np.array(rv3sb.dynamics)
    d[:, 11] = fv
    Y = regressor(
        SerialChain.from_model(rv3sb), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    tau = Y @ standard_parameters(rv3sb.with_dynamics(d))
    assert np.all(np.abs(tau - log.tau) <= 1e-9 * np.abs(log.tau).max(axis=0))


def _weak_rv3sb(rv3sb: RobotModel) -> RobotModel:
    effort = np.array(rv3sb.limits.effort)
    effort[1] = 10.0  # joint 2 cannot hold the arm against gravity (~20 N m)
    return dataclasses.replace(
        rv3sb, limits=dataclasses.replace(rv3sb.limits, effort=effort)
    )


def test_saturation_is_logged(rv3sb, traj) -> None:
    # The plant clamps actuation to +-effort; the logged torque is the clamped
    # one, so the oracle holds.
    weak = _weak_rv3sb(rv3sb)
    st = MakeStation(StationConfig(), true_model=weak, trajectory=traj)
    log = RunStation(st, periods=0.03)
    np.testing.assert_allclose(np.abs(log.tau[1:, 1]), 10.0, rtol=1e-12)
    Y = regressor(
        SerialChain.from_model(weak), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(weak) - log.tau) <= 1e-9 * scale)


def test_cli_reports_saturation(tmp_path, rv3sb, traj, capsys) -> None:
    rc = main([
        "simulate", "--robot", str(_weak_rv3sb(rv3sb).save(tmp_path / "weak.yaml")),
        "--trajectory", str(traj.save(tmp_path / "traj.yaml")),
        "--out", str(tmp_path / "log.csv"), "--periods", "0.03",
    ])  # fmt: skip
    assert rc == 0
    assert "warning: joint 2 saturated at its effort limit 10 N m" in (
        capsys.readouterr().out
    )


# ---- configuration ----------------------------------------------------------------
def _configs() -> list[StationConfig]:
    return [
        StationConfig(),
        StationConfig(
            simulator=SimulatorConfig(
                integration_scheme="runge_kutta3",
                max_step_size=0.005,
                accuracy=1e-5,
                use_error_control=True,
            ),
            log_period=0.005,
            v_eps=2e-3,
            sensors=SensorConfig(
                torque_noise=[0.1, 0.2, 0.1, 0.05, 0.05, 0.02],
                encoder_resolution=1e-5,
                seed=7,
            ),
            controller=InverseDynamicsControllerConfig(
                bandwidth=30.0, kp=[100.0] * 6, friction_feedforward=False
            ),
        ),  # fmt: skip
        StationConfig(
            time_step=DEFAULT_TIME_STEP,
            controller=PidControllerConfig(
                bandwidth=25.0,
                ki=0.0,
                gravity_compensation=False,
                friction_feedforward=True,
            ),
        ),  # fmt: skip
    ]


@pytest.mark.parametrize("config", _configs(), ids=["default", "id", "pid"])
def test_config_yaml_round_trip(config: StationConfig) -> None:
    text = yaml_dump_typed(config)
    back = yaml_load_typed(schema=StationConfig, data=text)
    assert yaml_dump_typed(back) == text
    assert type(back.controller) is type(config.controller)
    # Every field survives (SimulatorConfig, a C++ struct, compares by its repr).
    for field in dataclasses.fields(StationConfig):
        a, b = getattr(config, field.name), getattr(back, field.name)
        if field.name == "simulator":
            assert repr(a) == repr(b)
        else:
            assert a == b, field.name
    # The default variant needs no tag; the others are selected by theirs.
    if isinstance(config.controller, PidControllerConfig):
        assert "controller: !PidControllerConfig" in text
    else:
        assert "!InverseDynamicsControllerConfig" not in text
    # Dumping against the defaults keeps only what differs, and loads back.
    short = yaml_dump_typed(config, defaults=StationConfig())
    again = yaml_load_typed(schema=StationConfig, data=short)
    assert yaml_dump_typed(again) == text


def test_config_yaml_hand_written() -> None:
    config = yaml_load_typed(
        schema=StationConfig,
        data="""
simulator: {accuracy: 1.0e-5}
log_period: 0.01
sensors: {torque_noise: [0.1, 0.1, 0.1, 0.05, 0.05, 0.05], encoder_resolution: 0}
controller: !PidControllerConfig
  bandwidth: 20
  kp: 500.0
""",
    )
    assert config.simulator.accuracy == 1e-5
    assert config.simulator.integration_scheme == "runge_kutta3"  # default kept
    assert config.simulator.max_step_size == pytest.approx(1 / 150)
    assert config.log_period == 0.01 and config.v_eps == V_EPS
    assert config.sensors.torque_noise == [0.1] * 3 + [0.05] * 3
    assert config.sensors.encoder_resolution == 0 and config.sensors.seed == 0
    assert config.controller == PidControllerConfig(bandwidth=20.0, kp=500.0)
    untagged = yaml_load_typed(schema=StationConfig, data="controller: {kd: [1, 2]}")
    assert untagged.controller == InverseDynamicsControllerConfig(kd=[1.0, 2.0])


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("log_perod: 0.01", "log_perod"),
        ("sensors: {torque_nosie: 0.1}", "torque_nosie"),
        ("controller: !PidControllerConfig {bandwith: 20.0}", "bandwith"),
        ("controller: !PidController {bandwidth: 20.0}", "PidController"),
        ("simulator: {acuracy: 1.0e-5}", "acuracy"),
    ],
)
def test_config_yaml_typo_names_the_key(text: str, key: str) -> None:
    with pytest.raises(RuntimeError, match=key):
        yaml_load_typed(schema=StationConfig, data=text)


# ---- joint selection --------------------------------------------------------------
def test_joint_state_selector_picks_joints_by_index() -> None:
    # A plant whose state is not [q_joints; v_joints]: a slider carries the arm
    # and a separate pendulum hangs from the world.
    plant = MultibodyPlant(0.0)
    inertia = SpatialInertia.SolidSphereWithMass(1.0, 0.1)
    cart, link1, link2, bob = (
        plant.AddRigidBody(name, inertia) for name in ("cart", "l1", "l2", "bob")
    )
    world = plant.world_frame()
    plant.AddJoint(PrismaticJoint("slider", world, cart.body_frame(), [1, 0, 0]))
    plant.AddJoint(RevoluteJoint("pendulum", world, bob.body_frame(), [0, 1, 0]))
    plant.AddJoint(
        RevoluteJoint("joint1", cart.body_frame(), link1.body_frame(), [0, 0, 1])
    )  # noqa: E501
    plant.AddJoint(
        RevoluteJoint("joint2", link1.body_frame(), link2.body_frame(), [0, 0, 1])
    )  # noqa: E501
    tool = plant.AddRigidBody("tool", inertia)
    plant.AddJoint(
        WeldJoint("weld", link2.body_frame(), tool.body_frame(), RigidTransform())
    )  # noqa: E501
    plant.Finalize()
    nq, nv = plant.num_positions(), plant.num_velocities()
    assert (nq, nv) == (4, 4)
    S = joint_state_selector(plant, ["joint2", "joint1"])
    x = 10.0 + np.arange(nq + nv)
    j1, j2 = plant.GetJointByName("joint1"), plant.GetJointByName("joint2")
    want = [
        x[j2.position_start()], x[j1.position_start()],
        x[nq + j2.velocity_start()], x[nq + j1.velocity_start()],
    ]  # fmt: skip
    np.testing.assert_array_equal(S @ x, want)
    assert {j1.position_start(), j2.position_start()} != {0, 1}  # not the first
    with pytest.raises(ValueError, match="joint 'weld': expected one dof"):
        joint_state_selector(plant, ["joint1", "weld"])


def test_station_joint_state_and_initial_state(rv3sb, traj) -> None:
    st = MakeStation(StationConfig(), true_model=rv3sb, trajectory=traj)
    n = st.n_joints
    S = st.joint_selector
    np.testing.assert_array_equal(
        S, joint_state_selector(st.plant, [f"joint{j}" for j in range(1, n + 1)])
    )
    # MakePlant's state is [q; v] of the joints alone: no selector system needed.
    np.testing.assert_array_equal(S, np.eye(2 * n))
    assert st.joint_state.get_system() is st.plant
    ctx = st.CreateDefaultContext()
    x = st.plant.GetPositionsAndVelocities(st.plant.GetMyContextFromRoot(ctx))
    joint_state = st.joint_state.Eval(
        st.joint_state.get_system().GetMyContextFromRoot(ctx)
    )
    np.testing.assert_array_equal(joint_state, S @ x)
    np.testing.assert_allclose(joint_state[:n], traj.q0, atol=1e-12)
    np.testing.assert_allclose(joint_state[n:], 0.0, atol=1e-12)  # starts at rest


# ---- the PID variant --------------------------------------------------------------
def test_pid_tracks_slow_trajectory(rv3sb) -> None:
    """PID + gravity compensation + friction feedforward, all on the nominal
    model, on the +-15 % / +-20 % perturbed truth: a 0.05 Hz trajectory (top
    harmonic 0.25 Hz = 1.6 rad/s, 25x below the 40 rad/s bandwidth) is tracked
    within 0.25 deg on every joint over 2 s (measured 0.12 deg on the wrist,
    from the model error in gravity and friction; the missing inertia
    feedforward adds little that slowly). The torque oracle does not depend on
    the controller: it holds to the same 1e-9."""
    true = perturbed(rv3sb, seed=2)
    slow = random_fourier_trajectory(rv3sb, seed=1, fill=0.5, base_frequency=0.05)
    config = StationConfig(controller=PidControllerConfig(friction_feedforward=True))
    st = MakeStation(config, true_model=true, trajectory=slow, nominal_model=rv3sb)
    # Gains from the bandwidth: 3 w^2, 3 w, w^3 times the nominal mass-matrix
    # diagonal at the trajectory's start (N m/rad, N m s/rad, N m/(rad s)).
    plant, _ = MakePlant(rv3sb, visual=False)
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, slow.q0)
    J = np.diag(plant.CalcMassMatrix(plant_context))
    pid = st.diagram.GetSubsystemByName("controller")
    np.testing.assert_allclose(pid.get_Kp_vector(), 3 * 40.0**2 * J, rtol=1e-12)
    np.testing.assert_allclose(pid.get_Kd_vector(), 3 * 40.0 * J, rtol=1e-12)
    np.testing.assert_allclose(pid.get_Ki_vector(), 40.0**3 * J, rtol=1e-12)
    log = RunStation(st, periods=0.1)
    assert log.n_samples == 300
    err = np.abs(log.q - slow.q(log.t)).max(axis=0)
    assert np.all(err < np.radians(0.25)), np.degrees(err)
    Y = regressor(
        SerialChain.from_model(true), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(true) - log.tau) <= 1e-9 * scale)


# ---- AddToBuilder helpers ---------------------------------------------------------
def test_sensor_helpers_add_to_builder() -> None:
    builder = DiagramBuilder()
    angles = builder.AddSystem(ConstantVectorSource([0.12345, -0.12345]))
    encoder = EncoderQuantizer.AddToBuilder(
        builder, angles.get_output_port(), resolution=[1e-3, 0.0], name="enc"
    )
    torques = builder.AddSystem(ConstantVectorSource([1.0, 2.0, 3.0]))
    noisy = AddTorqueSensorNoise(
        builder, torques.get_output_port(), std=[0.0, 0.5, 2.0], sample_period=0.01
    )
    builder.ExportOutput(noisy, "tau")
    diagram = builder.Build()
    assert encoder.get_name() == "enc"
    assert diagram.GetSubsystemByName("torque_sensor_noise") is not None

    def measure(seed: int) -> tuple[np.ndarray, np.ndarray]:
        ctx = diagram.CreateDefaultContext()
        diagram.SetRandomContext(ctx, RandomGenerator(seed))
        q = encoder.get_output_port().Eval(encoder.GetMyContextFromRoot(ctx))
        return q, diagram.GetOutputPort("tau").Eval(ctx)

    (q, a), (_, b), (_, c) = measure(1), measure(1), measure(2)
    np.testing.assert_allclose(q, [0.123, -0.12345], atol=1e-15)
    assert a[0] == 1.0 and a[1] != 2.0  # std 0: exact; std > 0: noisy
    np.testing.assert_array_equal(a, b)  # seeded
    assert not np.array_equal(a, c)
    with pytest.raises(ValueError, match="torque noise: expected >= 0 N m"):
        AddTorqueSensorNoise(
            DiagramBuilder(), torques.get_output_port(), std=[0.0, -1.0, 0.0],
            sample_period=0.01,
        )  # fmt: skip


def test_station_with_selector_systems_matches(rv3sb, traj, monkeypatch) -> None:
    # The MatrixGain path (taken when the plant state holds more than the
    # joints) is wired like the direct one: forced on for MakePlant's plant, it
    # logs the same numbers bit for bit (a 0/1 selection is exact).
    def run():
        st = MakeStation(StationConfig(), true_model=rv3sb, trajectory=traj)
        return st, RunStation(st, periods=0.03)

    _, direct = run()

    from rmdrake.systems.joint_state import add_selector

    monkeypatch.setattr(station_module, "_map_port", add_selector)
    st, selected = run()
    assert st.joint_state.get_system().get_name() == "joint_state"
    assert st.diagram.GetSubsystemByName("joint_accelerations") is not None
    for name in ("q", "qd", "qdd", "tau"):
        np.testing.assert_array_equal(getattr(selected, name), getattr(direct, name))


# ---- point-to-point motion: a pydrake Trajectory as the desired motion ------------
def test_setpoint_trajectory_moves_holds_and_limits(rv3sb) -> None:
    rng = np.random.default_rng(5)
    lo, hi = rv3sb.limits.lower, rv3sb.limits.upper
    q_list = rng.uniform(0.8 * lo, 0.8 * hi, (3, 6))
    q_start = np.zeros(6)
    v_max, a_max = 0.5 * rv3sb.limits.velocity, 0.5 * rv3sb.limits.acceleration
    moves = setpoint_move_times(
        q_list, velocity=v_max, acceleration=a_max, q_start=q_start
    )
    pp = setpoint_trajectory(q_list, move_time=moves, settle_time=0.4, q_start=q_start)
    ends = setpoint_times(3, move_time=moves, settle_time=0.4)
    np.testing.assert_allclose(ends, np.cumsum(moves + 0.4), rtol=1e-14)  # sums
    assert (pp.start_time(), pp.end_time()) == (0.0, ends[-1])
    np.testing.assert_array_equal(pp.value(0.0)[:, 0], q_start)
    for i, t in enumerate(ends):
        for at in (t - 0.4, t - 0.2, t):  # the hold: at rest on q_list[i]
            np.testing.assert_allclose(pp.value(at)[:, 0], q_list[i], atol=1e-12)
            for order in (1, 2):
                np.testing.assert_allclose(
                    pp.EvalDerivative(at, order)[:, 0], 0.0, atol=1e-9
                )
    # Smooth through every break: q, v, vdot continuous (quintic end conditions).
    for t in pp.get_segment_times()[1:-1]:
        for order in (0, 1, 2):
            before, after = (pp.EvalDerivative(t + s, order) for s in (-1e-9, 1e-9))
            np.testing.assert_allclose(before, after, atol=1e-6)
    # The move times keep every joint within the velocity and acceleration
    # limits given, and one joint of each move reaches one of them.
    t = np.linspace(0.0, pp.end_time(), 4001)
    v = np.array([pp.EvalDerivative(x, 1)[:, 0] for x in t])
    a = np.array([pp.EvalDerivative(x, 2)[:, 0] for x in t])
    assert np.all(np.abs(v) <= v_max * (1 + 1e-9))
    assert np.all(np.abs(a) <= a_max * (1 + 1e-9))
    assert max(np.max(np.abs(v) / v_max), np.max(np.abs(a) / a_max)) > 0.99
    same = setpoint_trajectory(q_list, move_time=1.0, settle_time=0.0)
    assert same.end_time() == 3.0 and same.get_number_of_segments() == 3
    with pytest.raises(ValueError, match="move_time: expected one value or 3"):
        setpoint_trajectory(q_list, move_time=[1.0, 0.0, 1.0], settle_time=0.1)
    with pytest.raises(ValueError, match="settle_time: expected >= 0 s"):
        setpoint_trajectory(q_list, move_time=1.0, settle_time=-0.1)


def test_station_follows_setpoints(rv3sb) -> None:
    """The +-15 % / +-20 % perturbed truth under the nominal inverse-dynamics
    controller, driven through three configurations (1 s moves, within the
    joint limits, 0.3 s holds): the source is a JointTrajectorySource, the run
    goes to the trajectory's end, the arm is on each configuration within
    1e-3 rad at the hold's end (measured 5e-4 rad: the model error, which the
    integral action removes against the Coulomb friction at rest), and the
    torque oracle holds as for Fourier runs."""
    true = perturbed(rv3sb, seed=2)
    rng = np.random.default_rng(6)
    q_list = rng.uniform(0.5 * rv3sb.limits.lower, 0.5 * rv3sb.limits.upper, (3, 6))
    pp = setpoint_trajectory(q_list, move_time=1.0, settle_time=0.3)
    v_eps = 1e-2  # a cheaper hold for the explicit integrator (see measurement_runs)
    config = StationConfig(v_eps=v_eps)
    st = MakeStation(config, true_model=true, trajectory=pp, nominal_model=rv3sb)
    assert isinstance(st.source, JointTrajectorySource)
    assert st.diagram.GetSubsystemByName("desired_motion") is st.source
    ctx = st.CreateDefaultContext()
    x0 = st.plant.GetPositionsAndVelocities(st.plant.GetMyContextFromRoot(ctx))
    np.testing.assert_array_equal(x0, np.concatenate([q_list[0], np.zeros(6)]))
    log = RunStation(st)
    assert log.n_samples == 585  # 3.9 s at 150 Hz
    ends = setpoint_times(3, move_time=1.0, settle_time=0.3)
    k = np.rint(ends[:-1] * 150).astype(int)  # the last end is the run's end
    np.testing.assert_allclose(log.t[k], ends[:-1], rtol=0, atol=1e-9)
    err = np.abs(log.q[k] - q_list[:-1]).max()
    assert err < 1e-3, err
    Y = regressor(
        SerialChain.from_model(true), log.q, log.qd, log.qdd, coulomb_width=v_eps
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(true) - log.tau) <= 1e-9 * scale)
    assert RunStation(st, duration=0.5).n_samples == 75
    with pytest.raises(ValueError, match="periods: the station follows a Traj"):
        RunStation(st, periods=1.0)
    with pytest.raises(ValueError, match="periods, duration: give one"):
        RunStation(
            MakeStation(config, true_model=rv3sb, trajectory=random_fourier_trajectory(
                rv3sb, seed=1)), periods=1.0, duration=1.0,
        )  # fmt: skip


def test_trajectory_station_pid_gains_and_bad_input(rv3sb, traj) -> None:
    # The PID gains use the mass matrix where the motion starts: the
    # trajectory's value at its start time.
    q_list = np.array([[0.3, 0.2, 0.9, -0.4, 0.5, 0.1], [0.0, 0.4, 1.1, 0.0, 0.3, 0.0]])
    q_start = np.array([0.1, 0.1, 1.0, 0.2, 0.4, -0.3])
    pp = setpoint_trajectory(q_list, move_time=1.0, settle_time=0.5, q_start=q_start)
    config = StationConfig(controller=PidControllerConfig())
    st = MakeStation(config, true_model=rv3sb, trajectory=pp)
    plant, _ = MakePlant(rv3sb, visual=False)
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, q_start)
    J = np.diag(plant.CalcMassMatrix(plant_context))
    pid = st.diagram.GetSubsystemByName("controller")
    np.testing.assert_allclose(pid.get_Kp_vector(), 3 * 40.0**2 * J, rtol=1e-12)
    with pytest.raises(ValueError, match=r"trajectory has shape \(5, 1\) but robot"):
        MakeStation(
            StationConfig(), true_model=rv3sb,
            trajectory=setpoint_trajectory(q_list[:, :5], move_time=1, settle_time=0),
        )  # fmt: skip
    with pytest.raises(TypeError, match="expected a FourierTrajectory or a pydrake"):
        MakeStation(StationConfig(), true_model=rv3sb, trajectory=q_list)


# ---- offsets and asymmetric Coulomb friction (issue 12 item 4) ----------------------
def test_station_with_offsets_and_asymmetric_coulomb(rv3sb, traj) -> None:
    """A true robot with joint offsets and asymmetric Coulomb friction: the
    friction system outputs the law, the logged torque is the extended
    regressor's (1e-9 of each joint's peak), and identifying the log with
    those terms gives back the truth's base parameters (1e-6)."""
    from rmdrake.dynamics.identification import identify
    from rmdrake.dynamics.regressor import torques
    from rmdrake.model.dynamic_parameters import extended_parameters
    from rmdrake.model.robot import DynamicTerms

    fv, fc, fcn = np.array([2.0, 0.5]), np.array([3.0, 1.0]), np.array([1.0, 2.5])
    tau0, v = np.array([0.7, -0.4]), np.array([0.3, -0.2])
    sys_ = JointFriction(fv=fv, fc=fc, fcn=fcn, tau0=tau0, input="v")
    ctx = sys_.CreateDefaultContext()
    sys_.get_input_port().FixValue(ctx, v)
    want = -(fv * v + np.where(v > 0, fc, -fcn) * np.abs(np.tanh(v / V_EPS)) + tau0)
    np.testing.assert_allclose(sys_.get_output_port().Eval(ctx), want, atol=1e-14)
    sys_.SetFriction(ctx, fc=[1.0, 1.0])  # asymmetric: fcn kept
    np.testing.assert_array_equal(sys_.GetExtraTerms(ctx)[0], fcn)
    with pytest.raises(ValueError, match="fcn: expected >= 0"):
        JointFriction(fv=fv, fc=fc, fcn=[1.0, -1.0])

    rng = np.random.default_rng(5)
    base = perturbed(rv3sb, seed=3)
    true = dataclasses.replace(
        base,
        fcn=base.dynamics[:, 12] * rng.uniform(0.5, 1.5, 6),
        tau0=rng.uniform(-1.0, 1.0, 6),
    )
    station = MakeStation(
        StationConfig(), true_model=true, trajectory=traj, nominal_model=rv3sb
    )
    log = RunStation(station, periods=0.5)
    chi = extended_parameters(true)
    tau = torques(true, log.q, log.qd, log.qdd, chi, coulomb_width=V_EPS)
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(tau - log.tau) <= 1e-9 * scale)

    from rmdrake.dynamics.data import JointSamples

    # Offsets and both Coulomb levels regroup (fc - fcn = offset's column where
    # sign(qd) = +-1), which tanh breaks only near qd = 0: identify with the
    # exact sign on the samples where every |qd| > 10 v_eps (|tanh - sign| <
    # 4e-9 there).
    away = np.all(np.abs(log.qd) > 10 * V_EPS, axis=1)
    assert away.mean() > 0.5
    samples = JointSamples(log.t, log.q, log.qd, log.qdd, log.tau, 150.0)
    samples = samples.select(away)
    terms = DynamicTerms(offset=True, coulomb_asymmetric=True)
    model = dataclasses.replace(rv3sb, terms=terms)
    result = identify(model, samples, method="ols")
    truth = result.base.K_full @ chi
    assert np.abs(result.params - truth).max() < 1e-6 * np.abs(truth).max()
    # The symmetric model without offsets cannot explain this log.
    plain = identify(rv3sb, samples, method="ols")
    assert plain.residual_rms.max() > 1e3 * result.residual_rms.max()


def test_a_station_config_pickles_with_its_simulator_settings():
    """A study's task sends its station config to a Dask worker: Drake's
    SimulatorConfig inside it arrives with every field."""
    import pickle

    config = StationConfig(
        simulator=SimulatorConfig(integration_scheme="runge_kutta2", max_step_size=1e-3)
    )
    back = pickle.loads(pickle.dumps(config))
    assert back.simulator.integration_scheme == "runge_kutta2"
    assert back.simulator.max_step_size == 1e-3
    assert back.simulator.accuracy == config.simulator.accuracy
