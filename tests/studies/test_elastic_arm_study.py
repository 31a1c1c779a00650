"""The elastic-arm study on its smoke scenario: the elastostatic calibration
with compensation removes the load-dependent error a rigid calibration leaves,
and the Drake station reproduces the static prediction."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.model.loading import load_robot
from rmdrake.studies.elastic_arm import run_compliance_study, steps
from rmdrake.studies.elastic_arm.steps import (
    payload_readings,
    readings_step,
    true_elastic_arm,
)
from rmdrake.studies.scenarios import load_scenario


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    scenario = load_scenario(name="demo_rh_compliance_smoke")
    out = tmp_path_factory.mktemp("compliance")
    lines: list[str] = []
    result = run_compliance_study(
        load_robot(scenario.robot), scenario.compliance, out, echo=lines.append
    )
    return result, scenario.compliance, out, lines


def test_compensation_removes_the_load_error(study):
    result, config, _, _ = study
    for mass in config.test_payloads:
        nominal = result.mean("nominal", mass)
        assert nominal > 0.015  # m: tens of mm, as the paper says
        assert result.mean("elastostatic", mass) < 0.1 * nominal
        assert result.mean("rigid", mass) > 0.5 * nominal  # rigid leaves it
        assert result.mean("oracle", mass) < 1e-6
    # The unseen 2.25 t is compensated as well as the calibrated loads.
    seen = [result.mean("elastostatic", m) for m in (0.0, 4500.0)]
    assert result.mean("elastostatic", 2250.0) < 1.5 * max(seen)


def test_gravity_loaded_stiffness_identified(study):
    result, _, _, _ = study
    error = result.stiffness_identified / result.stiffness - 1
    assert np.all(np.abs(error[[1, 2]]) < 0.02)  # joints 2 and 3 within 2 %
    assert np.isnan(result.stiffness_identified[0])  # joint 1: vertical axis


def test_station_agrees_with_the_static_model(study):
    result, _, _, _ = study
    assert set(result.diagram) == {"nominal", "rigid", "elastostatic", "oracle"}
    assert result.diagram_gap < 2e-4  # m, after the smoke's short hold
    assert result.mode > 4 * result.bandwidth * 0.99
    path = result.path["elastostatic"]
    assert path.final_error < 0.1 * result.path["nominal"].final_error
    assert np.isfinite(path.settling_time) and path.oscillation < 1e-3
    # A module picked up mid-task: the controller told of it holds the target,
    # one left at payload 0 sags by the deflection.
    pickup = result.pickup
    assert pickup.told < 0.2 * pickup.untold and pickup.untold > 0.02


def test_files(study):
    result, _, out, lines = study
    names = {f.name for f in result.files}
    assert names == {
        "payload_errors.png",
        "deflection_field.png",
        "compliance.html",
        "results.yaml",
    }
    summary = yaml.safe_load((out / "results.yaml").read_text())
    assert summary["static_mean_mm"]["elastostatic"][4500.0] < 5.0
    assert any("stiffness true" in line for line in lines)


def test_rigid_robot_refused(tmp_path):
    config = load_scenario(name="demo_rh_compliance_smoke").compliance
    with pytest.raises(ValueError, match="needs a robot with compliance"):
        run_compliance_study(load_robot("demo_rh"), config, tmp_path)
    assert not any(tmp_path.iterdir())


class _RecordingRunner:
    """What :func:`readings_step` asks of its runner; the calls are not run,
    each payload's campaign returns ``part``."""

    parallel = False

    def __init__(self, part):
        self.asked, self.part = [], part

    def start_cluster(self) -> bool:
        self.asked.append("start_cluster")
        return False

    def run_calls(self, calls, **kwargs):
        self.asked.append(f"run_calls {len(calls)}")
        return [self.part] * len(calls)


