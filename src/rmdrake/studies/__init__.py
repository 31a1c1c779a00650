"""rmdrake.studies: the studies of the paper and beyond, run from typed
scenarios (:mod:`rmdrake.studies.scenarios`, shipped in ``scenarios.yaml``).

Layering: studies use :mod:`rmdrake.pipelines`, :mod:`rmdrake.systems` (Drake
diagrams) and the core numerics; nothing below imports a study. Each study is a
sequence of steps returning dataclasses, then a writer of its files.
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.pipelines.show": (
            "robot_summary",
            "save_robot_html",
        ),
        "rmdrake.studies.calibration": (
            "CalibrationDraw",
            "CalibrationStudyResult",
            "draw_true_robot",
            "run_calibration_study",
        ),
        "rmdrake.studies.compensation": (
            "CompensationStudyResult",
            "run_static_accuracy_study",
        ),
        "rmdrake.studies.elastic_arm": (
            "ComplianceStudyResult",
            "run_compliance_study",
        ),
        "rmdrake.studies.identification": (
            "IdentificationStudy",
            "perturb_dynamics",
            "run_identification_study",
            "simulate_log",
        ),
        "rmdrake.studies.planning": (
            "PlanConfig",
            "run_plan",
        ),
        "rmdrake.studies.runner": ("run_scenario",),
        "rmdrake.studies.scenarios": (
            "SHIPPED_SCENARIOS",
            "CalibrationStudyConfig",
            "CompensationStudyConfig",
            "ComplianceStudyConfig",
            "ExcitationRunConfig",
            "IdentificationStudyConfig",
            "LoopIdentificationConfig",
            "Scenario",
            "load_scenario",
            "scenario_names",
        ),
    },
)
