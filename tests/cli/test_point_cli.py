"""`rmdrake simulate-points` and `rmdrake calibrate` on point measurements:
the round trip with cross-validation, the file kind told by the header,
implausible fits refused (exit 3) unless forced, and the real TIAGo data read
in place from a URDF chain."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from rmdrake.calibration.config import CalibrationConfig, PointLMConfig
from rmdrake.calibration.points.data import (
    PointMeasurements,
    read_point_measurements,
    write_point_measurements,
)
from rmdrake.cli.commands import main

TIAGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "tiago_figaroh"


@pytest.fixture(scope="module")
def points(tmp_path_factory):
    folder = tmp_path_factory.mktemp("points")
    csv = folder / "p.csv"
    args = ["simulate-points", "--robot", "rv3sb", "--out", str(csv)]
    assert main([*args, "--poses", "30", "--seed", "4"]) == 0
    return folder, csv


def test_round_trip_with_folds(points, capsys):
    folder, csv = points
    out = folder / "cal.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    code = main([*args, "--out", str(out), "--params", "full", "--folds", "3"])
    printed, err = capsys.readouterr()
    assert code == 0, printed
    assert "cross-validated 3-D point error (3-fold over poses" in printed
    assert "cross-validation splits: 3/3 (100 %)" in err  # progress, batch lines
    record = yaml.safe_load(out.read_text())["calibration"]
    assert record["data"]["file"] == str(csv) and record["data"]["poses"] == 30
    assert len(record["markers"]) == 3 and set(record["X_IB"]) == {"xyz", "rpy"}
    cv = record["cross_validation"]
    assert cv["scheme"] == "3-fold" and not cv["nested"]
    # 20 um per coordinate: a 3-D error of about sqrt(3) x 20 um.
    assert 2e-5 < record["residual_rms"] < cv["rms"] < 6e-5


@pytest.mark.parametrize(
    "extra, expected",
    [
        ([], CalibrationConfig(calibrator=PointLMConfig())),
        (
            "--folds 3 --seed 2 --params offsets --loss huber --maxiter 9",
            CalibrationConfig(
                params="offsets",
                loss="huber",
                calibrator=PointLMConfig(seed=2, folds=3),
            ),
        ),
        (
            "--method lm --holdout 0.25 --compliance --force",
            CalibrationConfig(
                compliance=True, force=True, calibrator=PointLMConfig(holdout=0.25)
            ),
        ),
    ],
    ids=["defaults", "folds", "holdout"],
)
def test_the_cli_builds_the_point_config(points, monkeypatch, extra, expected):
    """Point measurements: a PointLMConfig with --seed, --folds, --holdout (the
    DE's options do not apply)."""
    folder, csv = points
    seen = {}

    def pipeline(robot, measurements, out, *, config, distances=(), kind=None):
        seen["config"] = config
        return out

    monkeypatch.setattr("rmdrake.pipelines.calibrate.calibrate_file", pipeline)
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    extra = extra.split() if isinstance(extra, str) else extra
    assert main([*args, "--out", str(folder / "x.yaml"), *extra]) == 0
    assert seen["config"] == expected


@pytest.mark.parametrize("method", ["de", "de+lm"])
def test_a_plate_method_on_points_is_refused(points, tmp_path, capsys, method):
    _, csv = points
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    assert main([*args, "--out", str(out), "--method", method]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"rmdrake: error: method '{method}': point measurements are calibrated "
        "by lm only"
    )
    assert not out.exists()


def test_neither_header_exit_2(points, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("pose,q1,x\n1,2,3\n")
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(bad)]
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "neither plane measurements" in err[0]
    assert not out.exists()


def test_swapped_markers_refused_then_forced(points, tmp_path, capsys):
    folder, csv = points
    d = read_point_measurements(csv)
    marker = np.array(d.marker)
    half = d.pose >= 15
    marker[half & (d.marker == 1)], marker[half & (d.marker == 2)] = 2, 1
    swapped = write_point_measurements(
        tmp_path / "s.csv", PointMeasurements(d.pose, marker, d.q, d.p_I)
    )
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(swapped)]
    args += ["--out", str(out), "--params", "offsets"]
    assert main(args) == 3
    assert not out.exists()
    capsys.readouterr()
    assert main([*args, "--force"]) == 0
    assert yaml.safe_load(out.read_text())["calibration"]["warnings"]


@pytest.mark.skipif(not TIAGO.is_dir(), reason="TIAGo data not on this machine")
def test_tiago_urdf_chain_offsets(tmp_path, capsys):
    """Real motion capture: the joint offsets' 5-fold CV RMS matches the
    README's independent fit (4.03 mm) and the training RMS (3.23 mm)."""
    out = tmp_path / "tiago.yaml"
    code = main(
        [
            "calibrate",
            "--robot",
            str(TIAGO / "tiago.urdf"),
            "--base",
            "base_footprint",
            "--tip",
            "wrist_ft_tool_link",
            "--measurements",
            str(TIAGO / "points_2021-11-30.csv"),
            "--out",
            str(out),
            "--params",
            "offsets",
            "--folds",
            "5",
        ]
    )
    assert code == 0, capsys.readouterr()
    record = yaml.safe_load(out.read_text())["calibration"]
    assert abs(record["residual_rms"] - 3.23e-3) < 0.02e-3
    assert abs(record["cross_validation"]["rms"] - 4.03e-3) < 0.05e-3
    assert len(record["markers"]) == 4
