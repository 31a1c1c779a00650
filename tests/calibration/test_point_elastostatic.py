"""Elastostatic point calibration: joint compliances c<j> among the unknowns of
the laser-tracker fit.

Oracle: the shipped demo_rh_elastic with known geometric errors, measured by a
simulated tracker at its link angles (rmdrake.dynamics.compliance.link_angles) under 0
and 4.5 t; finite differences of the residuals for the compliance columns of
the Jacobian."""

from __future__ import annotations

import dataclasses
import functools
import warnings

import numpy as np
import pytest
import yaml

from rmdrake.calibration.elastostatic import ComplianceWarning, JointLoads
from rmdrake.calibration.points.data import (
    PointMeasurements,
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.calibration.points.lm import PointLM
from rmdrake.calibration.points.problem import PointProblem, predict_points
from rmdrake.calibration.points.simulate import SimulatedPoints, simulate_points
from rmdrake.cli.commands import main
from rmdrake.dynamics.compliance import gravity_torques, link_angles
from rmdrake.model.error_parameters import apply_deltas
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel

ERRORS = {"dd2": 1e-3, "dalpha3": 5e-4, "dtheta2": -7e-4, "dr4": 8e-4}  # m, rad
PAYLOADS = (0.0, 4500.0)  # kg


@functools.cache
def _elastic() -> RobotModel:
    return load_robot("demo_rh_elastic")


def _stiffness() -> np.ndarray:
    return _elastic().compliance.stiffness  # N m/rad


@functools.cache
def _nominal() -> RobotModel:
    return dataclasses.replace(_elastic(), compliance=None)


@functools.cache
def _true() -> RobotModel:
    return apply_deltas(_elastic(), list(ERRORS), list(ERRORS.values()))


@functools.cache
def _points(noise: float, seed: int, payload=PAYLOADS) -> SimulatedPoints:
    return simulate_points(
        _true(), poses=40, markers=3, noise=noise, seed=seed, payload=list(payload)
    )


def _fit(data: PointMeasurements, params: str = "full") -> PointLM:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ComplianceWarning)
        return PointLM(_nominal(), params=params, compliance=True).fit(data)


def _stiffness_errors(est: PointLM) -> dict[int, float]:
    """{joint (1-based): relative stiffness error} of the identified c<j>."""
    k = _stiffness()
    return {
        int(n[1:]): (1 / v - k[int(n[1:]) - 1]) / k[int(n[1:]) - 1]
        for n, v in zip(est.names_, est.deltas_, strict=True)
        if n.startswith("c")
    }


def test_noise_free_points_give_the_true_stiffness_and_geometry():
    sim = _points(0.0, 0)
    assert set(np.unique(sim.data.payload)) == set(PAYLOADS)
    with pytest.warns(ComplianceWarning, match=r"c1, c6 .*gravity torque is 0"):
        est = PointLM(_nominal(), params="full", compliance=True).fit(sim.data)
    # c1 (vertical axis) and c6 (payload on its axis) unseen: left rigid.
    k_fit = est.model_.compliance.stiffness
    np.testing.assert_allclose(k_fit[1:5], _stiffness()[1:5], rtol=1e-3)
    assert k_fit[0] == 0.0 and k_fit[5] == 0.0
    fitted = dict(zip(est.names_, est.deltas_, strict=True))
    got = np.array([fitted[n] for n in ERRORS])
    np.testing.assert_allclose(got, list(ERRORS.values()), rtol=0, atol=1e-8)
    assert est.residual_rms_ < 1e-8
    assert est.residual_rms_nominal_ > 1e-2  # the 4.5 t bend: tens of mm
    assert 1 < est.elastic_passes_ <= 8
    # The calibrated model bends like the truth under a payload it never saw.
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.5, 0.5, (5, 6)) + np.array([0, 0.4, 0.6, 0, 0.5, 0])
    pose, marker = np.repeat(np.arange(5), 3), np.tile(np.arange(3), 5)
    truth = predict_points(
        _true().table,
        link_angles(_true(), q[pose], 2250.0),
        sim.markers[marker],
        sim.R_IB,
        sim.p_IB,
        sigma=_true().sigma,
    )
    unseen = PointMeasurements(pose, marker + 1, q[pose], truth, np.full(15, 2250.0))
    assert np.abs(est.predict(unseen) - truth).max() < 1e-7  # m
    record = est.model_.calibration
    assert set(record["compliance"]) == {"c2", "c3", "c4", "c5"}
    assert record["compliance"]["c2"]["stiffness"] == pytest.approx(5e7, rel=1e-3)
    assert record["elastic"]["payloads_kg"] == list(PAYLOADS)
    assert "c2" not in record["parameters"]


