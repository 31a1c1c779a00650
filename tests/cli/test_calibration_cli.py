"""`rmdrake simulate-plates` and `rmdrake calibrate`: round trip, and every bad
input of issue 3 (exit code 2, a one-line reason naming the problem, no output
file)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import warnings

import numpy as np
import pytest
import yaml

from rmdrake.calibration.config import (
    CalibrationConfig,
    PlaneLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
    de_start_budget,
)
from rmdrake.calibration.plates.checks import (
    MeasurementWarning,
    check_plane_measurements,
)
from rmdrake.calibration.plates.data import (
    PlaneMeasurements,
    read_plane_measurements,
    write_plane_measurements,
)
from rmdrake.cli.commands import main
from rmdrake.model.error_parameters import apply_deltas, error_parameter_names
from rmdrake.model.loading import load_robot


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A true robot YAML and its simulated readings (5 plates x 8, noise-free)."""
    folder = tmp_path_factory.mktemp("cli")
    nominal = load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    deltas = 3e-4 * np.random.default_rng(9).standard_normal(len(names))
    true = apply_deltas(nominal, names, deltas)
    true_yaml = folder / "true.yaml"
    true.save(true_yaml)
    csv = folder / "m.csv"
    code = main(
        [
            "simulate-plates",
            "--robot",
            str(true_yaml),
            "--out",
            str(csv),
            "--plates",
            "5",
            "--per-plate",
            "8",
            "--noise",
            "0",
            "--seed",
            "2",
        ]
    )
    assert code == 0
    return folder, csv, names, deltas


