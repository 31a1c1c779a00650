"""`rmdrake simulate-sockets` and `rmdrake import-sockets`: both write a socket
CSV and its distance file that read back; a simulation is reproducible and,
with a robot cell, keeps its clearance (Drake's distance query as the oracle);
MUKCa's real recordings import bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA, cell_distances

from rmdrake.calibration.sockets.data import (
    read_mukca_sockets,
    read_socket_measurements,
)
from rmdrake.cli.commands import main
from rmdrake.kinematics.clearance import default_collision_radius
from rmdrake.model.loading import load_robot
from rmdrake.model.scene import load_cell

MUKCA = SHARED_DATA / "mukca_panda"
NO_MUKCA = f"the MUKCa Panda data are not in {MUKCA}"


def _simulate(out: Path, *extra: str) -> int:
    argv = ["simulate-sockets", "--robot", "rv3sb", "--out", str(out)]
    return main([*argv, "--placements", "2", "--per-socket", "8", *extra])


def test_simulate_sockets_writes_readable_files(tmp_path, capsys):
    out = tmp_path / "sockets.csv"
    assert _simulate(out, "--seed", "3", "--distance", "0.08") == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith(
        "robot 'rv3sb' (seed 3): 32 configurations: 2 placements x 2 sockets "
        "(80 mm apart), 8 per socket; seating noise "
    )
    assert printed[1] == f"wrote {out} and {tmp_path / 'sockets_distances.csv'}"
    data = read_socket_measurements(out, 6)
    np.testing.assert_array_equal(data.socket, np.repeat(np.arange(4), 8))
    np.testing.assert_array_equal(data.distances, [[0, 1, 0.08], [2, 3, 0.08]])
    again = tmp_path / "again.csv"
    assert _simulate(again, "--seed", "3", "--distance", "0.08") == 0
    assert again.read_bytes() == out.read_bytes()


def test_simulate_sockets_keeps_clear_of_the_cell(tmp_path, capsys):
    model, cell = load_robot("rv3sb"), load_cell("rv3sb_table")
    radius = default_collision_radius(model)
    out = tmp_path / "sockets.csv"
    assert _simulate(out, "--seed", "1", "--scene", "rv3sb_table") == 0
    q = read_socket_measurements(out, 6).q
    assert q.shape == (32, 6)
    assert cell_distances(model, cell, radius, q).min() >= 0.05
    # the cell matters: without it some configurations come closer
    assert _simulate(tmp_path / "free.csv", "--seed", "1") == 0
    free = read_socket_measurements(tmp_path / "free.csv", 6).q
    assert cell_distances(model, cell, radius, free).min() < 0.05


@pytest.mark.skipif(not MUKCA.is_dir(), reason=NO_MUKCA)
def test_import_sockets_real_folder(tmp_path, capsys):
    out = tmp_path / "mukca.csv"
    folder = MUKCA / "panda_2_clean"
    assert main(["import-sockets", str(folder), "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == "placement back_left: sockets 0 (31 rows), 1 (31 rows)"
    assert printed[7] == "placement mid_right: sockets 14 (33 rows), 15 (30 rows)"
    assert printed[8] == (
        "497 configurations of 7 joints in 8 placements, sockets 0.05 m apart"
    )
    assert printed[9] == f"wrote {out} and {tmp_path / 'mukca_distances.csv'}"
    data = read_socket_measurements(out, 7)
    ref, _ = read_mukca_sockets(folder)
    assert data.q.tobytes() == ref.q.tobytes()
    np.testing.assert_array_equal(data.socket, ref.socket)
    assert data.distances.tobytes() == ref.distances.tobytes()


def test_import_sockets_refuses_a_folder_without_placements(tmp_path, capsys):
    code = main(["import-sockets", str(tmp_path), "--out", str(tmp_path / "s.csv")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no placement folder with hole_0.csv" in err[0], err
    assert not (tmp_path / "s.csv").exists()
    missing = str(tmp_path / "missing")
    assert main(["import-sockets", missing, "--out", str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rmdrake: error: argument DIR: {missing}: not a folder"]


# ---- calibrate and plan on sockets ------------------------------------------------
@pytest.fixture(scope="module")
def socket_files(tmp_path_factory):
    """A true RV-3SB (every MDH parameter 0.3 mm / 0.3 mrad off) and its socket
    files: 4 placements x 2 sockets x 12 configurations, 20 um seating noise."""
    from rmdrake.model.perturb import perturb_robot

    folder = tmp_path_factory.mktemp("sockets")
    true, _ = perturb_robot(
        load_robot("rv3sb"), params="full", length_std=3e-4, angle_std=3e-4, seed=2
    )
    true.save(folder / "true.yaml")
    argv = ["simulate-sockets", "--robot", str(folder / "true.yaml")]
    argv += ["--out", str(folder / "s.csv"), "--placements", "4"]
    assert main([*argv, "--per-socket", "12", "--noise", "2e-5", "--seed", "1"]) == 0
    return folder


def test_calibrate_sockets_then_correct_and_export(socket_files, tmp_path, capsys):
    """calibrate reads the socket CSV and its distance file, reports the
    held-out placements, records MUKCa's metrics; the result corrects a joint
    program and exports as a URDF."""
    import yaml

    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements"]
    argv += [str(socket_files / "s.csv"), "--out", str(out)]
    assert main([*argv, "--params", "full", "--folds", "placements"]) == 0
    printed = capsys.readouterr().out
    assert "96 configurations in 8 sockets, 4 placements, 4 known distances" in printed
    assert "held-out placements (leave one out)" in printed
    record = yaml.safe_load(out.read_text())["calibration"]
    metrics = record["metrics"]
    assert metrics["consistency_mean"] < 0.1 * metrics["consistency_mean_nominal"]
    assert record["cross_validation"]["placements"] == 4
    assert max(abs(d) for d in metrics["distortion"]) < 1e-4
    q = tmp_path / "q.csv"
    q.write_text("q1,q2,q3,q4,q5,q6\n0.1,0.3,0.9,0.1,0.6,0.2\n")
    argv = ["correct", "--robot", str(out), "--nominal", "rv3sb"]
    assert main([*argv, "--targets", str(q), "--out", str(tmp_path / "qc.csv")]) == 0
    argv = ["export-urdf", "--robot", str(out), "--out", str(tmp_path / "cal.urdf")]
    assert main(argv) == 0


def test_calibrate_refuses_a_row_from_another_socket(socket_files, tmp_path, capsys):
    """A row labelled with the wrong socket (its ball is 50 mm or more from
    that socket) is named and the fit refused with nothing written;
    --drop-outliers drops that row alone and writes the result."""
    lines = (socket_files / "s.csv").read_text().splitlines()
    cells = lines[5].split(",")
    lines[5] = ",".join(["7", *cells[1:]])  # a socket-0 row said to be socket 7
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    (tmp_path / "bad_distances.csv").write_bytes(
        (socket_files / "s_distances.csv").read_bytes()
    )
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(bad)]
    argv += ["--out", str(out), "--params", "full"]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "rmdrake: refused:" in err and "row 5 (socket 7" in err
    assert not out.exists()
    assert main([*argv, "--drop-outliers"]) == 0
    assert "dropped 1 outlying configuration(s): rows 5" in capsys.readouterr().out
    assert out.exists()


@pytest.mark.parametrize(
    "extra, says",
    [
        (["--socket-distance", "0,1"], "expected SOCKET_A,SOCKET_B,METRES"),
        (["--socket-distance", "0,1,-2"], "expected a positive distance"),
        (["--socket-distance", "0,99,0.05"], "socket 99 has a known distance"),
        (["--holdout", "0.2"], "cross-validate over placements only"),
        (["--method", "de"], "calibrated by lm only"),
        (["--loss", "huber"], "fitted by linear least squares"),
    ],
)
def test_calibrate_sockets_refuses_bad_options(
    socket_files, tmp_path, capsys, extra, says
):
    argv = ["calibrate", "--robot", "rv3sb", "--measurements"]
    argv += [str(socket_files / "s.csv"), "--out", str(tmp_path / "x.yaml")]
    assert main([*argv, *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rmdrake: error: ") and says in err
    assert not (tmp_path / "x.yaml").exists()


def test_socket_options_on_other_measurements_are_refused(tmp_path, capsys):
    pts = tmp_path / "p.csv"
    argv = ["simulate-points", "--robot", "rv3sb", "--out", str(pts), "--poses", "12"]
    assert main(argv) == 0
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(pts)]
    argv += ["--out", str(tmp_path / "x.yaml")]
    for extra in (["--folds", "placements"], ["--drop-outliers"]):
        assert main([*argv, *extra]) == 2
        assert "are for socket measurements" in capsys.readouterr().err
    assert main([*argv, "--socket-distance", "0,1,0.05"]) == 2
    assert "is for socket measurements" in capsys.readouterr().err


def test_sockets_plan(tmp_path, capsys):
    """rmdrake plan --placements: every arm calibrated from simulated sockets
    and measured at held-out poses; the files are written."""
    import yaml

    out = tmp_path / "plan"
    argv = ["plan", "--robot", "rv3sb", "--robots", "2", "--placements", "4"]
    argv += ["--per-socket", "12", "--noise", "2e-5", "--length-std", "3e-4"]
    argv += ["--angle-std", "3e-4", "--params", "full", "--target", "2e-4"]
    argv += ["--confidence", "0.2"]  # what 2 of 2 arms show (95 % lower bound)
    assert main([*argv, "--workers", "0", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "96 configurations (4 placements x 2 sockets x 12)" in printed
    summary = yaml.safe_load((out / "summary.yaml").read_text())
    assert summary["recommendation"]["readings"] == 96
    assert "ok" in (out / "robots.csv").read_text()
    argv[argv.index("--per-socket") : argv.index("--per-socket") + 2] = []
    assert main([*argv, "--markers", "3", "--out", str(tmp_path / "p2")]) == 2
    assert "--markers: a tracker plan's option" in capsys.readouterr().err
