"""`rmdrake perturb` and `rmdrake compare`: a seeded true robot, a calibration
that finds its errors (the calibrated robot's tool error to the true one at
least 10x under the nominal's), and the bad inputs (exit 2, one line, nothing
written)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
import yaml

from rmdrake.cli.commands import main
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel

MEAN = re.compile(
    r"tool error between (\S+) and (\S+) over (\d+) random poses: mean ([0-9.]+) "
    r"mm, 95th ([0-9.]+) mm, max ([0-9.]+) mm"
)


def _run(capsys, *argv: str) -> str:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    assert code == 0, out.err
    return out.out


def _mean_mm(printed: str) -> float:
    (m,) = MEAN.findall(printed)
    return float(m[3])


def _error(capsys, *argv: str) -> str:
    """Runs a command expected to fail on bad input: exit 2, one stderr line."""
    assert main([str(a) for a in argv]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def _delta_lines(printed: str) -> list[str]:
    return [s for s in printed.splitlines() if re.match(r"\s+d[a-z]+\d+\s", s)]


def test_same_seed_same_file_other_seed_other_robot(tmp_path, capsys):
    paths = [tmp_path / f"t{i}.yaml" for i in range(3)]
    for path, seed in zip(paths, (1, 1, 2), strict=True):
        _run(capsys, "perturb", "--robot", "rv3sb", "--out", path, "--seed", seed)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()


def test_printed_errors_are_the_files_and_dynamics_leave_them(tmp_path, capsys):
    kin, dyn = tmp_path / "kin.yaml", tmp_path / "dyn.yaml"
    args = ["perturb", "--robot", "rv3sb", "--seed", "4"]
    printed = _run(capsys, *args, "--out", kin)
    printed_dyn = _run(capsys, *args, "--out", dyn, "--dynamics-std", "0.2")
    lines = _delta_lines(printed)
    assert len(lines) == 17 and lines == _delta_lines(printed_dyn)
    assert "dynamics: " in printed_dyn and "dynamics: " not in printed
    a, b = load_robot(str(kin)), load_robot(str(dyn))
    assert np.array_equal(a.table, b.table)  # the kinematic draw is unchanged
    assert not np.array_equal(a.dynamics, b.dynamics)
    nominal = load_robot("rv3sb")
    assert np.array_equal(a.dynamics, nominal.dynamics)
    # the printed values (mm, deg) are the file's (m, rad), read by hand
    d3 = next(s for s in lines if s.split()[0] == "dd3").split()
    assert d3[2] == "mm"
    assert float(d3[1]) * 1e-3 == pytest.approx(a.mdh[2, 1] - nominal.mdh[2, 1],
                                                abs=1e-7)  # fmt: skip
    a2 = next(s for s in lines if s.split()[0] == "dalpha2").split()
    assert a2[2] == "deg"
    assert np.deg2rad(float(a2[1])) == pytest.approx(
        a.mdh[1, 0] - nominal.mdh[1, 0], abs=1e-6
    )
    assert _mean_mm(printed) == _mean_mm(printed_dyn) > 0.1
    data = yaml.safe_load(kin.read_text())
    assert data["name"] == "rv3sb_true"


def test_calibration_finds_the_drawn_errors(tmp_path, capsys):
    """perturb -> simulate-plates -> calibrate (paper parameters, as drawn) ->
    compare: the calibrated robot is >= 10x closer to the true one than the
    nominal is."""
    true, plates, cal = (tmp_path / n for n in ("true.yaml", "p.csv", "cal.yaml"))
    drawn = _run(capsys, "perturb", "--robot", "rv3sb", "--out", true, "--seed", 1)
    _run(capsys, "simulate-plates", "--robot", true, "--out", plates, "--seed", 1)
    _run(capsys, "calibrate", "--robot", "rv3sb", "--measurements", plates,
         "--out", cal, "--params", "paper", "--no-progress")  # fmt: skip
    after = _mean_mm(_run(capsys, "compare", "--robot", true, "--robot", cal))
    before = _mean_mm(_run(capsys, "compare", "--robot", true, "--robot", "rv3sb"))
    assert before == _mean_mm(drawn)  # perturb prints compare's figure
    assert before > 0.3  # errors of 0.5 mm and 1 mrad: about a millimetre
    assert after * 10 <= before


def test_compare_of_a_robot_with_itself_is_zero(tmp_path, capsys):
    printed = _run(capsys, "compare", "--robot", "rv3sb", "--robot", "rv3sb",
                   "--poses", "50", "--seed", "3")  # fmt: skip
    (m,) = MEAN.findall(printed)
    assert m[:3] == ("rv3sb", "rv3sb", "50")
    assert [float(v) for v in m[3:]] == [0.0, 0.0, 0.0]


def _five_joint_yaml(folder) -> str:
    model = load_robot("rv3sb")
    lim = model.limits
    limits = dataclasses.replace(
        lim, **{k: getattr(lim, k)[:5] for k in ("lower", "upper", "velocity",
                                                  "acceleration", "effort")}
    )  # fmt: skip
    five = RobotModel(name="five", mdh=model.mdh[:5], tool=model.tool, limits=limits)
    return str(five.save(folder / "five.yaml"))


def test_compare_refuses_other_robots(tmp_path, capsys):
    five = _five_joint_yaml(tmp_path)
    line = _error(capsys, "compare", "--robot", "rv3sb", "--robot", five)
    assert "6 joints" in line and "5" in line
    line = _error(capsys, "compare", "--robot", "rv3sb", "--robot", "demo_rh")
    assert "other kinematics" in line
    line = _error(capsys, "compare", "--robot", "rv3sb")
    assert "exactly two robots" in line


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--length-std", "-1", "argument --length-std: expected a number >= 0"),
        ("--length-std", "nan", "argument --length-std: expected a finite number"),
        ("--angle-std", "0.5", "angle_std 0.5 rad: over 0.1 rad"),
        ("--dynamics-std", "inf", "argument --dynamics-std: expected a finite"),
        ("--params", "dd3,dz2", "unknown error parameter 'dz2'"),
        ("--stiffness-std", "0.1", "no elastic joint"),
        ("--scale", "fv3", "argument --scale: expected NAME=FACTOR"),
        ("--scale", "fv3=-1", "argument --scale: expected a number > 0"),
        ("--scale", "fv9=1.5", "scale fv9: not a dynamic parameter"),
        ("--scale", "M2=0.01", "link 2 fails"),
    ],
)
def test_bad_perturb_input_writes_nothing(tmp_path, capsys, option, value, message):
    out = tmp_path / "true.yaml"
    line = _error(capsys, "perturb", "--robot", "rv3sb", "--out", out, option, value)
    assert message in line
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_nothing_to_perturb(tmp_path, capsys):
    out = tmp_path / "true.yaml"
    line = _error(capsys, "perturb", "--robot", "rv3sb", "--out", out,
                  "--length-std", "0", "--angle-std", "0")  # fmt: skip
    assert "nothing to perturb" in line and not out.exists()


def test_scale_makes_a_worn_joint_on_top_of_the_draw(tmp_path, capsys):
    """``--scale fv3=1.5,fc3=1.5``: the same draw, joint 3's friction x 1.5,
    nothing else changed; alone (every std 0) it scales the nominal."""
    drawn, worn, alone = (tmp_path / f"{n}.yaml" for n in ("drawn", "worn", "alone"))
    common = ["--robot", "rv3sb", "--dynamics-std", "0.03", "--seed", "4"]
    _run(capsys, "perturb", *common, "--out", drawn)
    _run(capsys, "perturb", *common, "--out", worn, "--scale", "fv3=1.5,fc3=1.5")
    _run(capsys, "perturb", "--robot", "rv3sb", "--length-std", "0", "--angle-std",
         "0", "--scale", "Ia2=2", "--out", alone)  # fmt: skip
    a, b = load_robot(drawn), load_robot(worn)
    factor = np.ones_like(a.dynamics)
    factor[2, 11:13] = 1.5  # joint 3's fv, fc
    np.testing.assert_array_equal(b.dynamics, a.dynamics * factor)
    np.testing.assert_array_equal(b.table, a.table)
    nominal, scaled = load_robot("rv3sb"), load_robot(alone)
    factor = np.ones_like(nominal.dynamics)
    factor[1, 10] = 2.0  # joint 2's rotor inertia
    np.testing.assert_array_equal(scaled.dynamics, nominal.dynamics * factor)
    np.testing.assert_array_equal(scaled.table, nominal.table)


def test_compare_aligned_takes_out_what_plates_cannot_see(tmp_path, capsys):
    """A robot moved as a whole (its base 5 mm up and turned 2 mrad about z:
    dr1, dtheta1): 5 mm and more apart as is, 0 after the best rigid alignment
    (oracle: the move is rigid, so the alignment undoes it exactly)."""
    from rmdrake.model.error_parameters import apply_deltas
    from rmdrake.model.loading import load_robot

    moved = apply_deltas(load_robot("rv3sb"), ["dr1", "dtheta1"], [5e-3, 2e-3])
    moved.save(tmp_path / "moved.yaml")
    argv = ["compare", "--robot", "rv3sb", "--robot", str(tmp_path / "moved.yaml")]
    assert main(argv) == 0
    mean = float(re.search(r"mean ([\d.]+) mm", capsys.readouterr().out).group(1))
    assert mean >= 5.0
    assert main([*argv, "--aligned"]) == 0
    out = capsys.readouterr().out
    assert "mean 0.0000 mm" in out and "max 0.0000 mm" in out
    assert out.strip().endswith("(after the best rigid alignment)")
