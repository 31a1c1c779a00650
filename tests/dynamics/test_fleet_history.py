"""One arm over time on numbers (no plant): a parameter that grows is
flagged with its trend, sign and size within its std; a constant arm is
quiet at the stated rate; scatter beyond the stds widens the trend's std."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.history import DAYS_PER_YEAR, compare_history

NAMES = ("ZZ1R", "fv1", "fc1", "MX2R", "M3", "Ia3", "fv3", "fc3", "XY5", "fv6")
NOMINAL = np.array([1.29, 2.5, 3.5, 0.96, 4.5, 0.05, 1.2, 2.0, 0.01, 0.15])
MONTHLY = np.arange(8) * DAYS_PER_YEAR / 12


def _history(seed: int, fits_std: float = 0.01, drift: float = 0.0):
    """8 monthly fits with relative noise ``fits_std`` (stds to match); fv3
    growing by ``drift`` of itself a year."""
    rng = np.random.default_rng(seed)
    std = fits_std * np.abs(NOMINAL) * np.ones((MONTHLY.size, NOMINAL.size))
    values = NOMINAL + std * rng.standard_normal(std.shape)
    k = NAMES.index("fv3")
    values[:, k] += drift * NOMINAL[k] * MONTHLY / DAYS_PER_YEAR
    return values, std


def test_a_growing_friction_is_flagged_with_its_trend():
    values, std = _history(0, drift=0.30)  # fv3 +30 % a year
    h = compare_history(NAMES, MONTHLY, values, std)
    assert [f.name for f in h.flagged] == ["fv3"]
    f = h.flagged[0]
    truth = 0.30 * 1.2  # N m s/rad per year
    assert f.trend > 0 and abs(f.trend - truth) < 3 * f.trend_std
    assert f.z > h.threshold and 0.1 < f.relative < 0.25  # 7 months of 30 %/year
    assert f.text().startswith("joint 3 viscous friction +")
    assert "%/year" in f.text() and "sigma" in f.text()
    assert "over 8 fits (7.0 months)" in h.describe()


def test_constant_arms_are_quiet_at_the_stated_rate():
    """300 constant arms x 10 parameters: at most 3 % raise a flag at the 1 %
    rule (the threshold of 10 tests: 3.29 sigma)."""
    flagged = sum(
        bool(compare_history(NAMES, MONTHLY, *_history(seed)).flagged)
        for seed in range(300)
    )
    assert flagged <= 9


def test_scatter_beyond_the_stds_widens_the_trend_std():
    """Fits that scatter 5x their stated std: the trend's std follows the
    scatter (t with n - 2 dof), so the constant arm stays quiet."""
    values, std = _history(3, fits_std=0.05)
    h = compare_history(NAMES, MONTHLY, values, std / 5)
    assert np.all(h.scatter > 2.0) and np.all(h.dof == MONTHLY.size - 2)
    assert h.flagged == []
    plain = compare_history(NAMES, MONTHLY, values, std)
    np.testing.assert_allclose(h.trend, plain.trend)
    assert np.all(np.isinf(plain.dof[plain.scatter <= 1]))


def test_fits_are_sorted_by_date_and_bad_input_is_refused():
    values, std = _history(1, drift=0.30)
    order = np.random.default_rng(0).permutation(MONTHLY.size)
    h = compare_history(NAMES, MONTHLY[order], values[order], std[order])
    ref = compare_history(NAMES, MONTHLY, values, std)
    np.testing.assert_allclose(h.trend, ref.trend)
    assert np.all(np.diff(h.days) > 0)
    with pytest.raises(ValueError, match="at least 3"):
        compare_history(NAMES, MONTHLY[:2], values[:2], std[:2])
    with pytest.raises(ValueError, match="same date"):
        compare_history(NAMES, np.zeros(8), values, std)
    with pytest.raises(ValueError, match="expected"):
        compare_history(NAMES, MONTHLY, values[:, :3], std)
