"""The studies' independent pieces as tasks (rmdrake.execution): the same
results in this process and on two local Dask workers. The calibration study
runs whole on a tiny config; the closed-loop and elastic-arm studies take a
minute or more even at smoke size, so their task functions (the station runs:
a variant driven to its targets, a cell of the tracking grid, the insertion
move, a pick-up run, one payload's plate readings) are compared one task each,
in this process against on the workers."""

from __future__ import annotations

import dataclasses
import functools
import pickle
import warnings

import numpy as np
import pytest

from rmdrake.execution import Execution, TaskRunner
from rmdrake.model.loading import load_robot
from rmdrake.studies.calibration import (
    draw_true_robot,
    run_calibration_study,
)
from rmdrake.studies.closed_loop import ClosedLoopModels
from rmdrake.studies.compensation import cube_step, drive_step, targets_step
from rmdrake.studies.elastic_arm.pickup import TOLD, pickup_run
from rmdrake.studies.elastic_arm.station_runs import drive_variant, insertion_path
from rmdrake.studies.elastic_arm.steps import (
    calibration_step,
    payload_readings,
    readings_step,
    static_step,
    study_models,
    true_elastic_arm,
)
from rmdrake.studies.elastic_arm.variants import NOMINAL, ORACLE
from rmdrake.studies.identification import perturb_dynamics
from rmdrake.studies.scenarios import CalibrationStudyConfig, load_scenario, stream
from rmdrake.studies.tracking import track_program


@pytest.fixture(scope="module")
def workers():
    """Two local worker processes, shared by this module's piece tests."""
    with TaskRunner(Execution(workers=2), tasks=2) as runner:
        assert runner.parallel
        yield runner


def _same(a, b) -> None:
    """Equal, bit for bit, through dataclasses, dicts, sequences and arrays;
    wall times (s) aside."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b)
        for f in dataclasses.fields(a):
            if f.name != "wall_time":
                _same(getattr(a, f.name), getattr(b, f.name))
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _same(x, y)
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b or (a != a and b != b)  # NaN equals NaN here


def _in_process_and_on(runner: TaskRunner, calls: list) -> None:
    here = TaskRunner(Execution(workers=0)).run_calls(calls, desc="", progress=False)
    there = runner.run_calls(calls, desc="", progress=False)
    _same(here, there)


def test_calibration_study_is_the_same_on_two_workers(tmp_path):
    config = CalibrationStudyConfig(
        seeds=3,
        plates=4,
        per_plate=8,
        n_validation=50,
        methods=["lm"],
        repeat_methods=["lm"],
        html=False,
    )
    nominal = load_robot("rv3sb")
    results = []
    for workers in (0, 2):
        lines: list[str] = []
        results.append(
            run_calibration_study(
                nominal,
                config,
                tmp_path / str(workers),
                progress=False,
                echo=lines.append,
                execution=Execution(workers=workers),
            )
        )
        assert any("mean before" in line for line in lines)
    serial, parallel = results
    np.testing.assert_array_equal(parallel.mean_before, serial.mean_before)
    np.testing.assert_array_equal(parallel.max_before, serial.max_before)
    np.testing.assert_array_equal(parallel.mean_after["lm"], serial.mean_after["lm"])
    np.testing.assert_array_equal(parallel.max_after["lm"], serial.max_after["lm"])
    assert parallel.mean_after["lm"].shape == (3,)
    # the first seed's fitted estimator came back from its worker, usable
    _same(parallel.estimators["lm"].model_.table, serial.estimators["lm"].model_.table)
    assert parallel.png is not None and parallel.png.is_file()


def test_closed_loop_station_runs_are_the_same_on_the_workers(workers):
    """A variant driven through its targets and a tracking cell (7 variants
    along a circle), from a perfectly known true robot (no loop: the loop is
    a task of the same kind)."""
    config = load_scenario(name="paper_closed_loop_smoke").compensation
    config = dataclasses.replace(config, n_targets=2, settle_time=0.3)
    config.tracking.bandwidths = [10.0]
    config.tracking.size = 0.05  # m: a 1.4 s circle
    assert pickle.loads(pickle.dumps(config)).station.simulator.accuracy == (
        config.station.simulator.accuracy
    )
    nominal = load_robot("rv3sb")
    true = perturb_dynamics(draw_true_robot(nominal, config, 0).true, stream(0, 1))
    models = ClosedLoopModels(nominal, true, true, {"ols": true, "physical": true})
    targets = targets_step(nominal, config, cube_step(nominal, config), models, 0)
    _in_process_and_on(
        workers,
        [
            functools.partial(drive_step, config, models, targets, "full", seed=0),
            functools.partial(track_program, models, config, (0, 0, 0)),
        ],
    )


def test_elastic_station_runs_are_the_same_on_the_workers(workers):
    """One plate reading of a payload in the station (5 s each on the heavy
    arm), a variant driven to a target, the insertion move and a pick-up run,
    on short holds."""
    config = load_scenario(name="demo_rh_compliance_smoke").compliance
    config = dataclasses.replace(config, n_targets=3, path_hold=1.0, settle_time=1.0)
    robot = load_robot("demo_rh_elastic")
    truth = true_elastic_arm(robot, config)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # compliances the readings cannot see
        readings = readings_step(robot, truth, config)
        calibration = calibration_step(truth, readings, config)
    models = study_models(truth, calibration)
    static = static_step(truth, models, config)
    mass, w = truth.heaviest, truth.bandwidth
    sim = truth.draw.simulation
    one = dataclasses.replace(  # the first reading of the first plate
        sim, data=sim.data.subset(np.array([0])), plates=sim.plates[:1]
    )
    one_reading = dataclasses.replace(
        truth, draw=dataclasses.replace(truth.draw, simulation=one)
    )
    in_diagram = dataclasses.replace(config, readings_in_diagram=True)
    _in_process_and_on(
        workers,
        [
            functools.partial(
                payload_readings, robot, one_reading, in_diagram, 1, progress=False
            ),
            functools.partial(
                drive_variant,
                config,
                ORACLE,
                models,
                static.q_link["oracle"][:1],
                mass,
                w,
            ),  # fmt: skip
            functools.partial(
                insertion_path,
                config,
                NOMINAL,
                models,
                static.q_nominal[0],
                static.X_BE[0],
                mass,
                w,
            ),  # fmt: skip
            functools.partial(
                pickup_run,
                config,
                models,
                static.q_link["elastostatic"][0],
                mass,
                w,
                TOLD,
            ),  # fmt: skip
        ],
    )


def test_a_tasks_warnings_are_raised_again_by_the_caller(workers):
    call = functools.partial(warnings.warn, "from a task", UserWarning)
    for runner in (TaskRunner(Execution(workers=0)), workers):
        with pytest.warns(UserWarning, match="from a task"):
            assert runner.run_calls([call], desc="", progress=False) == [None]
