"""Base parameters: counts of the literature and exact regrouping."""

from __future__ import annotations

import numpy as np
import pytest
from test_dynamics_regressor import write_urdf

from rmdrake.dynamics import (
    SerialChain,
    base_parameters,
    random_standard_parameters,
    regressor,
    standard_parameters,
)
from rmdrake.model.loading import load_robot


@pytest.mark.parametrize(("per_link", "count"), [(10, 36), (11, 40), (13, 52)])
def test_rv3sb_counts(rv3sb, per_link, count):
    base = base_parameters(rv3sb, per_link)
    assert base.count == count
    # a clear rank gap: kept |R_ii| far above the tolerance, the rest round-off
    assert base.r_diagonal[count - 1] > 1e-4
    assert np.all(base.r_diagonal[count:] < 1e-12)


def test_rv3sb_regrouping_reads_like_khalil(rv3sb):
    base = base_parameters(rv3sb)
    lines = base.expressions()
    zz1 = next(x for x in lines if x.startswith("ZZ1R = "))
    assert zz1.startswith("ZZ1R = ZZ1 + Ia1 + YY2 + 0.009025 M2")  # d2^2 M2
    assert any(x.startswith("MX2R = MX2 + 0.245 M3") for x in lines)  # d3 M3
    assert "M1" in base.unidentifiable and "ZZ1" not in base.unidentifiable
    assert "ZZ1R" in str(base)


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh"])
@pytest.mark.parametrize("per_link", [10, 11, 13])
def test_base_regressor_times_base_equals_full(name, per_link):
    model = load_robot(name)
    n = model.n_joints
    base = base_parameters(model, per_link)
    rng = np.random.default_rng(7)  # states unlike the ones used to find the base
    q, qd, qdd = (rng.uniform(-3, 3, (40, n)) for _ in range(3))
    for chi in (standard_parameters(model), random_standard_parameters(n, rng)):
        chi = chi.copy()
        drop = np.setdiff1d(np.arange(13 * n), base.standard_columns)
        chi[drop] = 0.0  # parameters outside the subset do not exist here
        full = regressor(model, q, qd, qdd) @ chi
        Yb = base.regressor(model, q, qd, qdd)
        np.testing.assert_array_equal(
            Yb, regressor(model, q, qd, qdd)[..., base.columns]
        )
        got = Yb @ base.regroup(chi)
        assert np.max(np.abs(got - full)) < 1e-9 * np.max(np.abs(full))
        # K_full is the same regrouping on the whole (13n,) vector.
        assert base.K_full.shape == (base.count, 13 * n)
        np.testing.assert_allclose(base.K_full @ chi, base.regroup(chi), rtol=1e-14)


def test_urdf_like_chain_base(tmp_path):
    rng = np.random.default_rng(3)
    path = tmp_path / "arm.urdf"
    write_urdf(path, rng, 5)
    chain = SerialChain.from_urdf(path)
    base = base_parameters(chain)
    chi = random_standard_parameters(5, rng)
    q, qd, qdd = (rng.uniform(-3, 3, (30, 5)) for _ in range(3))
    full = regressor(chain, q, qd, qdd) @ chi
    got = base.regressor(chain, q, qd, qdd) @ base.regroup(chi)
    assert np.max(np.abs(got - full)) < 1e-9 * np.max(np.abs(full))
    # generic axes: at most 10 per link minus the first link's 9 (only its
    # inertia about its own axis acts), plus Ia, fv, fc of every link
    assert base.count <= 13 * 5 - 9


def test_bad_options(rv3sb):
    with pytest.raises(ValueError, match="per_link: expected 10, 11 or 13, found 12"):
        base_parameters(rv3sb, 12)
    with pytest.raises(ValueError, match="n_samples: expected at least 13"):
        base_parameters(rv3sb, n_samples=5)
    base = base_parameters(rv3sb)
    with pytest.raises(ValueError, match=r"chi: expected shape \(78,\)"):
        base.regroup(np.ones(77))
