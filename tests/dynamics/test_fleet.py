"""The fleet comparison on synthetic numbers (no plant): a healthy fleet is
quiet, an outlier is exactly its parameter, in words, with its sign; the
reference mode; the words of base parameters; the small-sample correction."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.dynamics.fleet import (
    MAD_TO_SIGMA,
    compare_fleet,
    parameter_unit,
    parameter_words,
    robust_centre,
    sigma_equivalent,
    spread_dof,
)

# A 6-joint arm's friction and rotor inertia, a few inertial base parameters.
NAMES = ("ZZ1R", "fv1", "fc1", "MX2R", "M3", "Ia3", "fv3", "fc3", "XY5", "fv6")
NOMINAL = np.array([1.29, 2.5, 3.5, 0.96, 4.5, 0.05, 1.2, 2.0, 0.0, 0.15])
ARMS = tuple(f"arm_{i:02d}" for i in range(21))


def _fleet(seed: int = 0, spread: float = 0.03, id_std: float = 0.005):
    """21 arms: nominal times 1 + spread N(0, 1), plus identification noise of
    ``id_std`` relative (stds to match); XY5 is zero on every arm."""
    rng = np.random.default_rng(seed)
    true = NOMINAL * (1 + spread * rng.standard_normal((len(ARMS), NOMINAL.size)))
    std = np.maximum(id_std * np.abs(NOMINAL), 1e-16) * np.ones_like(true)
    return true + std * rng.standard_normal(true.shape), std


def test_healthy_fleets_are_quiet():
    """50 fleets of 21 arms x 10 parameters, 3 % spread: nothing flagged, and
    the sigmas look like a normal sample's (the largest of 10 500 under 5)."""
    largest = 0.0
    for seed in range(50):
        values, std = _fleet(seed)
        c = compare_fleet(ARMS, NAMES, values, std)
        assert c.flagged == {}, (seed, c.flagged)
        largest = max(largest, float(np.abs(c.z).max()))
    assert 2.5 < largest < 5.0


def test_an_outlier_is_exactly_its_parameter_in_words_with_its_sign():
    values, std = _fleet(1)
    values[7, NAMES.index("fv3")] *= 1.5  # worn joint 3
    values[7, NAMES.index("fc3")] *= 1.5
    values[12, NAMES.index("Ia3")] *= 0.6  # a lighter rotor on another arm
    c = compare_fleet(ARMS, NAMES, values, std)
    assert list(c.flagged) == ["arm_07", "arm_12"]
    worn = c.flags("arm_07")
    assert [f.name for f in worn] == ["fv3", "fc3"]
    for f in worn:
        assert f.z > 5 and 0.4 < f.relative < 0.6
    text = worn[0].text()
    assert text.startswith("joint 3 viscous friction +") and text.endswith(" sigma)")
    assert worn[1].text().startswith("joint 3 Coulomb friction +")
    (rotor,) = c.flags("arm_12")
    assert rotor.words == "joint 3 rotor inertia" and rotor.z < -5
    assert rotor.text().startswith("joint 3 rotor inertia -4")  # -40 %
    assert c.largest("arm_07")[0] in ("fv3", "fc3")


def test_flags_list_joint_terms_before_inertial_ones():
    values, std = _fleet(2)
    values[3, NAMES.index("MX2R")] *= 1.5
    values[3, NAMES.index("fc1")] *= 2.0
    names = [f.name for f in compare_fleet(ARMS, NAMES, values, std).flags(3)]
    assert names == ["fc1", "MX2R"]


def test_a_parameter_near_zero_is_told_in_si_units():
    """XY5 is zero on every arm: a change there has no percentage; the change
    is printed in kg m^2."""
    values, std = _fleet(3)
    k = NAMES.index("XY5")
    values[:, k] = 1e-4 * np.random.default_rng(0).standard_normal(len(ARMS))
    std[:, k] = 1e-4
    values[5, k] = 0.01
    (flag,) = compare_fleet(ARMS, NAMES, values, std).flags(5)
    assert flag.relative is None
    assert flag.text().startswith("link 5 inertia XY (XY5) +0.01 kg m^2 (")


def test_round_off_is_not_a_difference():
    """A parameter zero on every arm, found at 1e-15 with stds of 1e-17 (a
    noise-free simulation): its scatter is under the resolution floor."""
    values, std = _fleet(4, id_std=0.0)
    k = NAMES.index("XY5")
    values[:, k] = 1e-15 * np.random.default_rng(1).standard_normal(len(ARMS))
    values[2, k] = 1e-13
    std[:, k] = 1e-17
    assert compare_fleet(ARMS, NAMES, values, std).flagged == {}


