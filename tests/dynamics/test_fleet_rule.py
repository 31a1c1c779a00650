"""The fleet rule of issue 41 on numbers (no plant): the family-wise
threshold flags the worn arm of twelve the fixed 5 sigma missed; healthy
fleets of 4, 12 and 21 arms stay quiet at the stated rate; a known build
spread lets a fleet of 4 find the worn arm; the build spread of the base
parameters is that of the standard ones, regrouped."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.fleet import (
    build_spread_of,
    compare_fleet,
    family_threshold,
)

ISSUE_FV3 = [1.20, 1.23, 1.12, 1.21, 1.28, 1.17, 1.22, 1.76, 1.19, 1.24, 1.15, 1.20]


def _stacked(m: int, count: int, seed: int, worn: bool = False, build=0.03):
    """``count`` fleets of m arms x 52 parameters side by side (columns):
    centre 1, build spread ``build``, identification stds from 0.06 to 2 of
    the build spread; arm 0's first two parameters x 1.5 if ``worn``."""
    rng = np.random.default_rng(seed)
    noise = 0.03 * np.geomspace(0.06, 2.0, 52)
    true = 1.0 + build * rng.standard_normal((m, count, 52))
    if worn:
        true[0, :, :2] *= 1.5
    values = true + noise * rng.standard_normal(true.shape)
    std = np.broadcast_to(noise, values.shape).reshape(m, -1)
    return values.reshape(m, -1), std


def _flag_rate(m, count, seed, worn=False, build=None, true_build=0.03):
    values, std = _stacked(m, count, seed, worn, true_build)
    names = ["fv1"] * values.shape[1]
    kw = {} if build is None else {"build_spread": np.full(values.shape[1], build)}
    c = compare_fleet([f"a{i}" for i in range(m)], names, values, std,
                      threshold=family_threshold(m * 52), **kw)  # fmt: skip
    hit = (np.abs(c.z) > c.threshold).reshape(m, count, 52).any(axis=2)
    return hit[0].mean() if worn else hit.any(axis=0).mean()


def test_family_threshold_is_bonferroni_and_grows_with_the_tests():
    assert family_threshold(12 * 52) == pytest.approx(4.31, abs=0.01)
    assert family_threshold(4 * 52) == pytest.approx(4.06, abs=0.01)
    assert family_threshold(21 * 52) == pytest.approx(4.44, abs=0.01)
    assert family_threshold(1, 0.05) == pytest.approx(1.96, abs=0.01)
    assert family_threshold(10, 0.001) > family_threshold(10, 0.01)
    for bad in ((0, 0.01), (5, 0.0), (5, 1.0)):
        with pytest.raises(ValueError):
            family_threshold(*bad)


def test_the_issues_worn_arm_of_twelve_is_flagged_and_was_not_at_5_sigma():
    """fleet.csv of the issue: fv3 1.76 on arm 7 against 1.12-1.28 (stds
    0.005; these values give the issue's 4.82 sigma under the rule before,
    Welch-Satterthwaite's degrees of freedom), 51 other parameters quiet; the
    fixed 5 sigma flagged nothing."""
    rng = np.random.default_rng(41)
    other = 1.0 + 0.03 * rng.standard_normal((12, 51))
    values = np.c_[ISSUE_FV3, other]
    std = np.full(values.shape, 0.005)
    names = ["fv3"] + ["fc2"] * 51
    arms = [f"arm_{i:02d}" for i in range(12)]
    before = compare_fleet(arms, names, values, std, threshold=5.0)
    assert before.flagged == {}
    now = compare_fleet(arms, names, values, std)
    assert now.threshold == pytest.approx(family_threshold(12 * 52))
    assert list(now.flagged) == ["arm_07"]
    assert [f.name for f in now.flags("arm_07")] == ["fv3"]
    assert 4.5 < now.z[7, 0] < 5.0  # 4.79
    assert "false alarms 1 % over 12 x 52 tests" in now.describe()


@pytest.mark.parametrize("m", [4, 12, 21])
def test_healthy_fleets_stay_under_the_false_alarm_rate(m):
    """400 healthy fleets of m arms x 52: at most 2 % raise a flag at the 1 %
    rule (the bench measured 0.00-0.20 % over 4000). Welch-Satterthwaite's
    degrees of freedom (before) raised flags in 12 % of the fleets of 4."""
    assert _flag_rate(m, 400, seed=m) <= 0.02


def test_a_known_build_spread_lets_four_arms_find_the_worn_one():
    without = _flag_rate(4, 300, seed=5, worn=True)
    given = _flag_rate(4, 300, seed=5, worn=True, build=0.03)
    assert without < 0.2 and given > 0.95
    assert _flag_rate(4, 400, seed=6, build=0.03) <= 0.02  # and stays quiet


def test_build_dof_inf_is_the_build_spread_itself():
    values, std = _stacked(5, 1, seed=1)
    c = compare_fleet([f"a{i}" for i in range(5)], ["fv1"] * 52, values, std,
                      build_spread=np.full(52, 0.03), build_dof=np.inf)  # fmt: skip
    expect = np.sqrt(0.03**2 + np.median(std**2, axis=0))
    np.testing.assert_allclose(c.spread, expect)
    assert np.all(np.isinf(c.dof))
    with pytest.raises(ValueError, match="build_spread"):
        compare_fleet(["a", "b"], ["fv1"], [[1.0], [1.1]], [[0.1], [0.1]],
                      build_spread=[0.1, 0.2])  # fmt: skip


def test_build_spread_of_regrouped_parameters_is_that_of_their_draws():
    """A base parameter that sums three standard ones (and one alone): the
    spread over 20000 draws of 3 % on each matches the formula, which is
    below 3 % of the sum."""
    chi = np.array([2.0, 1.0, 0.5, 4.0])
    K = np.array([[1.0, 1.0, -1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    spread = build_spread_of(chi, K, 0.03)
    rng = np.random.default_rng(0)
    draws = (chi * (1 + 0.03 * rng.standard_normal((20000, 4)))) @ K.T
    np.testing.assert_allclose(draws.std(axis=0), spread, rtol=0.03)
    assert spread[0] < 0.03 * abs(K[0] @ chi) * 1.05 and spread[1] == 0.12
    with pytest.raises(ValueError):
        build_spread_of(chi, K, -0.01)
