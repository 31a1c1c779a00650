"""The calibration config (rmdrake.calibration.config): keyword-only
dataclasses, the method a tagged choice; make_calibrator and
make_point_calibrator build the same estimators from it as from keywords; an
unknown or misplaced method is refused; Drake's YAML reads it."""

from __future__ import annotations

import dataclasses
import re

import pytest
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from rmdrake.calibration.config import (
    CALIBRATION_METHODS,
    CalibrationConfig,
    PlaneLMConfig,
    PointLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
    de_start_budget,
    plate_calibrator_config,
    with_de_options,
)
from rmdrake.calibration.plates.estimators import (
    PlaneLM,
    VolumeDE,
    VolumeDEPlaneLM,
    make_calibrator,
)
from rmdrake.calibration.points.lm import PointLM, make_point_calibrator
from rmdrake.model.loading import load_robot

CONFIGS = (
    CalibrationConfig,
    PlaneLMConfig,
    PointLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
)


@pytest.fixture(scope="module")
def nominal():
    return load_robot("rv3sb")


@pytest.mark.parametrize("kind", CONFIGS, ids=lambda k: k.__name__)
def test_keyword_only_with_defaults(kind):
    kind()  # every field has a default
    if dataclasses.fields(kind):
        with pytest.raises(TypeError):
            kind(0)


def test_defaults():
    config = CalibrationConfig()
    assert config.params is None and config.calibrator is None
    assert (config.loss, config.f_scale, config.noise, config.force) == (
        "linear",
        1e-5,
        None,
        False,
    )
    assert VolumeDEPlaneLMConfig().de == de_start_budget()
    assert de_start_budget() == VolumeDEConfig(
        popsize=10, maxiter=100, max_per_plate=30
    )


def test_plate_calibrator_config_by_name():
    for method in CALIBRATION_METHODS:
        assert plate_calibrator_config(method).method == method
    assert isinstance(plate_calibrator_config("de+lm"), VolumeDEPlaneLMConfig)
    assert PointLMConfig.method == "lm"


def test_an_unknown_method_is_refused(nominal):
    with pytest.raises(ValueError, match="unknown method 'ga': expected one of de,"):
        plate_calibrator_config("ga")
    with pytest.raises(ValueError, match="unknown method 'ga': expected one of de,"):
        make_calibrator("ga", nominal)
    with pytest.raises(TypeError, match="expected a plate method config, found str"):
        make_calibrator(CalibrationConfig(calibrator="ga"), nominal)


def _state(est) -> dict:
    return {k: v for k, v in vars(est).items() if k != "de_options"}


@pytest.mark.parametrize(
    "config, method, options",
    [
        # params None is ``auto`` on the plates' lm and de+lm (``paper`` on de);
        # the estimators' own keyword default stays ``paper``.
        (CalibrationConfig(calibrator=PlaneLMConfig()), "lm", {"params": "auto"}),
        (
            CalibrationConfig(
                params="full",
                loss="huber",
                f_scale=2e-6,
                calibrator=PlaneLMConfig(max_nfev=50),
            ),
            "lm",
            {"params": "full", "loss": "huber", "f_scale": 2e-6, "max_nfev": 50},
        ),
        (CalibrationConfig(calibrator=VolumeDEConfig()), "de", {}),
        (
            CalibrationConfig(
                calibrator=VolumeDEConfig(seed=3, maxiter=7, angle_bound=1e-3)
            ),
            "de",
            {"seed": 3, "maxiter": 7, "angle_bound": 1e-3},
        ),
        (CalibrationConfig(), "de+lm", {"params": "auto"}),
        (
            CalibrationConfig(
                compliance=True,
                loss="cauchy",
                calibrator=VolumeDEPlaneLMConfig(
                    de=dataclasses.replace(de_start_budget(), seed=2, progress=True)
                ),
            ),
            "de+lm",
            {
                "params": "auto",
                "compliance": True,
                "loss": "cauchy",
                "seed": 2,
                "progress": True,
            },
        ),
    ],
)
def test_make_calibrator_builds_from_the_config(nominal, config, method, options):
    """A config gives the estimator the method name and keywords give."""
    from_config = make_calibrator(config, nominal)
    from_keywords = make_calibrator(method, nominal, **options)
    assert type(from_config) is type(from_keywords)
    assert from_config.method == method
    assert _state(from_config) == _state(from_keywords)
    if method == "de+lm":
        de_config = VolumeDE(nominal, **from_config.de_options)
        de_keywords = VolumeDE(nominal, **from_keywords.de_options)
        assert vars(de_config) == vars(de_keywords)


