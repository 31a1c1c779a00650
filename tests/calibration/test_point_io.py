"""Point measurements: the CSV round trip, the header rules and every bad input
of a point calibration (one-line ValueErrors naming the problem)."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.calibration.plates.data import PlaneMeasurements, write_plane_measurements
from rmdrake.calibration.points.checks import check_point_measurements
from rmdrake.calibration.points.data import (
    PointMeasurements,
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.calibration.points.lm import PointLM
from rmdrake.calibration.points.simulate import simulate_points
from rmdrake.calibration.registry import measurement_kind
from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def sim():
    return simulate_points(load_robot("rv3sb"), poses=12, markers=3, seed=4)


def _check(data, model):
    return check_point_measurements(
        data,
        n_joints=model.n_joints,
        lower=model.limits.lower,
        upper=model.limits.upper,
        sigma=model.sigma,
        reach=robot_reach(model),
    )


def _one_line(excinfo) -> str:
    text = str(excinfo.value)
    assert "\n" not in text
    return text


def test_round_trip_bit_for_bit(sim, tmp_path):
    for payload in (None, np.linspace(0, 3, sim.data.n_rows)):
        d = sim.data
        data = PointMeasurements(d.pose, d.marker, d.q, d.p_I, payload)
        path = write_point_measurements(tmp_path / "p.csv", data)
        back = read_point_measurements(path, 6)
        assert measurement_kind(path) == "point"
        for key in ("pose", "marker", "q", "p_I"):
            assert np.array_equal(getattr(back, key), getattr(data, key))
        if payload is None:
            assert back.payload is None
        else:
            assert np.array_equal(back.payload, payload)


def test_header_kinds(tmp_path):
    plane = tmp_path / "plane.csv"
    write_plane_measurements(plane, PlaneMeasurements([0], [[0.1] * 6], [0.1]))
    assert measurement_kind(plane) == "plane"
    bad = tmp_path / "bad.csv"
    bad.write_text("id,q1,x\n1,2,3\n")
    with pytest.raises(ValueError) as e:
        measurement_kind(bad)
    assert "plane,q1..qn,distance" in _one_line(e)
    assert "pose,marker,q1..qn,x,y,z" in _one_line(e)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t.replace("0.", "nan", 1), "not a finite number"),
        (lambda t: "pose,marker,q1,q2,q3,q4,q5,q6,x,y" + t[t.index("\n") :], "line"),
        (lambda t: t.replace("\n0,1,", "\n0.5,1,", 1), "not an integer id"),
    ],
    ids=["nan", "missing column", "fractional id"],
)
def test_reader_errors(sim, tmp_path, edit, match):
    path = write_point_measurements(tmp_path / "p.csv", sim.data)
    path.write_text(edit(path.read_text()))
    with pytest.raises(ValueError, match=match) as e:
        read_point_measurements(path, 6)
    _one_line(e)


def _edited(data, **changes):
    values = {k: np.array(getattr(data, k)) for k in ("pose", "marker", "q", "p_I")}
    for key, fn in changes.items():
        fn(values[key])
    return PointMeasurements(**values)


def test_content_errors(sim):
    model, d = load_robot("rv3sb"), sim.data
    assert _check(d, model) == []
    cases = {
        "different joint values": _edited(
            d, q=lambda q: q.__setitem__((1, 2), q[1, 2] + 0.1)
        ),
        "more than 1 mm apart": PointMeasurements(
            np.r_[d.pose, d.pose[:1]],
            np.r_[d.marker, d.marker[:1]],
            np.r_[d.q, d.q[:1]],
            np.r_[d.p_I, d.p_I[:1] + 0.01],
        ),
        "not mm": _edited(d, p_I=lambda p: p.__imul__(1000.0)),
        "looks like degrees": _edited(d, q=lambda q: q.__imul__(57.3)),
        "marker 9 at 2": _edited(d, marker=lambda m: m.__setitem__([0, 3], 9)),
    }
    for match, data in cases.items():
        with pytest.raises(ValueError, match=match) as e:
            _check(data, model)
        _one_line(e)
    # A repeat of one target within 1 mm is a repeated reading: accepted.
    again = PointMeasurements(
        np.r_[d.pose, d.pose[:1]],
        np.r_[d.marker, d.marker[:1]],
        np.r_[d.q, d.q[:1]],
        np.r_[d.p_I, d.p_I[:1] + 1e-4],
    )
    assert _check(again, model) == []


def test_mm_by_spread_alone(sim):
    """Near the instrument (all |p| < 100 m) but in mm: the spread rule."""
    model, d = load_robot("rv3sb"), sim.data
    local = (d.p_I - d.p_I.mean(axis=0)) * 50.0
    with pytest.raises(ValueError, match="spread over .* not mm"):
        _check(PointMeasurements(d.pose, d.marker, d.q, local), model)


def test_too_few_poses_for_the_unknowns():
    model = load_robot("rv3sb")
    few = simulate_points(model, poses=4, markers=1, seed=1).data
    with pytest.raises(ValueError, match="measure at least .* poses") as e:
        PointLM(model, params="full").fit(few)
    _one_line(e)
