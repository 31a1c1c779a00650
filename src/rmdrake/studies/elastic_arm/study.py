"""The compliance study's driver, :func:`run_compliance_study`: its steps
(:mod:`~rmdrake.studies.elastic_arm.steps`) in order, the station runs of
steps 4-6 together as tasks, then the report
(:mod:`~rmdrake.studies.elastic_arm.report`)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.execution import SERIAL, Execution, TaskRunner
from rmdrake.model.robot import RobotModel
from rmdrake.studies.elastic_arm.pickup import PICKUP_SOURCES
from rmdrake.studies.elastic_arm.report import mm, write_compliance_files
from rmdrake.studies.elastic_arm.results import ComplianceStudyResult
from rmdrake.studies.elastic_arm.steps import (
    calibration_step,
    insertion_calls,
    insertion_runs,
    pickup_calls,
    pickup_result,
    readings_step,
    static_step,
    station_accuracy,
    station_calls,
    study_models,
    true_elastic_arm,
)
from rmdrake.studies.elastic_arm.variants import VARIANTS
from rmdrake.studies.scenarios import ComplianceStudyConfig

__all__ = ["run_compliance_study"]


def run_compliance_study(
    robot: RobotModel,
    config: ComplianceStudyConfig,
    out_dir: str | os.PathLike,
    *,
    echo: Callable[[str], None] = print,
    execution: Execution | TaskRunner = SERIAL,
) -> ComplianceStudyResult:
    """Runs the study (module docstring) on ``robot`` (elastic, with a payload
    entry), prints its tables and writes its files into ``out_dir``.

    The steps (:mod:`~rmdrake.studies.elastic_arm.steps`):
    :func:`true_elastic_arm`, :func:`readings_step`, :func:`calibration_step`,
    :func:`static_step`, then the station runs of :func:`station_calls`,
    :func:`insertion_calls` and :func:`pickup_calls` together, gathered by
    :func:`station_accuracy`, :func:`insertion_runs` and
    :func:`pickup_result`; then :func:`write_compliance_files`. The readings
    of each payload and the station runs are tasks of ``execution`` (default:
    in this process), the result the same wherever they run.

    Example::

        scenario = load_scenario(name="demo_rh_compliance_smoke")
        result = run_compliance_study(
            load_robot(scenario.robot), scenario.compliance, "out/compliance"
        )
        result.mean("elastostatic", 4500.0)  # m, static tool error

    Raises:
      ValueError: a rigid robot or one without a payload, bad configuration
        values, and what the station and the calibration refuse.

    Example:

    >>> from rmdrake.studies import load_scenario
    >>> scenario = load_scenario(name="demo_rh_compliance_smoke")
    >>> type(scenario.compliance).__name__
    'ComplianceStudyConfig'

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake import load_robot
        from rmdrake.studies import run_compliance_study
        robot = load_robot(scenario.robot)
        result = run_compliance_study(robot, scenario.compliance, "out")
    """
    out = Path(out_dir)
    truth = true_elastic_arm(robot, config)
    out.mkdir(parents=True, exist_ok=True)
    echo(
        f"true robot: {mm(config.mean_error)} mm mean geometric error; stiffness "
        f"{np.array2string(truth.true.compliance.stiffness, precision=3)} N m/rad; "
        f"lowest structural mode {truth.mode:.1f} rad/s "
        f"({truth.mode / 2 / np.pi:.2f} Hz) with {truth.heaviest:g} kg, "
        f"controllers' bandwidth {truth.bandwidth:.2f} rad/s"
    )
    payloads = len(config.calibration_payloads) if config.readings_in_diagram else 0
    driven = len(VARIANTS) if min(config.diagram_targets, config.n_targets) > 0 else 0
    moves = len(VARIANTS) + len(PICKUP_SOURCES) if config.path_length > 0 else 0
    with TaskRunner(execution, tasks=payloads + driven + moves, echo=echo) as runner:
        readings = readings_step(robot, truth, config, runner=runner)
        echo(
            f"readings: {readings.data.n_readings} with payloads "
            f"{config.calibration_payloads} kg "
            f"({'in the Drake station' if config.readings_in_diagram else 'static'}"
            f"; {readings.wall_time:.0f} s)"
        )
        calibration = calibration_step(truth, readings, config)
        models = study_models(truth, calibration)
        static = static_step(truth, models, config)
        calls: dict[tuple[str, str], Callable[[], Any]] = {}
        for step, step_calls in (
            ("station", station_calls(truth, models, static, config)),
            ("insertion", insertion_calls(truth, models, static, config)),
            ("pickup", pickup_calls(truth, models, static, config)),
        ):
            calls.update({(step, k): call for k, call in step_calls.items()})
        done = runner.run_calls(list(calls.values()), desc="station runs")
    outputs = dict(zip(calls, done, strict=True))

    def of(step: str) -> dict[str, Any]:
        return {k: v for (s, k), v in outputs.items() if s == step}

    station = station_accuracy(truth, static, config, of("station"))
    insertion = insertion_runs(truth, static, config, of("insertion"))
    pickup = pickup_result(static, config, of("pickup"))
    result = ComplianceStudyResult(
        true=truth.true,
        rigid=calibration.rigid,
        elastic=calibration.elastic,
        readings=readings.data.n_readings,
        stiffness=calibration.stiffness,
        stiffness_identified=calibration.stiffness_identified,
        static=static.errors,
        deflection=static.deflection,
        diagram=station.errors,
        diagram_gap=station.gap,
        mode=truth.mode,
        bandwidth=truth.bandwidth,
        path={} if insertion is None else insertion.results,
        pickup=pickup,
    )
    result.files = write_compliance_files(
        out,
        config,
        result,
        calibration=calibration,
        static=static,
        insertion=insertion,
        echo=echo,
    )
    return result
