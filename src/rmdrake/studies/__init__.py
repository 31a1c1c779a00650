"""rmdrake.studies: the studies of the paper and beyond, run from typed
scenarios (:mod:`rmdrake.studies.scenarios`, shipped in ``scenarios.yaml``).

Layering: studies use :mod:`rmdrake.pipelines`, :mod:`rmdrake.systems` (Drake
diagrams) and the core numerics; nothing below imports a study. Each study is a
sequence of steps returning dataclasses, then a writer of its files.
"""

from rmdrake.pipelines.show import robot_summary, save_robot_html
from rmdrake.studies.calibration import (
    CalibrationDraw,
    CalibrationStudyResult,
    draw_true_robot,
    run_calibration_study,
)
from rmdrake.studies.compensation import (
    CompensationStudyResult,
    run_static_accuracy_study,
)
from rmdrake.studies.elastic_arm import ComplianceStudyResult, run_compliance_study
from rmdrake.studies.identification import (
    IdentificationStudy,
    perturb_dynamics,
    run_identification_study,
    simulate_log,
)
from rmdrake.studies.planning import PlanConfig, run_plan
from rmdrake.studies.runner import run_scenario
from rmdrake.studies.scenarios import (
    SHIPPED_SCENARIOS,
    CalibrationStudyConfig,
    CompensationStudyConfig,
    ComplianceStudyConfig,
    ExcitationRunConfig,
    IdentificationStudyConfig,
    LoopIdentificationConfig,
    Scenario,
    load_scenario,
    scenario_names,
)

__all__ = [
    "SHIPPED_SCENARIOS",
    "CalibrationDraw",
    "CalibrationStudyConfig",
    "CalibrationStudyResult",
    "CompensationStudyConfig",
    "CompensationStudyResult",
    "ComplianceStudyConfig",
    "ComplianceStudyResult",
    "ExcitationRunConfig",
    "IdentificationStudy",
    "IdentificationStudyConfig",
    "LoopIdentificationConfig",
    "PlanConfig",
    "Scenario",
    "draw_true_robot",
    "load_scenario",
    "perturb_dynamics",
    "robot_summary",
    "run_calibration_study",
    "run_compliance_study",
    "run_identification_study",
    "run_plan",
    "run_static_accuracy_study",
    "run_scenario",
    "save_robot_html",
    "scenario_names",
    "simulate_log",
]
