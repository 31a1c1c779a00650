"""Hostile socket inputs: `calibrate` on socket CSVs, `import-sockets` and
`simulate-sockets` refuse gross data errors and wrong units with one line and
the right exit code, write nothing and leave every input byte for byte as it
was; MUKCa's real folders still import and calibrate."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from rmdrake.calibration.sockets.data import read_socket_measurements
from rmdrake.cli.commands import main

MUKCA = SHARED_DATA / "mukca_panda"
NO_MUKCA = f"the MUKCa Panda data are not in {MUKCA}"
PANDA = ["--robot", str(MUKCA / "panda.urdf"), "--base", "panda_link0"]
PANDA += ["--tip", "ball_link"]


@pytest.fixture(scope="module")
def sockets(tmp_path_factory) -> Path:
    """An RV-3SB's socket CSV: 3 placements x 2 sockets x 10 configurations,
    20 um seating noise, its distance file beside it."""
    folder = tmp_path_factory.mktemp("sockets")
    argv = ["simulate-sockets", "--robot", "rv3sb", "--out", str(folder / "s.csv")]
    assert main([*argv, "--placements", "3", "--per-socket", "10", "--seed", "2"]) == 0
    return folder / "s.csv"


def _copy(src: Path, folder: Path, name: str, distances: str | None = None) -> Path:
    """``src`` copied as ``folder/name.csv`` with ``distances`` (the text of
    its distance file; None: the source's)."""
    path = folder / f"{name}.csv"
    path.write_bytes(src.read_bytes())
    side = src.with_name(f"{src.stem}_distances.csv")
    text = side.read_text() if distances is None else distances
    (folder / f"{name}_distances.csv").write_text(text)
    return path


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every regular file under ``folder``: its bytes."""
    return {
        str(p): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def _refused(capsys, argv: list[str], code: int, says: str, folder: Path) -> str:
    """Runs ``argv``: exit ``code``, one line on stderr with ``says`` in it,
    no new file in ``folder`` and every file there unchanged."""
    before = _snapshot(folder)
    assert main(argv) == code
    err = capsys.readouterr().err.strip().splitlines()
    err = [e for e in err if not e.startswith("rmdrake: warning:")]  # the URDF's
    assert len(err) == 1 or (code == 3 and err[0].startswith("rmdrake: refused:"))
    assert says in "\n".join(err), err
    assert _snapshot(folder) == before
    return err[0]


def _calibrate(path: Path, out: Path, *extra: str) -> list[str]:
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(path)]
    return [*argv, "--out", str(out), *extra]


# ---- calibrate: gross data errors --------------------------------------------------
@pytest.mark.parametrize("distance", ["50", "5"])
def test_distances_in_mm_or_cm_are_refused_at_the_door(
    sockets, tmp_path, capsys, distance
):
    text = sockets.with_name("s_distances.csv").read_text()
    bad = _copy(sockets, tmp_path, "mm", text.replace(",0.05\n", f",{distance}\n"))
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    line = _refused(capsys, argv, 2, "mm? convert the distances to m", tmp_path)
    assert f"known distance {distance} m between sockets 0 and 1" in line


def test_sockets_swapped_across_placements_are_refused(sockets, tmp_path, capsys):
    lines = sockets.read_text().splitlines()
    swap = {"0": "2", "2": "0"}
    rows = [lines[0]] + [
        ",".join([swap.get(r.split(",")[0], r.split(",")[0]), *r.split(",")[1:]])
        for r in lines[1:]
    ]
    bad = tmp_path / "swap.csv"
    bad.write_text("\n".join(rows) + "\n")
    side = sockets.with_name("s_distances.csv").read_bytes()
    (tmp_path / "swap_distances.csv").write_bytes(side)
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    _refused(capsys, argv, 2, "socket ids mixed up between placements", tmp_path)


def test_a_false_cross_placement_distance_is_refused(sockets, tmp_path, capsys):
    text = sockets.with_name("s_distances.csv").read_text() + "0,2,0.05\n"
    bad = _copy(sockets, tmp_path, "cross", text)
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    _refused(capsys, argv, 2, "between sockets 0 and 2, but robot 'rv3sb'", tmp_path)
    good = _copy(sockets, tmp_path, "good")
    argv = _calibrate(good, tmp_path / "cal.yaml", "--socket-distance", "0,2,0.05")
    _refused(capsys, argv, 2, "between sockets 0 and 2, but robot 'rv3sb'", tmp_path)


def test_conflicting_distances_of_one_pair_are_refused(sockets, tmp_path, capsys):
    text = sockets.with_name("s_distances.csv").read_text() + "1,0,0.08\n"
    bad = _copy(sockets, tmp_path, "dup", text)
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    _refused(capsys, argv, 2, "give one distance per pair", tmp_path)
    good = _copy(sockets, tmp_path, "good")
    twice = ["--socket-distance", "0,1,0.05", "--socket-distance", "1,0,0.06"]
    argv = _calibrate(good, tmp_path / "cal.yaml", *twice)
    _refused(capsys, argv, 2, "given as 0.05 and 0.06 m: give one per pair", tmp_path)
    # the same distance twice is one distance, not a conflict
    same = "0,1,0.05\n0,1,0.05\n"
    text = sockets.with_name("s_distances.csv").read_text() + same
    assert read_socket_measurements(_copy(sockets, tmp_path, "same", text)).distances[
        0
    ].tolist() == [0, 1, 0.05]


def test_a_distance_file_of_more_rows_than_pairs_is_refused(sockets, tmp_path, capsys):
    rows = "".join(f"{2 * (i % 3)},{2 * (i % 3) + 1},0.05\n" for i in range(3000))
    bad = _copy(sockets, tmp_path, "big", "socket_a,socket_b,distance\n" + rows)
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    _refused(capsys, argv, 2, "3000 distances for the 6 sockets", tmp_path)


@pytest.mark.parametrize("kind", ["fifo", "folder", "zero", "loop", "dangling"])
def test_a_distance_file_that_is_not_a_file_is_refused(sockets, tmp_path, capsys, kind):
    path = tmp_path / "s.csv"
    path.write_bytes(sockets.read_bytes())
    side = tmp_path / "s_distances.csv"
    make = {
        "fifo": lambda: os.mkfifo(side),
        "folder": side.mkdir,
        "zero": lambda: side.symlink_to("/dev/zero"),
        "loop": lambda: side.symlink_to(side),
        "dangling": lambda: side.symlink_to(tmp_path / "nowhere"),
    }
    make[kind]()
    says = {
        "fifo": "is a FIFO, not a regular file",
        "folder": "Is a directory",
        "zero": "is a device, not a regular file",
        "loop": "Too many levels of symbolic links",
        "dangling": "No such file or directory",
    }[kind]
    argv = _calibrate(path, tmp_path / "cal.yaml")
    line = _refused(capsys, argv, 2, says, tmp_path)
    assert "s_distances.csv" in line


def test_sockets_mixed_within_their_rows_refuse_auto(sockets, tmp_path, capsys):
    """Half of socket 0's rows said to be socket 2's and back, no distance
    file: the noise auto estimates from its own residuals is tens of mm, which
    no seating explains."""
    lines = sockets.read_text().splitlines()
    rows = [r.split(",") for r in lines[1:]]
    for s, t in (("0", "2"), ("2", "0")):
        for r in [r for r in rows if r[0] == s][:5]:
            r[0] = t + "*"
    bad = tmp_path / "mix.csv"
    body = [",".join([r[0].rstrip("*"), *r[1:]]) for r in rows]
    bad.write_text("\n".join([lines[0], *body]) + "\n")
    argv = _calibrate(bad, tmp_path / "cal.yaml")
    _refused(capsys, argv, 3, "not noise", tmp_path)


def test_drop_outliers_refuses_to_drop_a_large_share(sockets, tmp_path, capsys):
    """A quarter of the rows moved (joint 1 by 0.05 rad): --drop-outliers
    does not drop them and call the rest plausible."""
    lines = sockets.read_text().splitlines()
    rows = [r.split(",") for r in lines[1:]]
    for i, r in enumerate(rows):
        if i % 4 == 0:
            r[1] = repr(float(r[1]) + 0.05)
    bad = _copy(sockets, tmp_path, "moved")
    bad.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    argv = _calibrate(bad, tmp_path / "cal.yaml", "--drop-outliers")
    _refused(capsys, argv, 3, "over 10 %", tmp_path)


@pytest.mark.parametrize(
    "extra, says",
    [
        (["--noise", "0"], "leave --noise out to estimate it"),
        (["--noise", "1"], "mm? convert to m"),
        (["--noise", "0.005"], "at most 1 mm per coordinate: mm?"),
        (["--distance-noise", "1000"], "at most 10 mm: mm?"),
    ],
)
def test_noise_options_out_of_bounds_are_refused(
    sockets, tmp_path, capsys, extra, says
):
    path = _copy(sockets, tmp_path, "s")
    argv = _calibrate(path, tmp_path / "cal.yaml", *extra)
    _refused(capsys, argv, 2, says, tmp_path)


def test_calibrate_never_writes_over_its_distance_file(sockets, tmp_path, capsys):
    path = _copy(sockets, tmp_path, "s")
    argv = _calibrate(path, tmp_path / "s_distances.csv")
    _refused(capsys, argv, 2, "is also the input --measurements (side file)", tmp_path)


# ---- import-sockets ------------------------------------------------------------
@pytest.fixture
def placements(sockets, tmp_path) -> Path:
    """MUKCa's layout of the simulated rows: 3 placement folders of
    hole_0.csv and hole_1.csv (rad, no header)."""
    data = read_socket_measurements(sockets)
    folder = tmp_path / "mukca"
    for p in range(3):
        for hole in (0, 1):
            rows = data.q[data.socket == 2 * p + hole]
            (folder / f"p{p}").mkdir(parents=True, exist_ok=True)
            np.savetxt(folder / f"p{p}" / f"hole_{hole}.csv", rows, delimiter=",")
    return folder


@pytest.mark.parametrize("kind", ["fifo", "zero", "folder", "dangling"])
def test_import_refuses_a_hole_that_is_not_a_file(placements, tmp_path, capsys, kind):
    hole = placements / "p1" / "hole_0.csv"
    hole.unlink()
    make = {
        "fifo": lambda: os.mkfifo(hole),
        "zero": lambda: hole.symlink_to("/dev/zero"),
        "folder": hole.mkdir,
        "dangling": lambda: hole.symlink_to(tmp_path / "nowhere"),
    }
    make[kind]()
    argv = ["import-sockets", str(placements), "--out", str(tmp_path / "o.csv")]
    line = _refused(capsys, argv, 2, str(hole), tmp_path)
    says = {"fifo": "a FIFO", "zero": "a device", "folder": "Is a directory"}
    assert says.get(kind, "No such file") in line


def test_import_refuses_degrees(placements, tmp_path, capsys):
    hole = placements / "p2" / "hole_1.csv"
    q = np.loadtxt(hole, delimiter=",")
    np.savetxt(hole, np.rad2deg(q), delimiter=",")
    argv = ["import-sockets", str(placements), "--out", str(tmp_path / "o.csv")]
    line = _refused(capsys, argv, 2, "looks like degrees", tmp_path)
    assert str(hole) in line


def test_import_refuses_a_distance_in_mm(placements, tmp_path, capsys):
    argv = ["import-sockets", str(placements), "--out", str(tmp_path / "o.csv")]
    _refused(capsys, [*argv, "--distance", "50"], 2, "mm? convert to m", tmp_path)


@pytest.mark.parametrize("side", [False, True])
def test_import_never_writes_over_a_hole(placements, tmp_path, capsys, side):
    """Neither the CSV nor its distance file (here a link to a hole) replaces
    a hole file."""
    out = placements / "p0" / "hole_0.csv"
    if side:
        out = placements / "p0" / "o.csv"
        (placements / "p0" / "o_distances.csv").symlink_to("hole_1.csv")
    argv = ["import-sockets", str(placements), "--out", str(out)]
    _refused(capsys, argv, 2, "is also the input DIR", tmp_path)


def test_import_on_a_full_disk_replaces_neither_file(
    placements, tmp_path, capsys, monkeypatch
):
    """The socket CSV and its distance file are replaced together or not at
    all: a disk full at the second file leaves both old files."""
    out = tmp_path / "o.csv"
    argv = ["import-sockets", str(placements), "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    for p in placements.iterdir():  # new rows: a run that would change both
        hole = p / "hole_0.csv"
        hole.write_text(hole.read_text().splitlines()[0] + "\n" + hole.read_text())
    calls = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    _refused(capsys, argv, 2, "No space left on device", tmp_path)
    assert len(calls) == 2
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# ---- simulate-sockets ----------------------------------------------------------
SHIPPED = Path(__file__).parents[2] / "src" / "rmdrake" / "model"


@pytest.mark.parametrize(
    "option, source",
    [("--robot", "shipped/rv3sb.yaml"), ("--scene", "cells/rv3sb_table.yaml")],
)
def test_simulate_never_writes_its_distance_file_over_an_input(
    tmp_path, capsys, option, source
):
    """A robot or cell file named like the distance file of --out is refused,
    not replaced."""
    named = tmp_path / "s_distances.csv"
    named.write_bytes((SHIPPED / source).read_bytes())
    argv = ["simulate-sockets", "--out", str(tmp_path / "s.csv"), "--placements", "1"]
    argv += ["--per-socket", "4", "--robot", "rv3sb", option, str(named)]
    _refused(capsys, argv, 2, f"is also the input {option}", tmp_path)


def test_simulate_refuses_a_million_placements_up_front(tmp_path, capsys):
    argv = ["simulate-sockets", "--robot", "rv3sb", "--out", str(tmp_path / "s.csv")]
    line = _refused(
        capsys, [*argv, "--placements", "1000000"], 2, "bound of 100", tmp_path
    )
    assert "placements" in line
    argv += ["--placements", "100", "--per-socket", "1000"]
    _refused(capsys, argv, 2, "over the bound of 20000", tmp_path)


# ---- the real data pass --------------------------------------------------------
@pytest.mark.skipif(not MUKCA.is_dir(), reason=NO_MUKCA)
def test_real_mukca_folders_pass_and_their_mm_fail(tmp_path, capsys):
    """MUKCa's real Panda imports and calibrates (auto) as plausible under
    every new rule; the same distances in mm are refused at the door."""
    out = tmp_path / "mukca.csv"
    assert (
        main(["import-sockets", str(MUKCA / "panda_2_clean"), "--out", str(out)]) == 0
    )
    argv = ["calibrate", *PANDA, "--measurements", str(out)]
    assert main([*argv, "--out", str(tmp_path / "cal.yaml")]) == 0
    assert "sanity: plausible" in capsys.readouterr().out
    side = tmp_path / "mukca_distances.csv"
    side.write_text(side.read_text().replace(",0.05\n", ",50.0\n"))
    _refused(
        capsys,
        [*argv, "--out", str(tmp_path / "mm.yaml")],
        2,
        "mm? convert the distances to m",
        tmp_path,
    )
