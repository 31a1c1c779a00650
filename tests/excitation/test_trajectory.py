"""Fourier excitation trajectory (paper eq. 11-13), its YAML and the joint log."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
import yaml
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource

from rmdrake import (
    FourierTrajectory,
    JointLog,
    load_fourier,
    load_robot,
    random_fourier_trajectory,
    read_joint_log,
    write_joint_log,
)
from rmdrake.excitation.trajectory import fourier_series
from rmdrake.systems import FourierExcitationSource, FourierTrajectoryView


@pytest.fixture(scope="module")
def traj() -> FourierTrajectory:
    rng = np.random.default_rng(7)
    return FourierTrajectory(
        base_frequency=0.1,
        q0=rng.uniform(-1, 1, 6),
        a=0.2 * rng.standard_normal((6, 5)),
        b=0.2 * rng.standard_normal((6, 5)),
    )


def test_matches_paper_equations(traj: FourierTrajectory) -> None:
    # Eq. 11-13 written out term by term at one time (q0 added to eq. 11).
    t = 3.21
    w = 2 * np.pi * 0.1
    l = np.arange(1, 6)
    q = traj.q0 + (traj.a / (w * l)) @ np.sin(w * l * t)
    q -= (traj.b / (w * l)) @ np.cos(w * l * t)
    qd = traj.a @ np.cos(w * l * t) + traj.b @ np.sin(w * l * t)
    qdd = w * ((traj.b * l) @ np.cos(w * l * t) - (traj.a * l) @ np.sin(w * l * t))
    np.testing.assert_allclose(traj.q(t), q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(traj.qd(t), qd, rtol=0, atol=1e-14)
    np.testing.assert_allclose(traj.qdd(t), qdd, rtol=0, atol=1e-13)


def test_derivatives_equal_central_differences(traj: FourierTrajectory) -> None:
    # Central difference error is h^2/6 max|x'''| <= h^2/6 * sum (w l)^2 |a|+|b|
    # ~ 2e-8 * 10 for h = 1e-4 s; round-off eps*|q|/h ~ 1e-11. Tolerance 1e-6.
    t = np.linspace(0.0, 20.0, 101)
    h = 1e-4
    for order in (0, 1, 2):
        fd = (traj.derivative(t + h, order) - traj.derivative(t - h, order)) / (2 * h)
        np.testing.assert_allclose(fd, traj.derivative(t, order + 1), rtol=0, atol=1e-6)


def test_periodic_and_shapes(traj: FourierTrajectory) -> None:
    t = np.linspace(0.0, 10.0, 37)
    for k in range(3):
        x0 = traj.derivative(t, k)
        assert x0.shape == (37, 6)
        np.testing.assert_allclose(traj.derivative(t + traj.period, k), x0, atol=1e-12)
        np.testing.assert_allclose(
            traj.derivative(t + 3 * traj.period, k), x0, atol=1e-11
        )
    assert traj.q(1.0).shape == (6,)
    assert traj.period == pytest.approx(10.0)


def test_sample_counts_paper() -> None:
    # Paper §4: 150 Hz and 0.1 Hz give 1500 samples per period.
    tr = random_fourier_trajectory(load_robot("rv3sb"), seed=1)
    t, q, qd, qdd = tr.sample(150.0, 1)
    assert t.shape == (1500,) and q.shape == qd.shape == qdd.shape == (1500, 6)
    assert t[-1] == pytest.approx(10.0 - 1 / 150)
    assert tr.sample(150.0, 2)[0].shape == (3000,)


def test_random_trajectory_satisfies_eq17_and_limits() -> None:
    for name in ("rv3sb", "demo_rh"):
        model = load_robot(name)
        tr = random_fourier_trajectory(model, seed=3, fill=0.9)
        tr.check_limits(model)
        # Starts at rest at q0 (eq. 17 equalities).
        np.testing.assert_allclose(tr.q(0.0), tr.q0, atol=1e-12)
        np.testing.assert_allclose(tr.qd(0.0), 0.0, atol=1e-12)
        np.testing.assert_allclose(tr.qdd(0.0), 0.0, atol=1e-12)


def test_limit_violation_names_joint_and_excess() -> None:
    model = load_robot("rv3sb")
    tr = random_fourier_trajectory(model, seed=3, fill=0.5)
    a = tr.a.copy()
    a[3] *= 10.0  # joint 4 way too fast
    bad = FourierTrajectory(base_frequency=0.1, q0=tr.q0, a=a, b=tr.b * 0)
    with pytest.raises(ValueError, match=r"joint 4 .* by [0-9.]+ rad"):
        bad.check_limits(model)
    short = FourierTrajectory(base_frequency=0.1, q0=tr.q0[:5], a=a[:5], b=a[:5])
    with pytest.raises(ValueError, match="trajectory has 5 joints but robot"):
        short.check_limits(model)


def test_check_covers_one_period(traj: FourierTrajectory) -> None:
    # One 10 s period sampled at 150 Hz spans 10 - 1/150 s: accepted; half of it,
    # or fewer than two samples, is refused with the span and the period.
    traj.check_covers(np.arange(1500) / 150.0)
    traj.check_covers(3.0 + np.arange(3000) / 150.0)
    with pytest.raises(ValueError, match=r"^log x covers 4.993 s, shorter than one"):
        traj.check_covers(np.arange(750) / 150.0, "log x")
    with pytest.raises(ValueError, match=r"covers 0 s.*\(10 s\)"):
        traj.check_covers(np.array([2.0]))


def test_yaml_round_trip(tmp_path, traj: FourierTrajectory) -> None:
    path = traj.save(tmp_path / "sub" / "traj.yaml")
    back = load_fourier(path)
    assert back.base_frequency == traj.base_frequency
    for key in ("q0", "a", "b"):
        np.testing.assert_array_equal(getattr(back, key), getattr(traj, key))
    text = path.read_text()
    for key in ("base_frequency", "harmonics", "q0", "a", "b"):
        assert f"{key}:" in text
    assert FourierTrajectory.load(path).harmonics == 5


@pytest.mark.parametrize(
    "text, message",
    [
        ("[1, 2]", "expected a mapping at top level"),
        ("{base_frequency: 0.1, harmonics: 1, q0: [0], a: [[0]]}", "missing key 'b'"),
        (
            "{base_frequency: 0.1, harmonics: 2, q0: [0], a: [[0, 1]], b: [[0]]}",
            r"b\[0\]: expected 2 coefficients",
        ),
        (
            "{base_frequency: 0.1, harmonics: 1, q0: [0, 0], a: [[0]], b: [[0]]}",
            "a: expected 2 rows",
        ),
        (
            "{base_frequency: -1, harmonics: 1, q0: [0], a: [[0]], b: [[0]]}",
            "base_frequency: expected a positive",
        ),
        (
            "{base_frequency: 0.1, harmonics: 1, q0: [.nan], a: [[0]], b: [[0]]}",
            r"q0\[0\]: expected a finite number",
        ),
        (
            "{base_frequency: 0.1, harmonics: 1.5, q0: [0], a: [[0]], b: [[0]]}",
            "harmonics: expected a positive integer",
        ),
        (
            "{base_frequency: 0.1, harmonics: 1, q0: [0], a: [[x]], b: [[0]]}",
            r"a\[0\]\[0\]: expected a number",
        ),
        (
            "{base_frequency: 0.1, harmonics: 1, q0: [0], a: [[0]], b: [[0]], c: 1}",
            "unknown key",
        ),
        ("{a: [", "not valid YAML"),
    ],
)
def test_bad_yaml(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as err:
        load_fourier(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)
    with pytest.raises(ValueError, match="cannot read trajectory YAML"):
        load_fourier(tmp_path / "missing.yaml")


def test_pydrake_trajectory_in_trajectory_source(traj: FourierTrajectory) -> None:
    # Exact evaluation: equal to the numpy values to round-off.
    builder = DiagramBuilder()
    src = builder.AddSystem(TrajectorySource(FourierTrajectoryView(traj), 2))
    logger = LogVectorOutput(src.get_output_port(), builder, 0.25)
    sim = Simulator(builder.Build())
    sim.AdvanceTo(12.0)
    log = logger.FindLog(sim.get_context())
    t = log.sample_times()
    want = np.hstack([traj.q(t), traj.qd(t), traj.qdd(t)])
    np.testing.assert_allclose(log.data().T, want, rtol=0, atol=1e-13)
    pt = FourierTrajectoryView(traj)
    assert (pt.rows(), pt.cols(), pt.end_time()) == (6, 1, np.inf)
    np.testing.assert_allclose(
        pt.EvalDerivative(1.7, 3).ravel(), traj.derivative(1.7, 3), atol=1e-13
    )


def test_source_system_equals_trajectory(traj: FourierTrajectory) -> None:
    src = FourierExcitationSource(trajectory=traj)
    ctx = src.CreateDefaultContext()
    for t in (0.0, 1.3, 7.77, 23.1):
        ctx.SetTime(t)
        got = {k: src.GetOutputPort(k).Eval(ctx) for k in ("q", "v", "vdot", "state")}
        np.testing.assert_allclose(got["q"], traj.q(t), rtol=0, atol=1e-13)
        np.testing.assert_allclose(got["v"], traj.qd(t), rtol=0, atol=1e-13)
        np.testing.assert_allclose(got["vdot"], traj.qdd(t), rtol=0, atol=1e-13)
        np.testing.assert_array_equal(got["state"], np.r_[got["q"], got["v"]])
    for t in (-4.2, 0.5):  # periodic: before 0 too
        ctx.SetTime(t)
        np.testing.assert_allclose(
            src.GetOutputPort("q").Eval(ctx), traj.q(t), rtol=0, atol=1e-13
        )
    assert src.trajectory is traj


def test_batched_series_equals_each_trajectory(traj: FourierTrajectory) -> None:
    # A population of P coefficient sets (as the excitation design evaluates)
    # gives, member by member, the values of the single checked trajectory.
    # Values are O(10) at most, so 1e-12 is far above round-off differences.
    rng = np.random.default_rng(11)
    P, n, N = 4, traj.n_joints, traj.harmonics
    a = 0.3 * rng.standard_normal((P, n, N))
    b = 0.3 * rng.standard_normal((P, n, N))
    q0 = rng.uniform(-1, 1, (P, n))
    t = np.linspace(-3.0, 17.0, 23)
    orders = (0, 1, 2, 3, 5)
    for offsets in (q0, q0[0]):  # one offset per member, or one shared (n,)
        got = fourier_series(t, base_frequency=0.1, q0=offsets, a=a, b=b, orders=orders)
        at_t = fourier_series(2.5, base_frequency=0.1, q0=offsets, a=a, b=b)
        assert len(got) == len(orders) and len(at_t) == 3
        for p in range(P):
            q0_p = np.broadcast_to(offsets, (P, n))[p]
            one = FourierTrajectory(base_frequency=0.1, q0=q0_p, a=a[p], b=b[p])
            for k, x in zip(orders, got, strict=True):
                assert x.shape == (P, t.size, n)
                want = one.derivative(t, k)
                np.testing.assert_allclose(x[p], want, rtol=1e-12, atol=1e-12)
            for k, x in enumerate(at_t):
                assert x.shape == (P, n)
                want = one.derivative(2.5, k)
                np.testing.assert_allclose(x[p], want, rtol=0, atol=1e-12)
    # One trajectory: (M, n) at times, (n,) at a scalar time.
    q, qdd = fourier_series(
        t, base_frequency=0.1, q0=traj.q0, a=traj.a, b=traj.b, orders=(0, 2)
    )
    assert q.shape == qdd.shape == (t.size, n)
    np.testing.assert_allclose(qdd, traj.qdd(t), rtol=0, atol=1e-12)
    (v,) = fourier_series(
        1.0, base_frequency=0.1, q0=traj.q0, a=traj.a, b=traj.b, orders=(1,)
    )
    assert v.shape == (n,)
    with pytest.raises(ValueError, match="orders: expected k >= 0"):
        fourier_series(1.0, base_frequency=0.1, q0=0, a=traj.a, b=traj.b, orders=[-1])


def test_source_added_to_builder_follows_trajectory(traj: FourierTrajectory) -> None:
    # Oracle: the LeafSystem's outputs in a simulated diagram equal the
    # trajectory's q, qd, qdd at the logged times (values O(1): 1e-12 absolute).
    builder = DiagramBuilder()
    src = FourierExcitationSource.AddToBuilder(builder, trajectory=traj)
    assert src.get_name() == "excitation"
    assert (
        FourierExcitationSource.AddToBuilder(
            builder, trajectory=traj, name="second"
        ).get_name()
        == "second"
    )
    state = LogVectorOutput(src.GetOutputPort("state"), builder, 0.37)
    vdot = LogVectorOutput(src.GetOutputPort("vdot"), builder, 0.37)
    sim = Simulator(builder.Build())
    sim.AdvanceTo(13.0)
    ctx = sim.get_context()
    t = state.FindLog(ctx).sample_times()
    assert t.size > 30
    x = state.FindLog(ctx).data().T
    n = traj.n_joints
    np.testing.assert_allclose(x[:, :n], traj.q(t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(x[:, n:], traj.qd(t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        vdot.FindLog(ctx).data().T, traj.qdd(t), rtol=0, atol=1e-12
    )


def test_source_docstring_ports_and_keyword_constructor(
    traj: FourierTrajectory,
) -> None:
    doc = inspect.getdoc(FourierExcitationSource)
    block = doc.split(".. pydrake_system::", 1)[1].split("\n\n")[1]
    spec = yaml.safe_load(block)
    src = FourierExcitationSource(trajectory=traj)
    assert spec["name"] == "FourierExcitationSource"
    assert spec.get("input_ports", []) == []
    assert src.num_input_ports() == 0
    names = [src.get_output_port(i).get_name() for i in range(src.num_output_ports())]
    assert spec["output_ports"] == names == ["q", "v", "vdot", "state"]
    sizes = [src.get_output_port(i).size() for i in range(src.num_output_ports())]
    assert sizes == [6, 6, 6, 12]
    with pytest.raises(TypeError):
        FourierExcitationSource(traj)


# ---- joint-space log ------------------------------------------------------------
def _log(n: int = 3, M: int = 20, derivs: bool = True) -> JointLog:
    rng = np.random.default_rng(0)
    x = rng.standard_normal((4, M, n))
    return JointLog(
        t=np.arange(M) / 150.0,
        q=x[0],
        tau=x[1],
        qd=x[2] if derivs else None,
        qdd=x[3] if derivs else None,
    )


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
@pytest.mark.parametrize("derivs", [True, False])
def test_joint_log_round_trip(tmp_path, suffix: str, derivs: bool) -> None:
    log = _log(derivs=derivs)
    path = write_joint_log(tmp_path / f"log{suffix}", log)
    back = read_joint_log(path, n_joints=3)
    for key in ("t", "q", "tau", "qd", "qdd"):
        a, b = getattr(log, key), getattr(back, key)
        if a is None:
            assert b is None
        else:
            np.testing.assert_array_equal(a, b)  # %.17g is exact
    if suffix == ".csv":
        header = path.read_text().splitlines()[0]
        want = "t,q1,q2,q3,tau1,tau2,tau3"
        assert header == (want + ",qd1,qd2,qd3,qdd1,qdd2,qdd3" if derivs else want)


@pytest.mark.parametrize(
    "text, message",
    [
        ("t,q1,tau1\n0,nan,1\n", "q: expected finite numbers"),
        ("t,q1,tau1\n0,1,1\n0,1,1\n", "t: expected strictly increasing"),
        ("t,q1,q2,tau1\n0,1,1,1\n", "missing column.*tau2"),
        ("t,q1,tau1,foo\n0,1,1,2\n", "unknown column.*foo"),
        ("t,q1,tau1\n0,1\n", "not a numeric CSV|rows have"),
        ("q1,tau1\n1,1\n", "missing column 't'"),
    ],
)
def test_bad_joint_log(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_joint_log(path)


def test_joint_log_joint_count(tmp_path) -> None:
    path = write_joint_log(tmp_path / "log.csv", _log(n=3))
    with pytest.raises(ValueError, match="log has 3 joints, expected 6"):
        read_joint_log(path, n_joints=6)
