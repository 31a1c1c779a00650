"""rmdrake.studies: the studies of the paper and beyond, run from typed
scenarios (:mod:`rmdrake.studies.scenarios`, shipped in ``scenarios.yaml``).

Layering: studies use :mod:`rmdrake.systems` (Drake diagrams) and the core
numerics; nothing below imports a study.
"""

from rmdrake.studies.calibration import (
    CalibrationDraw,
    CalibrationStudyResult,
    draw_true_robot,
    run_calibration_study,
)
from rmdrake.studies.identification import (
    IdentificationStudy,
    run_identification_study,
    simulate_log,
)
from rmdrake.studies.runner import run_scenario
from rmdrake.studies.scenarios import (
    SHIPPED_SCENARIOS,
    CalibrationStudyConfig,
    IdentificationStudyConfig,
    Scenario,
    load_scenario,
    scenario_names,
)
from rmdrake.studies.show import robot_summary, save_robot_html

__all__ = [
    "SHIPPED_SCENARIOS",
    "CalibrationDraw",
    "CalibrationStudyConfig",
    "CalibrationStudyResult",
    "IdentificationStudy",
    "IdentificationStudyConfig",
    "Scenario",
    "draw_true_robot",
    "load_scenario",
    "robot_summary",
    "run_calibration_study",
    "run_identification_study",
    "run_scenario",
    "save_robot_html",
    "scenario_names",
    "simulate_log",
]
