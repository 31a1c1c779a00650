"""Excitation design (paper eq. 14-17): constraints by construction, the cost
against a direct cond(A), reproducibility, and the `excite` command."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.cli.commands import main
from rmdrake.dynamics.base import base_parameters
from rmdrake.excitation.design import (
    ExcitationCost,
    FourierParametrization,
    design_excitation,
    fit_to_limits,
)
from rmdrake.excitation.trajectory import (
    FourierTrajectory,
    fourier_series,
    load_fourier,
)


def test_parametrization_starts_at_rest():
    """Any coordinates give q(0) = q0, qd(0) = 0, qdd(0) = 0 (eq. 17) to 1e-12."""
    param = FourierParametrization(6, 5)
    assert param.size == 6 * 7
    X = np.random.default_rng(0).uniform(-3, 3, (20, param.size))
    a, b = param.coefficients(X)
    q0 = np.linspace(-1, 1, 6)
    q, qd, qdd = fourier_series(
        np.array([0.0, 10.0]), base_frequency=0.1, q0=q0, a=a, b=b
    )
    for k in (0, 1):  # t = 0 and one period later
        np.testing.assert_allclose(q[:, k], np.broadcast_to(q0, (20, 6)), atol=1e-12)
        np.testing.assert_allclose(qd[:, k], 0.0, atol=1e-12)
        np.testing.assert_allclose(qdd[:, k], 0.0, atol=1e-12)
    # Same values as the checked FourierTrajectory.
    traj = FourierTrajectory(base_frequency=0.1, q0=q0, a=a[3], b=b[3])
    t = np.linspace(0, 10, 37)
    q, qd, qdd = fourier_series(t, base_frequency=0.1, q0=q0, a=a[3:4], b=b[3:4])
    np.testing.assert_allclose(q[0], traj.q(t), atol=1e-12)
    np.testing.assert_allclose(qd[0], traj.qd(t), atol=1e-12)
    np.testing.assert_allclose(qdd[0], traj.qdd(t), atol=1e-12)


def test_fit_to_limits_keeps_every_joint_inside(rv3sb):
    param = FourierParametrization(6, 5)
    X = np.random.default_rng(1).uniform(-5, 5, (10, param.size))
    a, b = param.coefficients(X)
    q0 = 0.5 * (rv3sb.limits.lower + rv3sb.limits.upper)
    t = np.arange(1000) * 0.01
    a, b = fit_to_limits(0.1, q0, a, b, rv3sb, 0.95, t)
    for k in range(10):
        FourierTrajectory(base_frequency=0.1, q0=q0, a=a[k], b=b[k]).check_limits(rv3sb)


def test_cost_equals_direct_condition_number(rv3sb):
    """The vectorised cost == numpy's cond of the stacked base regressor.

    The samples miss t = 0, where the motion is at rest and qd is zero only up
    to round-off: there the Coulomb column sign(qd) is +-1 or 0 by round-off,
    which moves cond(A) by ~1e-4 between two exact evaluations."""
    base = base_parameters(rv3sb, 13)
    param = FourierParametrization(6, 5)
    q0 = 0.5 * (rv3sb.limits.lower + rv3sb.limits.upper)
    t = (np.arange(60) + 0.5) * (10 / 60)
    cost = ExcitationCost(
        model=rv3sb,
        base=base,
        parametrization=param,
        q0=q0,
        base_frequency=0.1,
        times=t,
    )
    X = np.random.default_rng(2).uniform(-1, 1, (5, param.size))
    a, b = cost.coefficients(X)
    for k in range(5):
        q, qd, qdd = fourier_series(
            t, base_frequency=0.1, q0=q0, a=a[k : k + 1], b=b[k : k + 1]
        )
        A = base.regressor(rv3sb, q[0], qd[0], qdd[0]).reshape(-1, base.count)
        assert cost(X[k : k + 1])[0] == pytest.approx(np.linalg.cond(A), rel=1e-6)


def test_design_is_reproducible_and_feasible(rv3sb):
    kw = dict(design_samples=40, popsize=4, maxiter=3, n_random=4, progress=False)
    r1 = design_excitation(rv3sb, seed=3, **kw)
    r2 = design_excitation(rv3sb, seed=3, **kw)
    np.testing.assert_array_equal(r1.trajectory.a, r2.trajectory.a)
    r1.trajectory.check_limits(rv3sb)
    assert r1.cond == pytest.approx(r2.cond)
    # Best-so-far history never increases; the DE never does worse than the
    # best of its first population.
    assert np.all(np.diff(r1.history[:, 2]) <= 0)
    assert r1.random_conds.shape == (4,) and r1.random_conds_full.shape == (4,)
    assert r1.samples == 1500  # 150 Hz over one 10 s period
    assert f"cond(A) on 1500 samples: optimised {r1.cond:.4g}" in r1.summary()
    logdet = design_excitation(rv3sb, seed=3, criterion="logdet", **kw)
    logdet.trajectory.check_limits(rv3sb)
    # Both figures for either design; log det against numpy's slogdet of the
    # base regressor stacked over the full period (an independent path).
    for r in (r1, logdet):
        tr = r.trajectory
        t = np.arange(r.samples) / (r.samples * tr.base_frequency)
        q, qd, qdd = fourier_series(
            t, base_frequency=tr.base_frequency, q0=tr.q0, a=tr.a[None], b=tr.b[None]
        )
        base = base_parameters(rv3sb, 13)
        A = base.regressor(rv3sb, q[0], qd[0], qdd[0]).reshape(-1, base.count)
        sign, value = np.linalg.slogdet(A.T @ A)
        assert sign > 0
        assert r.log_det == pytest.approx(value / base.count, rel=1e-6)
        assert f"(log det(A^T A) / p = {r.log_det:.4g})" in r.summary()


def test_design_bad_input(rv3sb):
    with pytest.raises(ValueError, match="harmonics: expected >= 3"):
        design_excitation(rv3sb, harmonics=2, progress=False)
    with pytest.raises(ValueError, match="q0: joint 2 .* not strictly inside"):
        design_excitation(rv3sb, q0=[0, -3, 0, 0, 0, 0], progress=False)
    with pytest.raises(ValueError, match="criterion"):
        design_excitation(rv3sb, criterion="aopt", maxiter=1, progress=False)


def test_excite_command(tmp_path, capsys):
    out = tmp_path / "traj.yaml"
    argv = [
        "excite",
        "--robot",
        "rv3sb",
        "--out",
        str(out),
        "--maxiter",
        "2",
        "--seed",
        "1",
    ]
    assert main(argv) == 0
    traj = load_fourier(out)
    assert traj.harmonics == 5 and traj.base_frequency == 0.1
    assert "cond(A) on 1500 samples" in capsys.readouterr().out
    bad = tmp_path / "bad.yaml"
    assert (
        main(
            ["excite", "--robot", "rv3sb", "--out", str(bad), "--base-frequency", "-1"]
        )
        == 2
    )
    assert not bad.exists()