def test_round_trip_lm(files, capsys):
    folder, csv, names, deltas = files
    out = folder / "cal.yaml"
    code = main(
        [
            "calibrate",
            "--robot",
            "rv3sb",
            "--measurements",
            str(csv),
            "--out",
            str(out),
            "--method",
            "lm",
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "rank 17" in printed and f"wrote {out}" in printed
    cal = load_robot(out)  # same schema: it loads back
    record = cal.calibration
    assert record["method"] == "lm" and record["rank"] == 17
    assert record["data"] == {"readings": 40, "plates": 5, "file": str(csv)}
    got = np.array([record["parameters"][n]["delta"] for n in names])
    assert np.abs(got - deltas).max() < 1e-9
    assert all(record["parameters"][n]["std"] >= 0 for n in names)
    assert record["residual_rms"] < 1e-12 < record["residual_rms_nominal"]
    assert record["condition_number"] > 1
    expected = apply_deltas(load_robot("rv3sb"), names, deltas).table
    np.testing.assert_allclose(cal.table, expected, rtol=0, atol=1e-9)


def test_round_trip_default_de_lm_and_csv(files, capsys):
    folder, csv, names, deltas = files
    data = read_plane_measurements(csv, 6)
    copy = folder / "copy.csv"
    write_plane_measurements(copy, data)
    again = read_plane_measurements(copy, 6)
    np.testing.assert_array_equal(again.q, data.q)  # full precision
    np.testing.assert_array_equal(again.distance, data.distance)
    out = folder / "cal_delm.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    args += ["--out", str(out), "--maxiter", "3", "--no-progress"]
    assert main(args) == 0
    record = yaml.safe_load(out.read_text())["calibration"]
    assert record["method"] == "de+lm"
    got = np.array([record["parameters"][n]["delta"] for n in names])
    assert np.abs(got - deltas).max() < 1e-9


def _config_of(monkeypatch, csv, extra):
    """The CalibrationConfig `rmdrake calibrate` hands the pipeline."""
    seen = {}

    def pipeline(robot, measurements, out, *, config, distances=(), kind=None):
        seen["config"] = config
        seen["distances"] = list(distances)
        return out

    monkeypatch.setattr("rmdrake.pipelines.calibrate.calibrate_file", pipeline)
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    assert main([*args, "--out", str(csv.parent / "x.yaml"), *extra]) == 0
    return seen["config"]


PLATE_CONFIGS = {
    "defaults": (
        [],
        CalibrationConfig(
            calibrator=VolumeDEPlaneLMConfig(
                de=dataclasses.replace(de_start_budget(), progress=True)
            )
        ),
    ),
    "lm": (
        "--method lm --params full --loss huber --f-scale 2e-6 --force --seed 4",
        CalibrationConfig(
            params="full",
            loss="huber",
            f_scale=2e-6,
            force=True,
            calibrator=PlaneLMConfig(),
        ),
    ),
    "de": (
        "--method de --maxiter 5 --seed 3 --no-progress --length-bound 1e-3 "
        "--angle-bound 2e-3 --compliance",
        CalibrationConfig(
            compliance=True,
            calibrator=VolumeDEConfig(
                seed=3, maxiter=5, length_bound=1e-3, angle_bound=2e-3
            ),
        ),
    ),
    "de+lm": (
        "--method de+lm --maxiter 7 --loss soft_l1",
        CalibrationConfig(
            loss="soft_l1",
            calibrator=VolumeDEPlaneLMConfig(
                de=dataclasses.replace(de_start_budget(), maxiter=7, progress=True)
            ),
        ),
    ),
}


@pytest.mark.parametrize(
    "extra, expected", PLATE_CONFIGS.values(), ids=list(PLATE_CONFIGS)
)
def test_the_cli_builds_the_calibration_config(
    files, monkeypatch, capsys, extra, expected
):
    """Each option lands in its place of the config: the common ones in
    CalibrationConfig, the DE's in the method's VolumeDEConfig (--maxiter only
    when given; the method's budget otherwise)."""
    _, csv, _, _ = files
    extra = extra.split() if isinstance(extra, str) else extra
    assert _config_of(monkeypatch, csv, extra) == expected


def test_an_unknown_method_is_refused(files, tmp_path, capsys):
    _, csv, _, _ = files
    out = tmp_path / "x.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    assert main([*args, "--out", str(out), "--method", "ga"]) == 2
    assert "argument --method: invalid choice: 'ga'" in capsys.readouterr().err
    assert not out.exists()


def test_folds_on_plane_measurements_are_refused(files, tmp_path, capsys):
    _, csv, _, _ = files
    out = tmp_path / "x.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(csv)]
    assert main([*args, "--out", str(out), "--folds", "3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"rmdrake: error: {csv}: --folds and --holdout cross-validate point "
        "measurements; these are plane measurements"
    )
    assert not out.exists()


def _write_csv(path, header, rows):
    lines = [",".join(header)] + [",".join(str(v) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")


def _bad(files, tmp_path, mutate, extra=()):
    """Writes a mutated copy of the good CSV, runs calibrate, returns stderr."""
    _, csv, _, _ = files
    text = csv.read_text().splitlines()
    header = text[0].split(",")
    rows = [line.split(",") for line in text[1:]]
    header, rows = mutate(header, rows)
    bad = tmp_path / "bad.csv"
    _write_csv(bad, header, rows)
    out = tmp_path / "out.yaml"
    args = ["calibrate", "--robot", "rv3sb", "--measurements", str(bad)]
    args += ["--out", str(out), "--method", "lm", *extra]
    return args, out


def _set(r, c, v):
    r[c] = v
    return r


BAD_INPUTS = {
    "few readings on a plate": (
        lambda h, rows: (h, [r for r in rows if r[0] != "3"] + rows[24:27]),
        r"fewer than 4 readings on a plate \(plate 3 has 3\)",
    ),
    "few plates": (
        lambda h, rows: (h, [r for r in rows if r[0] in ("0", "1", "2")]),
        r"3 plate location\(s\), at least 4 needed",
    ),
    "NaN": (
        lambda h, rows: (h, [_set(rows[0], 3, "nan"), *rows[1:]]),
        r"line 2, column q3: nan is not a finite number",
    ),
    "non-numeric": (
        lambda h, rows: (h, [rows[0], _set(rows[1], 7, "0.0x3"), *rows[2:]]),
        r"line 3, column distance: '0.0x3' is not a number",
    ),
    "column count": (
        lambda h, rows: (
            [c for i, c in enumerate(h) if i != 6],
            [[c for i, c in enumerate(r) if i != 6] for r in rows],
        ),
        r"5 joint columns \(q1..q5\), but the robot has 6 joints",
    ),
    "ragged row": (
        lambda h, rows: (h, [rows[0][:-1], *rows[1:]]),
        r"line 2 has 7 columns, expected 8",
    ),
    "negative reading": (
        lambda h, rows: (h, [*rows[:5], _set(rows[5], 7, "-0.01"), *rows[6:]]),
        r"negative range reading -0.01 m at reading 6",
    ),
    "degrees": (
        lambda h, rows: (
            h,
            [[r[0], *(str(np.rad2deg(float(v))) for v in r[1:7]), r[7]] for r in rows],
        ),
        r"joint q\d = .* looks like degrees; joint values must be in rad",
    ),
    "bad header": (
        lambda h, rows: (["plate", *h[1:]], rows),
        r"is neither plane measurements \(plane,q1..qn,distance\), point "
        r"measurements \(pose,marker,q1..qn,x,y,z.*\), socket measurements "
        r"\(socket,q1..qn\) nor pose measurements \(q1..qn,x,y,z,rx,ry,rz\)",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_measurements_exit_2_without_output(files, tmp_path, capsys, case):
    mutate, message = BAD_INPUTS[case]
    args, out = _bad(files, tmp_path, mutate)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rmdrake: error: ")
    assert len(err.splitlines()) == 1
    assert __import__("re").search(message, err), err
    assert not out.exists()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--params", "dalpha2,dgamma3"], r"unknown error parameter 'dgamma3'"),
        (["--params", "everything"], r"unknown parameter preset 'everything'"),
        (
            ["--params", "dalpha2,dd2,dr2,dtheta1,dr1"],
            r"not identifiable .*drop .*(dtheta1|dr1)",
        ),
    ],
)
def test_bad_parameters_exit_2_without_output(files, tmp_path, capsys, extra, message):
    args, out = _bad(files, tmp_path, lambda h, r: (h, r), extra)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert __import__("re").search(message, err), err
    assert not out.exists()


def test_joints_outside_limits_warn_but_calibrate(files, tmp_path, capsys):
    """Readings beyond the robot's limits warn and still calibrate. The limit is
    tightened past the readings rather than a reading moved: a moved joint
    angle is a bad reading, which the sanity checks refuse."""
    folder, csv, _, _ = files
    data = read_plane_measurements(csv, 6)
    model = load_robot("rv3sb")
    lower = model.limits.lower.copy()
    lower[2] = float(data.q[:, 2].min()) + 1e-3  # q3's lowest reading is outside
    limits = dataclasses.replace(model.limits, lower=lower)
    robot = dataclasses.replace(model, limits=limits).save(tmp_path / "tight.yaml")
    out = tmp_path / "out.yaml"
    args = ["calibrate", "--robot", str(robot), "--measurements", str(csv)]
    assert main([*args, "--out", str(out), "--method", "lm"]) == 0
    err = capsys.readouterr().err
    assert "rmdrake: warning: " in err and "joint q3 outside its limits" in err
    assert out.exists()


def test_check_warns_with_category(files):
    _, csv, _, _ = files
    data = read_plane_measurements(csv, 6)
    q = data.q.copy()
    q[0, 0] = 3.0  # beyond +170 deg, but not degrees
    model = load_robot("rv3sb")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        msgs = check_plane_measurements(
            PlaneMeasurements(data.plane, q, data.distance),
            n_joints=6,
            lower=model.limits.lower,
            upper=model.limits.upper,
        )
    assert len(msgs) == 1 and "joint q1 outside its limits" in msgs[0]
    assert caught[0].category is MeasurementWarning


def test_simulate_plates_bad_noise_writes_nothing(tmp_path, capsys):
    out = tmp_path / "m.csv"
    args = ["simulate-plates", "--robot", "rv3sb", "--out", str(out)]
    assert main([*args, "--noise=-1e-6"]) == 2
    assert "argument --noise: expected a number >= 0" in capsys.readouterr().err
    assert not out.exists()


def test_console_entry_point_missing_file(tmp_path):
    out = tmp_path / "x.yaml"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "rmdrake.cli",
            "calibrate",
            "--robot",
            "rv3sb",
            "--measurements",
            str(tmp_path / "none.csv"),
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2
    assert result.stderr.strip().startswith("rmdrake: error: cannot read measurements")
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()
