"""The poses as a measurement kind: every member of the kind interface, and
``rmdrake simulate-poses`` writing a file the kind reads back."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from rmdrake.calibration.config import CalibrationConfig, PointLMConfig
from rmdrake.calibration.poses.config import PoseLMConfig
from rmdrake.calibration.poses.kind import PoseKind
from rmdrake.calibration.poses.simulate import simulate_poses
from rmdrake.cli.commands import main
from rmdrake.model.error_parameters import apply_deltas
from rmdrake.model.loading import load_robot

KIND = PoseKind()


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    nominal = load_robot("rv3sb")
    true = apply_deltas(nominal, ["dtheta2", "dd3"], [1e-3, 1e-3])
    sim = simulate_poses(true, poses=30, noise_p=2e-5, noise_r=5e-5, seed=2)
    path = KIND.write(tmp_path_factory.mktemp("poses") / "poses.csv", sim.data)
    return nominal, sim, path


def test_the_kind_is_registered_and_keeps_the_interface():
    from rmdrake.calibration.kind import MeasurementKind, PlanSizing
    from rmdrake.calibration.registry import KINDS

    assert KINDS["poses"] is not None and isinstance(KIND, MeasurementKind)
    assert isinstance(KINDS["poses"].plan(20, 1e-4), PlanSizing)


def test_sniff_read_write_describe(case):
    nominal, sim, path = case
    header = path.read_text().splitlines()[0].split(",")
    assert KIND.sniff(header)
    assert not KIND.sniff(["pose", "marker", "q1", "x", "y", "z"])
    data = KIND.read(path, nominal.n_joints)
    assert np.array_equal(data.r_IM, sim.data.r_IM)
    assert KIND.describe(nominal, data, path).startswith("robot 'rv3sb': 30 poses")
    with pytest.raises(ValueError, match="socket measurements; these are pose"):
        KIND.read(path, distances=[(1, 2, 0.1)])


def test_calibrator_of_a_config(case):
    nominal, sim, _ = case
    config = CalibrationConfig(
        params="offsets", noise=2e-5, calibrator=PoseLMConfig(angle_noise=5e-5)
    )
    est = KIND.calibrator(config, nominal).fit(sim.data)
    assert est.sanity_.ok and est.names_ and est.params == "offsets"
    assert est.model_.calibration["noise"] == {
        "position": 2e-5,
        "angle": 5e-5,
        "source": "declared",
    }
    with pytest.raises(ValueError, match="PointLMConfig") as info:
        KIND.calibrator(CalibrationConfig(calibrator=PointLMConfig()), nominal)
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="rigid joints only"):
        KIND.calibrator(CalibrationConfig(compliance=True), nominal)


def test_cli_options_and_foreign_refusal(tmp_path):
    options = argparse.Namespace(
        method=None, angle_noise=1e-4, seed=3, folds=4, holdout=None
    )
    cfg = KIND.calibrator_options(options, "p.csv")
    assert (cfg.angle_noise, cfg.seed, cfg.folds) == (1e-4, 3, 4)
    with pytest.raises(ValueError, match="--angle-noise is for pose"):
        KIND.refuse_foreign(options, "points.csv", "point")
    KIND.refuse_foreign(argparse.Namespace(), "points.csv", "point")
    with pytest.raises(ValueError, match="lm only"):
        KIND.calibrator_options(argparse.Namespace(method="de"), "p.csv")


def test_cross_validation_report(case):
    nominal, sim, _ = case
    config = CalibrationConfig(
        params="offsets",
        noise=2e-5,
        calibrator=PoseLMConfig(angle_noise=5e-5, folds=3),
    )
    est = KIND.calibrator(config, nominal).fit(sim.data)
    report = KIND.cross_validate(config, nominal, sim.data, est)
    assert report.record["readings"] == sim.data.n_rows
    assert "cross-validated pose error (3-fold" in report.lines[0]
    assert KIND.cross_validate(CalibrationConfig(), nominal, sim.data, est) is None


def test_simulate_poses_command(tmp_path, capsys):
    out = tmp_path / "p.csv"
    args = ["simulate-poses", "--robot", "rv3sb", "--out", str(out), "--poses", "12"]
    assert main([*args, "--seed", "5", "--angle-noise", "1e-4"]) == 0
    assert "12 poses" in capsys.readouterr().out
    data = KIND.read(out, 6)
    sim = simulate_poses(load_robot("rv3sb"), poses=12, noise_r=1e-4, seed=5)
    assert np.array_equal(data.p_IM, sim.data.p_IM)


def test_calibrate_file_through_the_kind(case, tmp_path):
    """``calibrate_file`` with the kind handed in (the kinds branch); its YAML
    loads as a robot whose table carries the fitted deltas."""
    from rmdrake.pipelines.calibrate import calibrate_file

    nominal, sim, path = case
    config = CalibrationConfig(
        params="offsets", noise=2e-5, calibrator=PoseLMConfig(angle_noise=5e-5)
    )
    lines: list[str] = []
    out = calibrate_file(
        "rv3sb",
        path,
        tmp_path / "cal.yaml",
        config=config,
        echo=lines.append,
        kind=KIND,
    )
    cal = load_robot(out)
    assert cal.calibration["kind"].startswith("pose kinematic calibration")
    assert cal.calibration["data"]["file"] == str(path)
    assert not np.array_equal(cal.table, nominal.table)
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(path)]  # sniffed
    assert main([*args, "--out", str(tmp_path / "cli.yaml"), "--noise", "2e-5"]) == 0
