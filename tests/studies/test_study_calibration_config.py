"""The plate calibration inside the closed-loop and elastic-arm studies: their
scenario sections share the true robot's draw (PlateDrawConfig, defined once)
with the calibration study, and the LM fit's CalibrationConfig is read from it
in one typed function."""

from __future__ import annotations

import dataclasses

import pytest

from rmdrake.calibration.config import CalibrationConfig, PlaneLMConfig
from rmdrake.studies.calibration import plate_calibration
from rmdrake.studies.scenarios import (
    CalibrationStudyConfig,
    CompensationStudyConfig,
    ComplianceStudyConfig,
    PlateDrawConfig,
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


def test_the_draw_is_defined_once():
    assert tuple(f.name for f in dataclasses.fields(PlateDrawConfig)) == SHARED
    for study in (CalibrationStudyConfig, CompensationStudyConfig):
        assert issubclass(study, PlateDrawConfig)
    # The compliance study keeps its own defaults for the shared fields.
    heavy = ComplianceStudyConfig()
    assert isinstance(heavy, PlateDrawConfig)
    assert (heavy.mean_error, heavy.plates, heavy.noise) == (1e-2, 6, 1e-5)
    assert heavy.n_validation == 500 and heavy.per_plate == 12


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
    assert plate_calibration(config) == CalibrationConfig(
        params=config.params, noise=config.noise, calibrator=PlaneLMConfig()
    )


def test_every_shipped_section_has_its_calibration():
    found = list(_sections())
    assert found, "no scenario calibrates inside a study"
    for name, section in found:
        fit = plate_calibration(section)
        assert (section.params, section.noise) == (fit.params, fit.noise), name
