"""calibrate_file and identify_file refuse an implausible result (issue 10):
ImplausibleResultError naming the fault and no file; with force=True the file
is written, the reasons echoed as warnings and recorded in its calibration
record."""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml

from rmdrake.calibration import simulate_plates
from rmdrake.calibration.config import CalibrationConfig, PlaneLMConfig, PointLMConfig
from rmdrake.calibration.plates.data import PlaneMeasurements, write_plane_measurements
from rmdrake.dynamics import standard_parameters
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.regressor import torques
from rmdrake.errors import ImplausibleResultError
from rmdrake.excitation.design import random_fourier_trajectory
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.calibrate import calibrate_file
from rmdrake.pipelines.identify import identify_file


@pytest.fixture(scope="module")
def plates(tmp_path_factory):
    """Clean readings of the RV-3SB and a copy with three wrong plate ids."""
    folder = tmp_path_factory.mktemp("sanity")
    data = simulate_plates(load_robot("rv3sb"), seed=1).data
    plane = data.plane.copy()
    plane[[5, 25, 45]] = (plane[[5, 25, 45]] + 1) % 5
    clean = write_plane_measurements(folder / "clean.csv", data)
    wrong = PlaneMeasurements(plane, data.q, data.distance)
    return folder, clean, write_plane_measurements(folder / "wrong.csv", wrong)


LM = CalibrationConfig(calibrator=PlaneLMConfig())


def test_calibrate_file_writes_a_plausible_result_without_warnings(plates):
    folder, clean, _ = plates
    lines: list[str] = []
    path = calibrate_file(
        "rv3sb", clean, folder / "ok.yaml", config=LM, echo=lines.append
    )
    assert "warnings" not in load_robot(path).calibration
    assert any(line.startswith("sanity: plausible") for line in lines)


def test_calibrate_file_refuses_and_writes_nothing(plates):
    folder, _, wrong = plates
    out = folder / "refused.yaml"
    with pytest.raises(ImplausibleResultError) as caught:
        calibrate_file("rv3sb", wrong, out, config=LM, echo=lambda _: None)
    assert not out.exists()
    assert caught.value.reasons[0].startswith("outlying readings 6, 26, 46")
    assert isinstance(caught.value.result, RobotModel)


def test_calibrate_file_force_records_the_warnings(plates):
    folder, _, wrong = plates
    lines: list[str] = []
    out = folder / "forced.yaml"
    forced = CalibrationConfig(force=True, calibrator=PlaneLMConfig())
    path = calibrate_file("rv3sb", wrong, out, config=forced, echo=lines.append)
    # The forced robot is as absurd as its warnings say (a 156 km link): it
    # is written, but loading it back refuses it as a robot in mm.
    with pytest.raises(ValueError, match="this looks like mm"):
        load_robot(path)
    warnings = yaml.safe_load(path.read_text())["calibration"]["warnings"]
    assert warnings[0].startswith("outlying readings 6, 26, 46")
    printed = [w for w in lines if w.startswith("warning: ")]
    assert len(printed) == len(warnings) and warnings[0] in printed[0]


def test_calibrate_file_refuses_a_method_of_the_other_kind(plates, tmp_path):
    """A PointLMConfig on plane measurements, a plate method on points: one
    line naming both, nothing written."""
    folder, clean, _ = plates
    out = tmp_path / "x.yaml"
    points = CalibrationConfig(calibrator=PointLMConfig(folds=3))
    with pytest.raises(ValueError, match="PointLMConfig calibrates point measure"):
        calibrate_file("rv3sb", clean, out, config=points, echo=lambda _: None)
    csv = tmp_path / "points.csv"
    csv.write_text("pose,marker,q1,q2,q3,q4,q5,q6,x,y,z\n")
    with pytest.raises(ValueError, match=r"PlaneLMConfig \(method 'lm'\) calibrates"):
        calibrate_file("rv3sb", csv, out, config=LM, echo=lambda _: None)
    assert not out.exists()


@pytest.fixture(scope="module")
def swapped_log(tmp_path_factory):
    """A noisy log of the RV-3SB with q2 and q3 (and their derivatives)
    written in each other's columns."""
    folder = tmp_path_factory.mktemp("identify")
    model = load_robot("rv3sb")
    t, q, qd, qdd = random_fourier_trajectory(model, fill=0.8, seed=4).sample(50.0)
    tau = torques(model, q, qd, qdd, standard_parameters(model))
    tau += (
        0.01 * model.limits.effort * np.random.default_rng(5).standard_normal(tau.shape)
    )
    p = [0, 2, 1, 3, 4, 5]
    log = JointLog(t=t, q=q[:, p], tau=tau, qd=qd[:, p], qdd=qdd[:, p])
    return folder, write_joint_log(folder / "swapped.csv", log)


def test_identify_file_refuses_then_force_records(swapped_log):
    folder, log = swapped_log
    out = folder / "identified.yaml"
    quiet = {"method": "ols", "echo": lambda _: None}
    with pytest.raises(ImplausibleResultError) as caught:
        identify_file("rv3sb", log, out, **quiet)
    assert not out.exists()
    assert re.match(r"(positions|held out): ", caught.value.reasons[0])  # q2, q3
    path = identify_file("rv3sb", log, out, force=True, **quiet)
    warnings = load_robot(path).calibration["warnings"]  # and the fit's own
    assert warnings[: len(caught.value.reasons)] == caught.value.reasons
