"""perturb_robot (a true robot drawn near a nominal one) and tool_error_stats
(the tool distance between two models of one robot), each against an oracle
of its own: chi-square bounds on the drawn errors, the MDH table read by hand,
a tool row lengthened by a known amount."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.stats import chi2

from rmdrake.kinematics.compare import tool_error_stats
from rmdrake.model.dynamic_parameters import check_physical
from rmdrake.model.loading import load_robot
from rmdrake.model.perturb import perturb_robot
from rmdrake.model.robot import Compliance, RobotModel

COLUMNS = ("alpha", "d", "theta", "r", "beta")


def _entry(table: np.ndarray, name: str) -> float:
    """The MDH table entry an error parameter adds to, read by hand: ``dd3`` is
    row 3 (1-based), column d."""
    key = name[1:].rstrip("0123456789")
    row = int(name[1 + len(key) :])
    return float(table[row - 1, COLUMNS.index(key)])


def _chi2_ok(x: np.ndarray, std: float, p: float = 1e-6) -> bool:
    """sum (x / std)^2 of N independent N(0, std^2) draws is chi-square with N
    degrees of freedom: inside its central 1 - 2p interval (a false failure
    once in 500 000 runs), i.e. the sample std is std to within about
    5 / sqrt(2 N) relative (8 % for 2000 draws)."""
    s = float(np.sum((np.asarray(x) / std) ** 2))
    return chi2.ppf(p, x.size) < s < chi2.ppf(1 - p, x.size)


def test_deltas_are_added_to_their_table_entries(rv3sb):
    true, deltas = perturb_robot(rv3sb, length_std=5e-4, angle_std=1e-3, seed=3)
    assert len(deltas) == 17  # the paper's parameters
    for name, value in deltas.items():
        moved = _entry(true.table, name) - _entry(rv3sb.table, name)
        assert moved == pytest.approx(value, rel=1e-9, abs=1e-15), name
    touched = np.zeros_like(rv3sb.table, dtype=bool)
    for name in deltas:
        key = name[1:].rstrip("0123456789")
        touched[int(name[1 + len(key) :]) - 1, COLUMNS.index(key)] = True
    assert np.array_equal(true.table[~touched], rv3sb.table[~touched])
    assert true.name == "rv3sb_true"
    assert np.array_equal(true.dynamics, rv3sb.dynamics)  # dynamics untouched


def test_drawn_deltas_have_the_asked_std():
    """params full on the RV-3SB: 14 lengths and 21 angles per seed; over 60
    seeds 840 and 1260 draws, each tested by its chi-square interval."""
    model = load_robot("rv3sb")
    lengths, angles = [], []
    for seed in range(60):
        _, d = perturb_robot(
            model, params="full", length_std=2e-4, angle_std=3e-3, seed=seed
        )
        assert len(d) == 35
        lengths += [v for k, v in d.items() if k.startswith(("dd", "dr"))]
        angles += [v for k, v in d.items() if not k.startswith(("dd", "dr"))]
    lengths, angles = np.array(lengths), np.array(angles)
    assert lengths.size == 840 and angles.size == 1260
    assert _chi2_ok(lengths, 2e-4) and _chi2_ok(angles, 3e-3)
    # zero mean: |mean| under 5 standard errors
    assert abs(lengths.mean()) < 5 * 2e-4 / np.sqrt(lengths.size)
    assert abs(angles.mean()) < 5 * 3e-3 / np.sqrt(angles.size)


def test_same_seed_same_robot_and_streams_are_independent(rv3sb):
    a, da = perturb_robot(rv3sb, length_std=5e-4, angle_std=1e-3, seed=7)
    b, db = perturb_robot(rv3sb, length_std=5e-4, angle_std=1e-3, seed=7)
    c, dc = perturb_robot(rv3sb, length_std=5e-4, angle_std=1e-3, seed=8)
    assert a.to_yaml() == b.to_yaml() and da == db
    assert dc != da
    dyn, dd = perturb_robot(
        rv3sb, length_std=5e-4, angle_std=1e-3, dynamics_std=0.1, seed=7
    )
    assert dd == da and np.array_equal(dyn.table, a.table)
    assert not np.array_equal(dyn.dynamics, a.dynamics)
    # a zero std zeroes its own parameters only: the angles are the same draws
    _, lengths_off = perturb_robot(rv3sb, length_std=0.0, angle_std=1e-3, seed=7)
    angles = {k: v for k, v in da.items() if not k.startswith(("dd", "dr"))}
    assert lengths_off == angles


def test_named_parameters_and_compliances_skipped(rv3sb):
    _, d = perturb_robot(rv3sb, params="dd3, dtheta2,c1", length_std=1e-3, seed=0)
    assert list(d) == ["dd3"]  # angle std 0, compliance skipped
    _, d = perturb_robot(rv3sb, params=["dr7"], length_std=1e-3)
    assert list(d) == ["dr7"]


def test_dynamics_stay_physical_and_near(rv3sb):
    for model in (rv3sb, load_robot("demo_rh")):
        for seed in range(3):
            true, d = perturb_robot(
                model, length_std=0, angle_std=0, dynamics_std=0.5, seed=seed
            )
            assert d == {}
            assert check_physical(true.dynamics).ok
            nz = model.dynamics != 0
            assert np.array_equal(true.dynamics[~nz], model.dynamics[~nz])
            ratio = true.dynamics[nz] / model.dynamics[nz]
            assert np.all(np.abs(ratio - 1) < 6 * 0.5)  # 6 sigma
            assert np.all(true.dynamics[:, 9] > 0)  # masses
            assert np.array_equal(true.table, model.table)
            assert true.payload is model.payload  # the tool is another body
    small, _ = perturb_robot(rv3sb, length_std=0, angle_std=0, dynamics_std=0.01)
    nz = rv3sb.dynamics != 0
    rel = small.dynamics[nz] / rv3sb.dynamics[nz] - 1
    assert 0 < np.abs(rel).max() < 0.06  # every entry moved, by ~1 %


def test_stiffness_log_normal_and_rigid_joints_stay_rigid():
    model = load_robot("demo_rh_elastic")
    k0 = model.compliance.stiffness.copy()
    k0[2] = 0.0  # joint 3 rigid
    model = dataclasses.replace(model, compliance=Compliance(k0))
    logs = []
    for seed in range(300):
        true, _ = perturb_robot(
            model, length_std=0, angle_std=0, stiffness_std=0.3, seed=seed
        )
        k = true.compliance.stiffness
        assert k[2] == 0 and np.all(k[k0 > 0] > 0)
        logs.append(np.log(k[k0 > 0] / k0[k0 > 0]))
        assert np.array_equal(true.dynamics, model.dynamics)
    assert _chi2_ok(np.concatenate(logs), 0.3)  # 1500 draws


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"length_std": -1e-3}, "length_std: expected a finite number >= 0"),
        ({"angle_std": float("nan")}, "angle_std: expected a finite number >= 0"),
        ({"length_std": float("inf")}, "length_std: expected a finite number"),
        ({"length_std": 0.2}, "length_std 0.2 m: over 0.1 m"),
        ({"angle_std": 0.11}, "angle_std 0.11 rad: over 0.1 rad"),
        ({"dynamics_std": 0.6}, "dynamics_std 0.6: over 0.5"),
        ({"stiffness_std": 1.5}, "stiffness_std 1.5: over 1"),
        ({}, "nothing to perturb"),
        ({"length_std": 0, "angle_std": 0}, "nothing to perturb"),
        ({"length_std": 1e-3, "params": "dd3,dq4"}, "unknown error parameter 'dq4'"),
        ({"length_std": 1e-3, "params": "dd9"}, "unknown error parameter 'dd9'"),
        ({"length_std": 1e-3, "params": "papper"}, "unknown parameter preset"),
        ({"length_std": 1e-3, "params": "dd3,dd3"}, "given twice"),
        ({"stiffness_std": 0.1}, "no elastic joint"),
        ({"length_std": 1e-3, "params": "c1,c2"}, "nothing to perturb: no param"),
        ({"angle_std": 1e-3, "params": "dd2,dr3"}, "nothing to perturb: no param"),
    ],
)
def test_refusals(rv3sb, kwargs, message):
    with pytest.raises(ValueError, match=message) as e:
        perturb_robot(rv3sb, **kwargs)
    assert "\n" not in str(e.value)


def test_refusals_of_what_the_robot_lacks(rv3sb):
    bare = rv3sb.with_dynamics(None)
    with pytest.raises(ValueError, match="has no dynamics"):
        perturb_robot(bare, dynamics_std=0.1)
    five = _five_joints(rv3sb)
    with pytest.raises(ValueError, match="preset 'paper'"):
        perturb_robot(five, length_std=1e-3)
    perturb_robot(five, params="full", length_std=1e-3)  # fine


def _five_joints(model: RobotModel) -> RobotModel:
    """The first five joints of ``model`` (its wrist's last joint removed)."""
    lim = model.limits
    limits = dataclasses.replace(
        lim, **{k: getattr(lim, k)[:5] for k in ("lower", "upper", "velocity",
                                                  "acceleration", "effort")}
    )  # fmt: skip
    return RobotModel(name="five", mdh=model.mdh[:5], tool=model.tool, limits=limits)


# ---- tool_error_stats -----------------------------------------------------------
def test_tool_error_of_a_longer_tool_is_its_length(rv3sb):
    """Lengthening the tool row's r by 1 mm moves the tool point 1 mm along the
    tool axis at every pose; moving the base row's r moves it along the base z:
    the distance is 1 mm everywhere."""
    for row in (6, 0):
        table = rv3sb.table.copy()
        table[row, 3] += 1e-3
        longer = rv3sb.with_table(table)
        stats = tool_error_stats(rv3sb, longer, n_poses=200, seed=4)
        assert stats["n_poses"] == 200
        for key in ("mean", "p95", "max"):
            assert stats[key] == pytest.approx(1e-3, rel=1e-9)
    same = tool_error_stats(rv3sb, rv3sb)
    assert same == {"mean": 0.0, "p95": 0.0, "max": 0.0, "n_poses": 1000}


def test_tool_error_grows_with_the_errors(rv3sb):
    small, _ = perturb_robot(rv3sb, length_std=1e-4, angle_std=2e-4, seed=1)
    large, _ = perturb_robot(rv3sb, length_std=1e-3, angle_std=2e-3, seed=1)
    s, g = tool_error_stats(rv3sb, small), tool_error_stats(rv3sb, large)
    assert 0 < s["mean"] <= s["p95"] <= s["max"]
    assert g["mean"] == pytest.approx(10 * s["mean"], rel=0.02)  # linear, ~1e-3
    assert tool_error_stats(rv3sb, large, seed=2) != g  # other poses


def test_tool_error_refuses_other_robots(rv3sb):
    with pytest.raises(ValueError, match="6 joints, robot 'five' 5"):
        tool_error_stats(rv3sb, _five_joints(rv3sb))
    slide = dataclasses.replace(rv3sb, sigma=np.array([1, 0, 0, 0, 0, 0]))
    with pytest.raises(ValueError, match="joint 1 is revolute .* prismatic"):
        tool_error_stats(rv3sb, slide)
    with pytest.raises(ValueError, match="other kinematics"):
        tool_error_stats(rv3sb, load_robot("demo_rh"))
    with pytest.raises(ValueError, match="n_poses"):
        tool_error_stats(rv3sb, rv3sb, n_poses=0)
