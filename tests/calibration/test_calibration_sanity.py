"""Calibration sanity checks (issue 10): a fit on clean readings is never
flagged; each corruption of the issue is refused with a reason that names the
readings, plates or parameters at fault."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rmdrake.calibration import make_calibrator, simulate_plates
from rmdrake.calibration.plates.data import PlaneMeasurements, read_plane_measurements
from rmdrake.calibration.sanity import CalibrationBounds, robot_reach
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot

NOISE = {"rv3sb": 2e-6, "demo_rh": 1e-5}  # m, the shipped scenarios' range finders
SIZE = {"rv3sb": 3e-4, "demo_rh": 1e-3}  # m and rad, the true robot's errors


def _clean(name: str, seed: int, plates: int = 5, per_plate: int = 12):
    nominal = load_robot(name)
    names = error_parameter_names(nominal, "paper")
    rng = np.random.default_rng(seed)
    true = apply_deltas(nominal, names, SIZE[name] * rng.standard_normal(len(names)))
    sim = simulate_plates(
        true,
        plates=plates,
        per_plate=per_plate,
        noise=NOISE[name],
        seed=seed,
        planning_model=nominal,
    )
    return nominal, sim.data


@pytest.fixture(scope="module")
def rv3sb_data():
    return _clean("rv3sb", 1)


def _fit(model, data, method="lm", params="paper", **options):
    return make_calibrator(method, model, params=params, **options).fit(data)


def _reasons(est) -> str:
    assert not est.sanity_.ok
    return "\n".join(est.sanity_.reasons)


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh"])
@pytest.mark.parametrize("params", ["paper", "full"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clean_readings_are_never_flagged(name, params, seed):
    nominal, data = _clean(name, seed)
    est = _fit(nominal, data, params=params)
    assert est.sanity_.ok, est.sanity_.reasons
    assert est.check(noise=NOISE[name]).ok  # the declared noise agrees
    assert est.sanity_.reference == "calibrated"
    assert est.sanity_.outliers.size == 0
    assert 0.5 < est.sanity_.residual_rms / est.sanity_.noise < 2


def test_clean_readings_pass_with_de_lm_and_few_readings():
    nominal, data = _clean("rv3sb", 3, per_plate=8)  # 8 dof, the smoke scenarios
    est = _fit(nominal, data, "de+lm", maxiter=5, progress=False)
    assert est.sanity_.ok, est.sanity_.reasons


def test_three_wrong_plate_ids_are_named(rv3sb_data):
    nominal, data = rv3sb_data
    bad = np.array([5, 25, 45])
    plane = data.plane.copy()
    plane[bad] = (plane[bad] + 1) % 5
    est = _fit(nominal, PlaneMeasurements(plane, data.q, data.distance))
    text = _reasons(est)
    assert re.search(r"outlying readings 6, 26, 46 \(plates", text), text
    assert set(est.sanity_.outliers) == set(bad)
    # The fit collapsed out of the nominal basin: corrections beyond bounds, and
    # the parameters the Jacobian no longer fixes get no finite std.
    assert re.search(r"correction\(s\) beyond physical bounds .*dalpha", text)
    if "degenerate solution" in text:
        assert np.isinf(est.std_).any()


def test_distances_in_mm_are_refused_before_the_fit(rv3sb_data):
    nominal, data = rv3sb_data
    mm = PlaneMeasurements(data.plane, data.q, data.distance * 1e3)
    limit = 2 * robot_reach(nominal) + 1.0
    with pytest.raises(ValueError, match=r"reading \d+ is longer than .* not mm"):
        _fit(nominal, mm)
    assert limit < 1e3 * data.distance.max()


def test_distances_ten_times_too_long_are_refused(rv3sb_data):
    nominal, data = rv3sb_data
    est = _fit(nominal, PlaneMeasurements(data.plane, data.q, data.distance * 10))
    text = _reasons(est)
    assert "distances not in m" in text or "beyond physical bounds" in text


def test_random_distances_are_refused(rv3sb_data):
    nominal, data = rv3sb_data
    rng = np.random.default_rng(0)
    noise = rng.uniform(0.01, 0.08, data.n_readings)
    est = _fit(nominal, PlaneMeasurements(data.plane, data.q, noise))
    text = _reasons(est)
    assert re.search(r"scatter \d.* mm about their plates", text), text
    assert re.search(r"beyond physical bounds .*(dalpha|dd|dr)\d", text), text


# io.py casts the float ids to int64 (1e19 and 2e19 both saturate, with numpy's
# RuntimeWarning); the calibration's reading check refuses what comes out.
@pytest.mark.filterwarnings("ignore:invalid value encountered in cast")
def test_huge_plate_ids_are_refused_not_merged(rv3sb_data, tmp_path):
    nominal, data = rv3sb_data
    ids = {0: "1e19", 1: "2e19", 2: "3", 3: "4", 4: "5"}
    rows = ["plane," + ",".join(f"q{j}" for j in range(1, 7)) + ",distance"]
    for p, q, d in zip(data.plane, data.q, data.distance, strict=True):
        rows.append(",".join([ids[int(p)], *map(repr, q.tolist()), repr(float(d))]))
    csv = tmp_path / "ids.csv"
    csv.write_text("\n".join(rows) + "\n")
    read = read_plane_measurements(csv, 6)
    with pytest.raises(ValueError, match=r"plate id .* beyond \+-2\^53"):
        _fit(nominal, read)


def test_two_plates_under_one_id_are_named(rv3sb_data):
    nominal, data = rv3sb_data
    plane = np.where(data.plane == 1, 0, data.plane)
    est = _fit(nominal, PlaneMeasurements(plane, data.q, data.distance))
    text = _reasons(est)
    assert re.search(r"plate 0: its readings do not fit one plane", text), text
    assert not re.search(r"plate [234]:", text)


@pytest.mark.parametrize(
    "rows, errors",
    [([17], [1e-3]), ([17], [5e-5]), ([3, 30], [5e-3, -4e-3])],
    ids=["one 1 mm", "one 50 um", "two masking each other"],
)
def test_bad_readings_are_named_by_row(rv3sb_data, rows, errors):
    nominal, data = rv3sb_data
    distance = data.distance.copy()
    distance[rows] += errors
    est = _fit(nominal, PlaneMeasurements(data.plane, data.q, distance))
    text = _reasons(est)
    named = ", ".join(str(r + 1) for r in rows)
    assert re.search(rf"outlying readings? {named} \(plates?", text), text
    assert sorted(est.sanity_.outliers) == rows
    assert est.sanity_.reference == "calibrated"  # small errors: a sound model
    assert est.sanity_.noise < 5 * NOISE["rv3sb"]  # the robust estimate holds


def test_too_few_readings_for_the_unknowns():
    nominal, data = _clean("rv3sb", 4, per_plate=8)
    est = _fit(nominal, data, params="full")  # 22 + 15 unknowns, 40 readings
    assert re.search(r"only \d degrees of freedom \(40 readings", _reasons(est))
    rows = np.flatnonzero((data.plane != 2) | (np.cumsum(data.plane == 2) <= 5))
    short = data.subset(rows)  # plate 2 keeps 5 readings
    est = _fit(nominal, short)
    assert re.search(r"plate 2 has 5 readings, at least 6", _reasons(est))


def test_declared_noise_is_compared_both_ways(rv3sb_data):
    nominal, data = rv3sb_data
    est = _fit(nominal, data)
    low = est.check(noise=1e-7)  # about 20x: a warning naming what to try
    assert low.ok and not low.reasons
    assert re.search(
        r"times the noise \(0\.1 um, declared\).*--params", low.warnings[0]
    )
    absurd = est.check(noise=2e-8)  # about 100x: refused
    assert not absurd.ok
    assert re.search(
        r"times the noise \(0\.02 um, declared\), over 30x", absurd.reasons[0]
    )
    high = est.check(noise=1e-3)
    assert not high.ok and "far below the noise" in high.reasons[0]


@pytest.mark.parametrize("method", ["lm", "de+lm"])
def test_the_fit_checks_against_the_declared_noise_once(rv3sb_data, method):
    # A config's noise reaches the estimator: the fit's own report is the
    # check against it, so no caller needs a second check.
    from rmdrake.calibration.config import (
        CalibrationConfig,
        PlaneLMConfig,
        VolumeDEConfig,
        VolumeDEPlaneLMConfig,
    )

    nominal, data = rv3sb_data
    calibrator = (
        PlaneLMConfig()
        if method == "lm"
        else VolumeDEPlaneLMConfig(de=VolumeDEConfig(maxiter=5))
    )
    config = CalibrationConfig(params="paper", noise=1e-7, calibrator=calibrator)
    est = make_calibrator(config, nominal).fit(data)
    assert est.noise == 1e-7
    assert (est.sanity_.noise, est.sanity_.noise_source) == (1e-7, "declared")
    assert est.sanity_.warnings == est.check(noise=1e-7).warnings
    assert est.sanity_.warnings and re.search(
        r"0\.1 um, declared", est.sanity_.warnings[0]
    )
    # Without a declared noise it is estimated, and check() can still declare.
    plain = _fit(nominal, data, method=method)
    assert plain.noise is None and plain.sanity_.noise_source != "declared"
    assert plain.check(noise=1e-7).noise_source == "declared"


def test_point_fit_checks_against_the_declared_noise():
    from rmdrake.calibration.config import CalibrationConfig, PointLMConfig
    from rmdrake.calibration.points.lm import make_point_calibrator
    from rmdrake.calibration.points.simulate import simulate_points

    nominal = load_robot("rv3sb")
    data = simulate_points(nominal, poses=30, markers=3, noise=1e-5, seed=4).data
    config = CalibrationConfig(
        params="base", noise=1e-5, calibrator=PointLMConfig(seed=0)
    )
    est = make_point_calibrator(config, nominal).fit(data)
    assert (est.sanity_.noise, est.sanity_.noise_source) == (1e-5, "declared")
    assert est.sanity_.ok == est.check(noise=1e-5).ok


def test_bounds_are_stated_per_kind_and_adjustable(rv3sb_data):
    nominal, data = rv3sb_data
    est = _fit(nominal, data)
    tight = est.check(
        bounds=CalibrationBounds(angle=1e-9, length=1e-9, length_fraction=0)
    )
    assert not tight.ok
    bounds = r"\+-5.73e-08 deg on angles, \+-1e-06 mm on lengths"
    assert re.search(bounds, tight.reasons[-1]), tight.reasons