def test_each_payloads_readings_integrate_their_moves_as_configured(monkeypatch):
    """``readings_integration_schemes`` gives each calibration payload's
    campaign its own move scheme (the holds keep the station's hold scheme);
    without it every campaign keeps the station's."""
    config = load_scenario(name="demo_rh_compliance_smoke").compliance
    robot = load_robot("demo_rh_elastic")
    truth = true_elastic_arm(robot, config)
    seen: list[tuple[str, str]] = []

    class _Run:
        data = PlaneMeasurements(np.zeros(1, int), np.zeros((1, 6)), np.ones(1))

    def record(station, **kwargs):
        seen.append(
            (station.simulator.integration_scheme, station.hold_integration_scheme)
        )
        return _Run()

    monkeypatch.setattr(steps, "measure_plates_in_diagram", record)
    for schemes, moves in (
        (["radau3", "runge_kutta3"], ["radau3", "runge_kutta3"]),
        ([], ["runge_kutta3", "runge_kutta3"]),
    ):
        seen.clear()
        c = dataclasses.replace(
            config, readings_in_diagram=True, readings_integration_schemes=schemes
        )
        for k in range(len(c.calibration_payloads)):
            payload_readings(robot, truth, c, k, progress=False)
        assert seen == [(m, "radau3") for m in moves], schemes
    assert config.station.simulator.integration_scheme == "runge_kutta3"


def test_payload_campaigns_in_the_station_start_the_cluster_at_once():
    """Two payloads' campaigns in the station take minutes each: the default
    execution's cluster starts before them, not after timing the first."""
    config = load_scenario(name="demo_rh_compliance_smoke").compliance
    robot = load_robot("demo_rh_elastic")
    truth = true_elastic_arm(robot, config)
    part = PlaneMeasurements(np.zeros(2, int), np.zeros((2, 6)), np.ones(2))
    for in_diagram, asked in (
        (True, ["start_cluster", "run_calls 2"]),
        (False, []),  # static readings: milliseconds, in this process
    ):
        runner = _RecordingRunner(part)
        c = dataclasses.replace(config, readings_in_diagram=in_diagram)
        if in_diagram:
            readings = readings_step(robot, truth, c, runner=runner)
            np.testing.assert_array_equal(
                readings.data.payload, np.repeat(c.calibration_payloads, 2)
            )
        else:
            readings_step(robot, truth, c, runner=runner)
        assert runner.asked == asked, in_diagram


def test_each_variant_runs_the_controller_its_record_names():
    """The variants' records decide the station controllers: the compensating
    ones pre-deflect at the payload with their own model, the nominal one
    knows no calibrated model, and a record naming no model is refused."""
    from rmdrake.studies.elastic_arm.variants import (
        ELASTOSTATIC,
        NOMINAL,
        ORACLE,
        RIGID,
        VARIANTS,
        ElasticModels,
        Variant,
    )
    from rmdrake.systems.station_config import (
        CompensationControllerConfig,
        InverseDynamicsControllerConfig,
    )

    robot = load_robot("demo_rh_elastic")
    models = ElasticModels(
        nominal=dataclasses.replace(robot, name="n", compliance=None),
        rigid=dataclasses.replace(robot, name="r", compliance=None),
        elastic=dataclasses.replace(robot, name="e"),
        true=dataclasses.replace(robot, name="t"),
    )
    assert [v.name for v in VARIANTS] == ["nominal", "rigid", "elastostatic", "oracle"]
    for variant, model in ((ELASTOSTATIC, models.elastic), (ORACLE, models.true)):
        for build in (variant.target_controller, variant.move_controller):
            controller, calibrated = build(models, 2.0, 4500.0)
            assert isinstance(controller, CompensationControllerConfig)
            assert controller.deflection_compensation
            assert controller.payload_mass == 4500.0 and calibrated is model
    for variant in (NOMINAL, RIGID):  # their static targets are corrected already
        controller, calibrated = variant.target_controller(models, 2.0, 4500.0)
        assert type(controller) is InverseDynamicsControllerConfig
        assert calibrated is None
    controller, calibrated = RIGID.move_controller(models, 2.0, 4500.0)
    assert not controller.deflection_compensation and calibrated is models.rigid
    assert NOMINAL.move_controller(models, 2.0, 4500.0)[1] is None
    q = np.zeros((2, robot.n_joints))
    assert RIGID.motor_commands(models, q, 4500.0) is q  # a rigid model
    assert np.abs(ORACLE.motor_commands(models, q, 4500.0) - q).max() > 1e-4
    with pytest.raises(ValueError, match="model expected one of"):
        Variant("typo", "typo", "calibrated", True, True)
