"""A residual over the noise: a warning that names the likely cause and the
option to try between 3x and 30x the noise, a refusal beyond (the rule of
rmdrake.calibration.sanity). The case is a new user's: a robot perturbed on
every error parameter, its plates read with 2 um noise, calibrated with the
paper's 17 parameters and the noise declared."""

from __future__ import annotations

import re

import yaml

from rmdrake.cli.commands import main


def test_missing_parameters_warn_and_the_option_finds_them(tmp_path, capsys):
    true, plates = tmp_path / "true.yaml", tmp_path / "plates.csv"
    assert main(["perturb", "--robot", "rv3sb", "--params", "full", "--out",
                 str(true), "--seed", "0"]) == 0  # fmt: skip
    assert main(["simulate-plates", "--robot", str(true), "--out", str(plates),
                 "--seed", "1", "--noise", "2e-6"]) == 0  # fmt: skip
    capsys.readouterr()
    out = tmp_path / "paper.yaml"
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(plates),
            "--noise", "2e-6", "--method", "lm"]  # fmt: skip
    assert main([*argv, "--params", "paper", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    ratio = float(re.search(r"is ([\d.]+) times the noise \(2 um, declared\)",
                            printed).group(1))  # fmt: skip
    assert 3 < ratio <= 30, printed
    assert "warning: residual" in printed and "try --params auto or full" in printed
    assert "plausible, with 1 warning(s)" in printed
    record = yaml.safe_load(out.read_text())["calibration"]
    assert "try --params auto" in record["sanity_warnings"][0]
    # the option the warning names: the residual back at the noise, no warning
    assert main([*argv, "--params", "auto", "--out", str(tmp_path / "a.yaml")]) == 0
    printed = capsys.readouterr().out
    assert "warning: residual" not in printed and "sanity: plausible;" in printed


def test_far_over_the_noise_is_still_refused(tmp_path, capsys):
    plates = tmp_path / "plates.csv"
    assert main(["simulate-plates", "--robot", "rv3sb", "--out", str(plates),
                 "--seed", "1", "--noise", "2e-6"]) == 0  # fmt: skip
    argv = ["calibrate", "--robot", "rv3sb", "--measurements", str(plates),
            "--noise", "2e-8", "--out", str(tmp_path / "c.yaml")]  # fmt: skip
    assert main(argv) == 3  # 2 um readings declared as 0.02 um: about 100x
    assert "over 30x: readings the model cannot explain" in capsys.readouterr().err
    assert not (tmp_path / "c.yaml").exists()
