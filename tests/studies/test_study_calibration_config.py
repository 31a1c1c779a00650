"""The plate calibration inside the closed-loop and elastic-arm studies: their
flat scenario fields read once, typed, into the draw settings and the
CalibrationConfig of the LM fit."""

from __future__ import annotations

import pytest

from rmdrake.calibration.config import CalibrationConfig, PlaneLMConfig
from rmdrake.studies.calibration import plate_calibration, plate_study_config
from rmdrake.studies.compliance_config import ComplianceStudyConfig
from rmdrake.studies.scenarios import (
    CalibrationStudyConfig,
    CompensationStudyConfig,
    load_scenario,
    scenario_names,
)

SHARED = ("params", "mean_error", "plates", "per_plate", "noise", "n_validation")


def _sections():
    """Every compensation and compliance section of the shipped scenarios."""
    for name in scenario_names():
        scenario = load_scenario(name=name)
        for section in (scenario.compensation, scenario.compliance):
            if section is not None:
                yield name, section


@pytest.mark.parametrize(
    "config",
    [
        CompensationStudyConfig(),
        ComplianceStudyConfig(),
        CompensationStudyConfig(params="full", noise=5e-6, plates=7, per_plate=9),
        ComplianceStudyConfig(params="full", mean_error=2e-3, n_validation=30),
    ],
    ids=["compensation", "compliance", "compensation-full", "compliance-full"],
)
def test_plate_calibration_reads_the_shared_fields(config):
    draw, fit = plate_calibration(config)
    assert isinstance(draw, CalibrationStudyConfig)
    for field in SHARED:
        assert getattr(draw, field) == getattr(config, field), field
    assert fit == CalibrationConfig(
        params=config.params, noise=config.noise, calibrator=PlaneLMConfig()
    )


def test_every_shipped_section_has_its_calibration():
    found = list(_sections())
    assert found, "no scenario calibrates inside a study"
    for name, section in found:
        draw, fit = plate_calibration(section)
        assert (draw.params, draw.noise) == (fit.params, fit.noise), name


def test_plate_study_config_is_a_deprecated_alias():
    config = CompensationStudyConfig(plates=3)
    with pytest.warns(DeprecationWarning, match="plate_calibration"):
        draw = plate_study_config(config)
    assert draw == plate_calibration(config)[0]