def test_reference_mode():
    """Every arm's fv3 50 % over the reference (a fleet that wore alike): the
    fleet does not see it, the reference does (the spread of the arms stays in
    s); a reference std as large as the change hides it again; with one arm
    only its own std counts."""
    values, std = _fleet(5)
    k = NAMES.index("fv3")
    values[:, k] *= 1.5
    assert compare_fleet(ARMS, NAMES, values, std).flagged == {}
    c = compare_fleet(ARMS, NAMES, values, std, reference=NOMINAL)
    assert set(c.flagged) == set(ARMS)
    assert all([f.name for f in fl] == ["fv3"] for fl in c.flagged.values())
    assert all(0.35 < f.relative < 0.65 for fl in c.flagged.values() for f in fl)
    assert c.describe().startswith("compared 10 base parameters with reference")
    loose = np.where(np.arange(NOMINAL.size) == k, 0.5 * NOMINAL[k], 0.0)
    c = compare_fleet(ARMS, NAMES, values, std, reference=NOMINAL, reference_std=loose)
    assert c.flagged == {}
    one = compare_fleet(ARMS[:1], NAMES, values[:1], std[:1], reference=NOMINAL)
    assert np.all(one.spread == 0) and np.all(np.isinf(one.dof))
    np.testing.assert_allclose(one.z[0, k], (values[0, k] - NOMINAL[k]) / std[0, k])


def test_robust_centre_ignores_a_minority():
    x = np.r_[np.linspace(-1.0, 1.0, 15), [50.0, 60.0, 70.0]][:, None]
    for kind in ("qn", "mad"):
        centre, spread = robust_centre(x, kind)
        assert abs(centre[0]) < 0.3 and 0.3 < spread[0] < 1.2
    mad = MAD_TO_SIGMA * np.median(np.abs(x - np.median(x)))
    assert robust_centre(x, "mad")[1][0] == pytest.approx(mad)
    big = np.random.default_rng(0).standard_normal((4000, 2))
    for kind in ("qn", "mad"):
        np.testing.assert_allclose(robust_centre(big, kind)[1], 1.0, rtol=0.06)


def test_a_small_fleet_tells_little():
    """The t correction: a ratio is worth fewer sigma when the spread comes
    from few arms; with the stds alone (infinite dof) sigma is the ratio."""
    assert spread_dof(21) == pytest.approx(0.82 * 20)
    assert spread_dof(1) == 0.0
    z = sigma_equivalent([5.0, -5.0, 100.0, 1e20, 0.0], spread_dof(21))
    assert 3.5 < z[0] < 4.5 and z[1] == -z[0] and z[2] > 9 and z[4] == 0
    assert 30 < z[3] < 50  # far, still finite and ordered
    np.testing.assert_array_equal(sigma_equivalent([5.0, -7.0], np.inf), [5, -7])
    assert sigma_equivalent(1e3, 0.0) == 0.0
    assert sigma_equivalent(1e3, spread_dof(3)) < 5
    values, std = _fleet(6)
    values[1, NAMES.index("fv1")] *= 1.5
    few = compare_fleet(ARMS[:3], NAMES, values[:3], std[:3])
    assert few.flagged == {}


@pytest.mark.parametrize(
    "name, words, unit",
    [
        ("fv3", "joint 3 viscous friction", "N m s/rad"),
        ("fc3", "joint 3 Coulomb friction", "N m"),
        ("fc3R", "joint 3 Coulomb friction (fc3R, regrouped)", "N m"),
        ("fcn2", "joint 2 Coulomb friction at negative velocity", "N m"),
        ("tau04", "joint 4 torque offset", "N m"),
        ("Ia4", "joint 4 rotor inertia", "kg m^2"),
        ("M3", "link 3 mass (M3)", "kg"),
        ("MX2R", "link 2 first moment MX (MX2R, regrouped)", "kg m"),
        ("ZZ1R", "link 1 inertia ZZ (ZZ1R, regrouped)", "kg m^2"),
        ("XY5", "link 5 inertia XY (XY5)", "kg m^2"),
        ("fv12", "joint 12 viscous friction", "N m s/rad"),
    ],
)
def test_parameter_words(name, words, unit):
    assert parameter_words(name) == words
    assert parameter_unit(name) == unit


def test_units_of_a_prismatic_joint():
    assert parameter_unit("fv1", prismatic=True) == "N s/m"
    assert parameter_unit("Ia1", prismatic=True) == "kg"
    assert parameter_unit("MX2", prismatic=True) == "kg m"


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"arms": ("a", "a")}, "names repeat"),
        ({"threshold": 0.0}, "threshold"),
        ({"names": ("fv1", "bogus")}, "base parameter 'bogus'"),
        ({"spread": "iqr"}, "spread: expected one of qn, mad"),
        ({"reference": [1.0]}, "reference: expected 2"),
    ],
)
def test_bad_input(kwargs, message):
    args = {"arms": ("a", "b"), "names": ("fv1", "fc1")}
    args |= {"values": np.ones((2, 2)), "std": np.ones((2, 2))}
    args |= kwargs
    arms, names, values, std = (args.pop(k) for k in ("arms", "names", "values", "std"))
    with pytest.raises(ValueError, match=message):
        compare_fleet(arms, names, values, std, **args)
    with pytest.raises(ValueError, match="finite"):
        compare_fleet(("a",), ("fv1",), [[np.nan]], [[1.0]])
