"""The true-robot station: friction, sensors, torque oracle, CLI."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rmdrake import (
    FourierTrajectory,
    RobotModel,
    load_robot,
    random_fourier_trajectory,
    read_joint_log,
)
from rmdrake.cli import main
from rmdrake.dynamics import SerialChain, regressor, standard_parameters
from rmdrake.systems import (
    EncoderQuantizer,
    JointFriction,
    MakeStation,
    RunStation,
    friction_torque,
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
    station = MakeStation(true, trajectory=traj, nominal_model=rv3sb)
    return true, RunStation(station, periods=0.3)


# ---- friction ---------------------------------------------------------------------
def test_joint_friction_outputs_documented_force() -> None:
    fv, fc = np.array([2.0, 0.5, 1.0]), np.array([3.0, 1.0, 0.0])
    v = np.array([0.3, -2e-3, 0.0])
    smooth = JointFriction(fv=fv, fc=fc, v_eps=V_EPS)
    ctx = smooth.CreateDefaultContext()
    smooth.get_input_port().FixValue(ctx, np.r_[np.ones(3), v])  # [q; v]
    want = -(fv * v + fc * np.tanh(v / V_EPS))
    np.testing.assert_allclose(smooth.get_output_port().Eval(ctx), want, atol=1e-15)
    np.testing.assert_allclose(want, -friction_torque(v, fv, fc, V_EPS), atol=0)

    exact = JointFriction(fv=fv, fc=fc, exact_sign=True, input="v")
    ctx = exact.CreateDefaultContext()
    exact.get_input_port().FixValue(ctx, v)
    np.testing.assert_allclose(
        exact.get_output_port().Eval(ctx), -(fv * v + fc * np.sign(v)), atol=1e-15
    )
    # Parameters live in the Context.
    exact.SetFriction(ctx, fc=[1.0, 1.0, 1.0])
    assert exact.GetFriction(ctx)[1].tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_allclose(
        exact.get_output_port().Eval(ctx), -(fv * v + np.sign(v)), atol=1e-15
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
    log = RunStation(MakeStation(true, trajectory=tr, nominal_model=model), periods=0.1)
    Y = regressor(
        SerialChain.from_model(true), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(true) - log.tau) <= 1e-9 * scale)


def test_sensor_effects_seeded(rv3sb, traj, clean_run) -> None:
    true, clean = clean_run
    sigma, res = 0.05, 1e-4

    def run(seed: int):
        st = MakeStation(
            true, trajectory=traj, nominal_model=rv3sb, torque_noise=sigma,
            encoder_resolution=res, seed=seed,
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


def test_discrete_plant_runs(rv3sb, traj) -> None:
    # Accepted but not the default: qdd is a one-step difference there.
    st = MakeStation(rv3sb, trajectory=traj, time_step=1e-3)
    log = RunStation(st, periods=0.02)
    assert log.n_samples == 30 and np.all(np.isfinite(log.tau))


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
    with pytest.raises(ValueError, match="nominal robot 'five' has 5 joints"):
        MakeStation(rv3sb, trajectory=traj, nominal_model=_five_joints(rv3sb))
    tr5 = FourierTrajectory(
        base_frequency=0.1, q0=traj.q0[:5], a=traj.a[:5], b=traj.b[:5]
    )
    with pytest.raises(ValueError, match="trajectory has 5 joints but robot"):
        MakeStation(rv3sb, trajectory=tr5)
    d = np.array(rv3sb.dynamics)
    d[2, 0] = -0.1  # XX3 < 0: no mass distribution has this inertia
    with pytest.raises(ValueError, match="link 3: pseudo-inertia PSD fails"):
        MakeStation(rv3sb.with_dynamics(d), trajectory=traj)
    d = np.array(rv3sb.dynamics)
    d[4, 12] = -1.0
    with pytest.raises(ValueError, match="link 5: fc >= 0 fails"):
        MakeStation(rv3sb, trajectory=traj, nominal_model=rv3sb.with_dynamics(d))
    with pytest.raises(ValueError, match="expected a 'dynamics' section"):
        MakeStation(rv3sb.with_dynamics(None), trajectory=traj)
    with pytest.raises(ValueError, match="torque noise: expected finite"):
        MakeStation(rv3sb, trajectory=traj, torque_noise=np.nan)
    with pytest.raises(ValueError, match="kp: expected shape"):
        MakeStation(rv3sb, trajectory=traj, kp=[1.0, 2.0])
    with pytest.raises(ValueError, match="log_period"):
        MakeStation(rv3sb, trajectory=traj, log_period=0.0)


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
        "link 2: mass > 0 fails",
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
    st = MakeStation(rv3sb, trajectory=traj)
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


def test_saturation_is_logged_and_reported(tmp_path, rv3sb, traj, capsys) -> None:
    # The plant clamps actuation to +-effort; the logged torque is the clamped
    # one, so the oracle holds, and the CLI reports the saturated joint.
    effort = np.array(rv3sb.limits.effort)
    effort[1] = 10.0  # joint 2 cannot hold the arm against gravity (~20 N m)
    weak = dataclasses.replace(
        rv3sb, limits=dataclasses.replace(rv3sb.limits, effort=effort)
    )
    log = RunStation(MakeStation(weak, trajectory=traj), periods=0.03)
    np.testing.assert_allclose(np.abs(log.tau[1:, 1]), 10.0, rtol=1e-12)
    Y = regressor(
        SerialChain.from_model(weak), log.q, log.qd, log.qdd, coulomb_width=V_EPS
    )
    scale = np.abs(log.tau).max(axis=0)
    assert np.all(np.abs(Y @ standard_parameters(weak) - log.tau) <= 1e-9 * scale)
    rc = main([
        "simulate", "--robot", str(weak.save(tmp_path / "weak.yaml")),
        "--trajectory", str(traj.save(tmp_path / "traj.yaml")),
        "--out", str(tmp_path / "log.csv"), "--periods", "0.03",
    ])  # fmt: skip
    assert rc == 0
    assert "warning: joint 2 saturated at its effort limit 10 N m" in (
        capsys.readouterr().out
    )