def test_compliance_columns_match_finite_differences():
    sim = _points(0.0, 0)
    data, model = sim.data, _nominal()
    # The loads at the true geometry and compliances are the true robot's.
    k = _stiffness()
    names = [*ERRORS, "c1", "c2", "c3", "c4", "c5", "c6"]
    truth = np.concatenate([list(ERRORS.values()), 1 / k])
    tau = JointLoads(model, data, names).torques(truth)
    q_l = link_angles(_true(), data.q, data.payload)
    expected = gravity_torques(_true(), q_l, data.payload)
    assert np.abs(tau - expected).max() < 1e-6 * np.abs(expected).max()
    # c2 without its offset among the unknowns: its column is dtheta2's anyway.
    names = ["dd2", "dtheta3", "c2", "c3", "c5"]
    loads = JointLoads(model, data, names)
    params = np.array([1e-4, -2e-4, 2e-8, 4e-8, 1e-7])
    torques = loads.torques(params)
    idx = np.array([1 * 5 + 1, 2 * 5 + 2])  # dd2, dtheta3
    problem = PointProblem(
        model.table,
        data,
        idx,
        sim.R_IB,
        sigma=model.sigma,
        **loads.problem_options(torques),
    )
    x = problem.pack(params, sim.p_IB, sim.markers)
    h = 1e-11  # rad/(N m): a deflection step of about 1e-6 rad
    steps = h * np.eye(x.size)[2:5]
    fd = np.column_stack(
        [(problem.residuals(x + s) - problem.residuals(x - s)) / (2 * h) for s in steps]
    )
    J = problem.jacobian(x)[:, 2:5]
    assert np.all(np.abs(fd).max(axis=0) > 1e2)  # m per rad/(N m): seen
    np.testing.assert_allclose(J, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_noisy_points_give_the_loaded_joints_stiffness_within_2_percent():
    # 0.05 mm per coordinate, 40 poses x 3 markers, poses alternating 0 and
    # 4.5 t. Over seeds 0..4 (params full): k2 within 0.06 %, k3 within 0.11 %,
    # k4 within 0.76 %, k5 within 0.41 % (reported std of k2, k3 0.03-0.05 %,
    # k4 0.3-0.5 %, k5 0.16-0.2 %); the four geometric errors within 2.6e-5.
    est = _fit(_points(5e-5, 0).data)
    errors = _stiffness_errors(est)
    for j in (2, 3):
        assert abs(errors[j]) < 0.02
    std = dict(zip(est.names_, est.std_, strict=True))
    values = dict(zip(est.names_, est.deltas_, strict=True))
    k = _stiffness()
    for j in (2, 3, 4, 5):
        assert abs(values[f"c{j}"] - 1 / k[j - 1]) < 4 * std[f"c{j}"]


def test_one_payload_warns_and_a_rigid_fit_ignores_the_column():
    data = _points(0.0, 1, payload=(0.0,)).data
    with pytest.warns(ComplianceWarning, match="one payload .0 kg.: add readings"):
        PointLM(_nominal(), params="full", compliance=True).fit(data)
    bare = PointMeasurements(data.pose, data.marker, data.q, data.p_I)
    names = ["dd2", "dalpha3", "dtheta2", "dr4"]
    a = PointLM(_nominal(), params=names).fit(data)
    b = PointLM(_nominal(), params=names).fit(bare)
    assert a.elastic_passes_ == 1
    assert np.array_equal(a.deltas_, b.deltas_)
    assert "compliance" not in a.model_.calibration


def test_bad_input(tmp_path):
    data = _points(0.0, 0).data
    no_dynamics = dataclasses.replace(_nominal(), dynamics=None)
    with pytest.raises(ValueError, match="no dynamics: c1, c2"):
        PointLM(no_dynamics, params="dd2", compliance=True).fit(data)
    no_payload = dataclasses.replace(_nominal(), payload=None)
    with pytest.raises(ValueError, match="payload: masses up to 4500 kg"):
        PointLM(no_payload, params="dd2", compliance=True).fit(data)
    with pytest.raises(ValueError, match="payload: masses up to 10 kg"):
        simulate_points(no_payload, poses=5, payload=[0, 10])
    with pytest.raises(ValueError, match="unknown error parameter 'c7'"):
        PointLM(_nominal(), params="dd2,c7").fit(data)
    with pytest.raises(ValueError, match="payload: expected masses >= 0"):
        PointMeasurements(data.pose, data.marker, data.q, data.p_I, -data.payload - 1)
    path = write_point_measurements(tmp_path / "p.csv", data)
    text = path.read_text().splitlines()
    assert text[0].endswith(",x,y,z,payload")
    text[3] = text[3].rsplit(",", 1)[0] + ",-5.0"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(ValueError, match="row 3, column payload: -5 kg is negative"):
        read_point_measurements(path, 6)


def test_cli_simulates_payloads_and_writes_the_stiffness(tmp_path, capsys):
    csv, out, nominal = tmp_path / "p.csv", tmp_path / "cal.yaml", tmp_path / "n.yaml"
    _true().save(tmp_path / "true.yaml")
    _nominal().save(nominal)
    simulate = ["simulate-points", "--robot", str(tmp_path / "true.yaml")]
    simulate += ["--out", str(csv), "--poses", "40", "--noise", "0"]
    assert main([*simulate, "--payload", "0,4500"]) == 0
    assert "payloads 0, 4500 kg" in capsys.readouterr().out
    assert set(read_point_measurements(csv).payload) == set(PAYLOADS)
    calibrate = ["calibrate", "--robot", str(nominal), "--measurements", str(csv)]
    calibrate += ["--out", str(out), "--params", "full", "--compliance"]
    assert main(calibrate) == 0
    text = capsys.readouterr()
    assert "compliances c1, c6 are not identifiable" in text.err + text.out
    saved = yaml.safe_load(out.read_text())
    k = np.array(saved["compliance"]["stiffness"])
    assert np.allclose(k[1:5], _stiffness()[1:5], rtol=1e-3)
    assert k[0] == 0 and k[5] == 0
    assert saved["calibration"]["compliance"]["c3"]["relative_std"] < 1e-3
    assert saved["calibration"]["options"]["compliance"] is True
