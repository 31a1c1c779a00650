"""The measurement kinds behind one interface: every kind in the registry
satisfies it, claims its own files and no other kind's, reads back what it
writes, and is found by either name; the CLI's options reach the kind that
owns them."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from rmdrake.calibration.config import CalibrationConfig
from rmdrake.calibration.kind import MeasurementKind, PlanSizing, read_header
from rmdrake.calibration.plates.simulate import simulate_plates
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.calibration.poses.simulate import simulate_poses
from rmdrake.calibration.registry import KINDS, kind_named, kind_of_file
from rmdrake.calibration.sockets.simulate import simulate_sockets
from rmdrake.model.loading import load_robot

NAMES = list(KINDS)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One small file of each kind, written by its own kind."""
    model = load_robot("rv3sb")
    folder = tmp_path_factory.mktemp("kinds")
    sims = {
        "plates": simulate_plates(model, plates=3, per_plate=8, seed=1),
        "points": simulate_points(model, poses=8, seed=1),
        "sockets": simulate_sockets(model, placements=2, per_socket=6, seed=1),
        "poses": simulate_poses(model, poses=8, seed=1),
    }
    return model, {
        name: (KINDS[name].write(folder / f"{name}.csv", sim.data), sim.data)
        for name, sim in sims.items()
    }


def test_every_kind_is_a_measurement_kind():
    assert NAMES == ["plates", "points", "sockets", "poses"]
    nouns = [k.noun for k in KINDS.values()]
    assert len(set(nouns)) == len(nouns)
    for name, kind in KINDS.items():
        assert isinstance(kind, MeasurementKind), name
        assert kind.name == name
        assert isinstance(kind.plan(2), PlanSizing), name


@pytest.mark.parametrize("name", NAMES)
def test_a_kind_claims_its_own_file_only(files, name):
    _, written = files
    path, data = written[name]
    header = read_header(path)
    claims = [k.name for k in KINDS.values() if k.sniff(header)]
    assert claims == [name]
    assert kind_of_file(path) is KINDS[name]
    back = KINDS[name].read(path, 6)
    np.testing.assert_array_equal(back.q, data.q)


@pytest.mark.parametrize("name", NAMES)
def test_either_name_finds_the_kind(name):
    kind = KINDS[name]
    assert kind_named(kind.name) is kind_named(kind.noun) is kind


def test_an_unknown_name_or_header_is_refused(tmp_path):
    with pytest.raises(ValueError, match="expected one of plates, points, sockets"):
        kind_named("lasers")
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(ValueError) as info:
        kind_of_file(bad)
    for kind in KINDS.values():
        assert f"{kind.noun} measurements ({kind.header})" in str(info.value)


@pytest.mark.parametrize("name", ["plates", "points"])
def test_socket_distances_are_refused_by_kinds_without_sockets(files, name):
    _, written = files
    path, _ = written[name]
    with pytest.raises(ValueError, match="--socket-distance is for socket"):
        KINDS[name].read(path, 6, distances=[(0, 1, 0.05)])


def _options(**changes) -> argparse.Namespace:
    options = dict(
        method=None,
        seed=0,
        folds=None,
        holdout=None,
        maxiter=None,
        length_bound=3e-3,
        angle_bound=3e-3,
        no_progress=True,
        distance_noise=None,
        drop_outliers=False,
    )
    return argparse.Namespace(**{**options, **changes})


@pytest.mark.parametrize("name", NAMES)
def test_each_kind_builds_its_own_method(files, name):
    """A kind's CLI options give a method its own estimator accepts, and
    every other kind's estimator refuses it."""
    model, _ = files
    kind = KINDS[name]
    config = CalibrationConfig(calibrator=kind.calibrator_options(_options(), "x"))
    kind.calibrator(config, model)
    for other in KINDS.values():
        if other is not kind:
            with pytest.raises((ValueError, TypeError)):
                other.calibrator(config, model)


def test_only_the_sockets_own_their_options():
    given = _options(drop_outliers=True)
    KINDS["sockets"].calibrator_options(given, "x")
    for name in ("plates", "points"):
        with pytest.raises(ValueError, match="are for socket measurements"):
            KINDS["sockets"].refuse_foreign(given, "x", KINDS[name].noun)
        KINDS[name].refuse_foreign(given, "x", "socket")  # theirs: nothing


@pytest.mark.parametrize("name", NAMES)
def test_a_plan_divides_its_readings(name):
    plan = KINDS[name].plan(3)
    bigger = plan.sized(2 * plan.readings)
    assert bigger.readings == 2 * plan.readings
    assert type(bigger) is type(plan) and bigger.record() == plan.record()
    assert bigger.sized(plan.readings) == plan