def test_make_calibrator_types(nominal):
    assert isinstance(make_calibrator(CalibrationConfig(), nominal), VolumeDEPlaneLM)
    lm = make_calibrator(CalibrationConfig(calibrator=PlaneLMConfig()), nominal)
    assert isinstance(lm, PlaneLM) and lm.params == "auto"
    assert (lm.folds, lm.seed) == (5, 0)
    de = CalibrationConfig(calibrator=VolumeDEConfig())
    assert isinstance(make_calibrator(de, nominal), VolumeDE)
    assert make_calibrator(de, nominal).params == "paper"  # the DE cannot choose


def test_make_calibrator_refuses_points_and_keywords(nominal):
    points = CalibrationConfig(calibrator=PointLMConfig())
    with pytest.raises(ValueError, match="PointLMConfig calibrates point measure"):
        make_calibrator(points, nominal)
    with pytest.raises(TypeError, match="takes no keyword options, found seed"):
        make_calibrator(CalibrationConfig(), nominal, seed=1)


def test_make_point_calibrator(nominal):
    est = make_point_calibrator(CalibrationConfig(), nominal)
    reference = PointLM(nominal, params="auto", f_scale=1e-5)
    assert isinstance(est, PointLM) and vars(est) == vars(reference)
    config = CalibrationConfig(
        params="offsets",
        compliance=True,
        loss="huber",
        rtol=1e-7,
        calibrator=PointLMConfig(seed=4, selection_folds=3, repeats=2, folds=6),
    )
    est = make_point_calibrator(config, nominal)
    reference = PointLM(
        nominal,
        params="offsets",
        compliance=True,
        loss="huber",
        f_scale=1e-5,
        folds=3,
        seed=4,
        repeats=2,
        rtol=1e-7,
    )
    assert vars(est) == vars(reference)


@pytest.mark.parametrize("method", CALIBRATION_METHODS)
def test_make_point_calibrator_refuses_a_plate_method(nominal, method):
    config = CalibrationConfig(calibrator=plate_calibrator_config(method))
    pattern = rf"\(method '{re.escape(method)}'\) calibrates plane"
    with pytest.raises(ValueError, match=pattern):
        make_point_calibrator(config, nominal)


def test_with_de_options():
    assert with_de_options(PlaneLMConfig(), seed=3) == PlaneLMConfig()
    assert with_de_options(PointLMConfig(), seed=3) == PointLMConfig()
    assert with_de_options(VolumeDEConfig(), seed=3) == VolumeDEConfig(seed=3)
    both = with_de_options(VolumeDEPlaneLMConfig(), maxiter=5)
    assert both.de == dataclasses.replace(de_start_budget(), maxiter=5)
    for calibrator in (PlaneLMConfig(), VolumeDEConfig(), VolumeDEPlaneLMConfig()):
        with pytest.raises(TypeError, match="popsise"):
            with_de_options(calibrator, popsise=5)


def test_de_start_budget_is_the_estimators_default(nominal):
    budget = dataclasses.asdict(de_start_budget())
    assert VolumeDEPlaneLM(nominal).de_options.items() <= budget.items()


def test_yaml_reads_the_tagged_method():
    text = "params: full\nnoise: 2.0e-6\ncalibrator: !VolumeDEConfig {maxiter: 5}\n"
    config = yaml_load_typed(schema=CalibrationConfig, data=text)
    assert config == CalibrationConfig(
        params="full", noise=2e-6, calibrator=VolumeDEConfig(maxiter=5)
    )
    untagged = yaml_load_typed(
        schema=CalibrationConfig, data="calibrator: {de: {maxiter: 9}}"
    )
    assert untagged.calibrator == VolumeDEPlaneLMConfig(
        de=dataclasses.replace(de_start_budget(), maxiter=9)
    )
    points = yaml_load_typed(
        schema=CalibrationConfig, data="calibrator: !PointLMConfig {folds: 4}"
    )
    assert points.calibrator == PointLMConfig(folds=4)
    assert yaml_load_typed(schema=CalibrationConfig, data="{}") == CalibrationConfig()
    for each in (config, untagged, points, CalibrationConfig()):
        again = yaml_load_typed(schema=CalibrationConfig, data=yaml_dump_typed(each))
        assert again == each
    with pytest.raises(RuntimeError, match="'GaConfig' did not match"):
        yaml_load_typed(schema=CalibrationConfig, data="calibrator: !GaConfig {}")
    with pytest.raises(RuntimeError, match="popsise"):
        yaml_load_typed(
            schema=CalibrationConfig, data="calibrator: !VolumeDEConfig {popsise: 3}"
        )
