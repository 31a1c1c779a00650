"""Scenarios: what a study runs, as typed dataclasses read from YAML.

A scenario file is a YAML mapping from scenario names to :class:`Scenario`
mappings (the shipped ones are in ``scenarios.yaml`` beside this module:
``paper``, ``paper_smoke``, ``demo_rh``, ``paper_closed_loop``, ...). Every field
has a default, so a scenario names only what differs; a key that is not a field
is refused with its dotted path and the closest field name. The file is read
with Drake's :func:`pydrake.common.yaml.yaml_load_typed`, so tagged choices
(``!Tag``) and Drake's own config types (``SimulatorConfig``) load as in
Drake's ``hardware_sim``.

Copy a scenario, change the robot, the noise, the plate count or the budgets,
and run it with ``rmdrake run --scenario-file F --scenario NAME --out DIR``. A
robot that is not a shipped name is a path to a robot YAML, relative to the
scenario file's folder.

Units: SI (m, rad, s, N m); noise levels are standard deviations.

This module does not use ``from __future__ import annotations``: Drake's loader
reads the field types at run time.
"""

import dataclasses
import difflib
import math
import os
import typing
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import GetIntegrationSchemes

from rmdrake.calibration.config import CALIBRATION_METHODS
from rmdrake.dynamics.estimators import IDENTIFICATION_METHODS
from rmdrake.io.yaml import BoundedSafeLoader, read_yaml
from rmdrake.systems.measurement_runs import measurement_config
from rmdrake.systems.station_config import StationConfig

__all__ = [
    "CalibrationStudyConfig",
    "CompensationStudyConfig",
    "ComplianceStudyConfig",
    "ExcitationRunConfig",
    "IdentificationStudyConfig",
    "PlateDrawConfig",
    "LoopIdentificationConfig",
    "SHIPPED_SCENARIOS",
    "VALUE_RULES",
    "check_scenario",
    "drawn_parameters",
    "Scenario",
    "TrackingStudyConfig",
    "load_scenario",
    "scenario_names",
    "stream",
]

SHIPPED_SCENARIOS = Path(str(resources.files("rmdrake.studies") / "scenarios.yaml"))
"""The scenario file shipped with rmdrake."""


def stream(seed: int, k: int) -> int:
    """An independent seed, stream k of the scenario seed."""
    return int(np.random.SeedSequence([seed, k]).generate_state(1)[0])


def drawn_parameters(params: str) -> str:
    """The parameters a study draws its true robot's errors on, for a
    section's ``params``: ``full`` for ``auto`` (a real arm's errors are not
    limited to what the readings see; the calibration then chooses from the
    readings, as the CLI's ``calibrate --params auto``), else ``params``.

    Example:

    >>> from rmdrake.studies.scenarios import drawn_parameters
    >>> drawn_parameters("auto"), drawn_parameters("paper")
    ('full', 'paper')
    """
    return "full" if params.strip() == "auto" else params


@dataclasses.dataclass
class PlateDrawConfig:
    """What every study that draws a true robot and reads plates shares: the
    true robot's kinematic errors and the plate readings taken of it. The
    calibration, compensation and compliance studies derive from it, each with
    its own defaults, and a scenario gives these fields flat in their
    sections.

    Attributes:
      params: error parameters perturbed and calibrated: ``paper`` (the 17 of
        Table 1), ``full`` (the identifiable subset is chosen), ``auto`` (the
        CLI's default: the errors drawn on every parameter, as ``full``, and
        the calibrated set chosen from the readings by cross-validation over
        the plates; methods ``lm`` and ``de+lm``) or a comma-separated list
        of names.
      mean_error: mean tool-point error of the nominal model on the held-out
        poses, m (the drawn errors are scaled to it).
      plates: plate locations (per payload, in the compliance study).
      per_plate: readings per plate.
      noise: range-finder noise, m.
      n_validation: held-out poses of the calibrated model's kinematic error.
    """

    params: str = "paper"
    mean_error: float = 1.6e-3
    plates: int = 5
    per_plate: int = 12
    noise: float = 2e-6
    n_validation: int = 1000


@dataclasses.dataclass
class CalibrationStudyConfig(PlateDrawConfig):
    """The kinematic-calibration study (paper §2 and §4, Table 1, Fig. 3).

    One true robot per seed: the nominal table plus errors on ``params`` drawn
    at random and scaled so that the nominal model's mean tool-point error on
    the held-out poses is ``mean_error``; plate readings of the true robot;
    each method calibrates from them; errors are measured on held-out poses.

    Besides those of :class:`PlateDrawConfig`, with its defaults, the attributes
    are:

    Attributes:
      seeds: seeds 0..seeds-1.
      methods: methods run on the first seed (``de``, ``lm``, ``de+lm``).
      repeat_methods: methods run on the other seeds (a subset of ``methods``).
      de_maxiter: DE generations (None: the estimator's default).
      de_popsize: DE population per parameter (None: default).
      max_per_plate: readings per plate used in the volume cost (None: all).
      html: write the Meshcat scene of the plates and points.

    Example:

    >>> from rmdrake.studies import CalibrationStudyConfig
    >>> config = CalibrationStudyConfig(seeds=2, plates=4, methods=["lm"])
    >>> config.seeds, config.methods, config.per_plate
    (2, ['lm'], 12)
    """

    seeds: int = 20
    methods: list[str] = dataclasses.field(
        default_factory=lambda: list(CALIBRATION_METHODS)
    )
    repeat_methods: list[str] = dataclasses.field(
        default_factory=lambda: ["lm", "de+lm"]
    )
    de_maxiter: int | None = None
    de_popsize: int | None = None
    max_per_plate: int | None = None
    html: bool = True


@dataclasses.dataclass
class ExcitationRunConfig:
    """What both identification steps share: an excitation designed by DE on
    the nominal model runs on the true robot in the Drake station, logged with
    torque noise and encoder quantisation; qdd is estimated from the logged qd.

    :class:`IdentificationStudyConfig` and :class:`LoopIdentificationConfig`
    derive from it, each with its own defaults, and a scenario gives these
    fields flat in their sections. The defaults here are the paper study's.

    Attributes:
      noise: torque-sensor noise std, as a fraction of each joint's peak torque
        (which peak: see the deriving config).
      encoder_resolution: encoder quantum, rad (m for a prismatic joint) per
        count; default 20 bit per turn, 0 = none.
      derivative_cutoff: low-pass inside the differentiation of qd, Hz.
      periods: excitation periods logged for identification.
      design_time: wall-time budget of the excitation DE, s; None (the
        default): none, the generations (``design_maxiter``) decide and the
        same scenario gives the same bytes on any machine at any load. A
        design this budget stops depends on the machine's load: it warns on
        stderr, naming the budget, and ``excitation.yaml`` says so.
      design_maxiter: generations of the excitation DE.
      design_popsize: its population per parameter.
      n_random: random feasible trajectories the design is compared with.
      design_seed: the DE is seeded by :func:`stream` 4 of it. The design
        depends on the nominal model only: a closed-loop study designs one
        excitation and runs it on every true robot, as an engineer runs one
        plan on each arm of a fleet (the sensors' noise is each robot's own),
        and a scenario's identification study and closed loop with the same
        seed and budget share it.

    Example:

    >>> from rmdrake.studies import ExcitationRunConfig
    >>> config = ExcitationRunConfig(design_maxiter=50, periods=2.0)
    >>> config.design_maxiter, config.periods
    (50, 2.0)
    """

    noise: float = 0.01
    encoder_resolution: float = 5.992112452678286e-06
    derivative_cutoff: float = 30.0
    periods: float = 3.0
    design_time: float | None = None
    design_maxiter: int = 600
    design_popsize: int = 5
    n_random: int = 50
    design_seed: int = 0


@dataclasses.dataclass
class IdentificationStudyConfig(ExcitationRunConfig):
    """The dynamic-identification study (paper §3.2 and §4, Fig. 4, 6, 7).

    A true robot (nominal inertial parameters perturbed 10-30 % per link) runs
    the excitation designed by DE in the Drake station; every method identifies
    the base parameters; a different trajectory validates them.

    Besides those of :class:`ExcitationRunConfig` (with its defaults; ``noise`` is
    relative to each joint's peak torque in the noise-free run of the excitation
    on the true robot), the attributes are:

    Attributes:
      seed: seeds the true robot and the noise.
      de_maxiter: most generations of the paper's DE identification (it stops
        earlier when its population's costs agree to 1e-12).
      methods: estimators run (``ols``, ``wls``, ``de``, ``physical``).
      html: write the Meshcat scene of the robot following the excitation.
      station: the Drake station (simulator, logging, sensors, controller).

    Example:

    >>> from rmdrake.studies import ExcitationRunConfig, IdentificationStudyConfig
    >>> config = IdentificationStudyConfig(design_maxiter=50)
    >>> isinstance(config, ExcitationRunConfig), config.design_maxiter
    (True, 50)
    """

    seed: int = 0
    de_maxiter: int = 3000
    methods: list[str] = dataclasses.field(
        default_factory=lambda: list(IDENTIFICATION_METHODS)
    )
    html: bool = True
    station: StationConfig = dataclasses.field(default_factory=StationConfig)


@dataclasses.dataclass
class LoopIdentificationConfig(ExcitationRunConfig):
    """The identification step of the closed-loop study: an excitation designed
    by DE on the nominal model runs on the true robot in the study's station;
    OLS (then projected to physically consistent standard parameters) and
    physically consistent least squares identify it, with the station's
    Coulomb law.

    The fields are those of :class:`ExcitationRunConfig`, with a smaller log
    and DE budget by default; ``noise`` is relative to each joint's peak
    torque of the nominal model along the designed excitation.

    Example:

    >>> from rmdrake.studies import LoopIdentificationConfig
    >>> config = LoopIdentificationConfig()
    >>> config.periods, config.design_maxiter
    (2.0, 120)
    """

    periods: float = 2.0
    design_maxiter: int = 120  # no wall-time budget: 120 generations, about 8 s
    design_popsize: int = 5
    n_random: int = 10


@dataclasses.dataclass
class TrackingStudyConfig:
    """The path-tracking part of the closed-loop study: each path, planned on
    the nominal model with the tool orientation of ``cube_q``, runs once at
    each speed and feedback bandwidth under every controller variant.

    Attributes:
      seeds: run it on the first ``seeds`` true robots (0 = skip).
      paths: ``circle`` (diameter ``size``) and/or ``rectangle`` (``size``
        by 0.6 ``size``, rounded corners), centred at the cube's centre.
      size: m.
      normal: the path plane's normal in B (normalised; the plane's x axis is
        base y x normal).
      speeds: fractions of the joint velocity and acceleration limits, one
        run each (the duration is the shortest that keeps them).
      bandwidths: feedback bandwidths of the controllers, rad/s (a stiff and a
        soft one).
      html: write the Meshcat scene of the fastest soft-gain run.
    """

    seeds: int = 1
    paths: list[str] = dataclasses.field(
        default_factory=lambda: ["circle", "rectangle"]
    )
    size: float = 0.2
    normal: list[float] = dataclasses.field(default_factory=lambda: [1.0, 0.0, 1.0])
    speeds: list[float] = dataclasses.field(default_factory=lambda: [0.2, 0.5, 0.9])
    bandwidths: list[float] = dataclasses.field(default_factory=lambda: [40.0, 10.0])
    html: bool = True


@dataclasses.dataclass
class CompensationStudyConfig(PlateDrawConfig):
    """The closed-loop compensation study: static pose accuracy in the manner
    of ISO 9283, with the true robot driven in the Drake station.

    Per seed, a true robot (the kinematic errors of the calibration study on
    ``params``, sized to ``mean_error``, and dynamics perturbed 10-30 % per
    link) is calibrated by LM from plate readings taken in the diagram; then
    the station's controller (on the nominal dynamic model) drives it to the
    joint targets of three variants: the nominal IK of the tool targets, the
    targets corrected on the calibrated model, and on the true one (oracle);
    a tool tracker reads the attained tool position at the end of each hold.

    Targets: the five ISO 9283 points of a cube centred at the nominal tool
    position at ``cube_q``, edges along the base axes, the tool orientation
    fixed at the nominal one at ``cube_q``; each point visited ``cycles``
    times, the cycles in seeded orders that change the previous point; then
    ``n_targets`` held-out targets: the nominal tool poses of joint
    configurations uniform in the joint ranges less ``target_margin`` of each
    range at both ends, kept when the smallest singular value of the 6 x n
    tool Jacobian (linear rows m/rad, angular rows rad/rad) is at least
    ``min_singular``.

    Besides those of :class:`PlateDrawConfig`, with its defaults, the attributes
    are:

    Attributes:
      seeds: seeds 0..seeds-1, one true robot each.
      calibration_settle_time: hold before each plate reading, s (the
        readings are taken at the encoder angles: the settle error does not
        bias them).
      cube_q: joint angles (rad, n) whose nominal tool pose gives the cube's
        centre and the fixed tool orientation.
      cube_side: cube edge, m.
      cycles: visits of each cube point (>= 2).
      n_targets: held-out targets.
      target_margin: fraction of each joint range left out at both ends.
      min_singular: smallest singular value of the tool Jacobian kept.
      settle_time: hold before each tool reading, s.
      speed: fraction of the joint velocity and acceleration limits of the
        moves.
      station: the Drake station (default: the measurement runs' config,
        Coulomb smoothing 0.05 rad/s).
      target_mean_error: the goal for the corrected variant's held-out mean
        error, m (RV-3SB 0.03 mm; a DEMO-class arm 0.5 mm).
      identification: the identification step.
      tracking: the path-tracking runs.

    Example:

    >>> from rmdrake.studies import CompensationStudyConfig
    >>> config = CompensationStudyConfig(seeds=1, cube_side=0.1)
    >>> config.seeds, config.cube_side
    (1, 0.1)
    """

    seeds: int = 3
    calibration_settle_time: float = 0.5
    cube_q: list[float] = dataclasses.field(
        default_factory=lambda: [0.0, 0.6, 1.0, 0.0, 1.0, 0.0]
    )
    cube_side: float = 0.2
    cycles: int = 5
    n_targets: int = 100
    target_margin: float = 0.15
    min_singular: float = 0.05
    settle_time: float = 2.0
    speed: float = 0.5
    station: StationConfig = dataclasses.field(default_factory=measurement_config)
    target_mean_error: float = 0.03e-3
    identification: LoopIdentificationConfig = dataclasses.field(
        default_factory=LoopIdentificationConfig
    )
    tracking: TrackingStudyConfig = dataclasses.field(
        default_factory=TrackingStudyConfig
    )


@dataclasses.dataclass
class ComplianceStudyConfig(PlateDrawConfig):
    """The elastostatic study of a heavy arm with elastic joints (the robot's
    ``compliance``; its stiffness is the truth's nominal value).

    A true robot gets the calibration study's kinematic errors on ``params``
    (sized to ``mean_error``) and joint stiffness off the robot's by a factor
    1 + ``stiffness_spread`` N(0, 1) (seeded). Plate readings are taken in the
    Drake station (``readings_in_diagram``) or from the static model, once per
    payload in ``calibration_payloads`` (all plates each time). Two models are
    calibrated by LM on them: the paper's rigid one (``params``) and the
    elastostatic one (``params`` and the joint compliances). Then static tool
    accuracy at ``test_payloads`` on ``n_targets`` held-out poses (as the
    compensation study's) for the nominal controller, the rigid calibration,
    the elastostatic calibration with deflection compensation and the oracle;
    the first ``diagram_targets`` targets are also driven in the station at
    the largest payload. Last, an insertion-like straight move of
    ``path_length`` along the tool's approach axis at ``path_speed`` of the
    joint limits, then a hold of ``path_hold``, with the largest payload.

    Besides those of :class:`PlateDrawConfig`, whose defaults it changes:
    ``mean_error`` 10 mm, ``plates`` 6, ``noise`` 10 um, ``n_validation`` 500, the
    attributes are:

    Attributes:
      seed: seeds the true robot, plates, noise and targets.
      stiffness_spread: relative std of the true stiffness about the robot's.
      calibration_payloads: payload masses of the readings, kg.
      test_payloads: payload masses of the accuracy test, kg.
      n_targets: held-out targets of the static accuracy test.
      target_margin, min_singular: as the compensation study's.
      readings_in_diagram: take the plate readings in the Drake station (else
        from the static deflection model, which the station reproduces).
      readings_integration_schemes: Drake's integration scheme of the moves
        between the readings in the station, one per entry of
        ``calibration_payloads``; empty (the default): ``station.simulator``'s
        for all. An elastic arm's moves are stiff where its links are light
        (an explicit scheme's step is bounded by the stiffest rotor-link
        mode) and smooth where a heavy payload slows those modes, so an
        implicit scheme (``radau3``) suits the unloaded moves and an explicit
        one (``runge_kutta3``) the heavily loaded ones.
      diagram_targets: targets driven in the station per variant (0 = none).
      settle_time: hold before each reading or target, s.
      speed: fraction of the joint limits of the moves.
      bandwidth: feedback bandwidth of every controller, rad/s; 0 = a quarter
        of the nominal robot's lowest structural mode with the largest payload
        at its home position.
      path_length: m; path_speed: fraction of the joint limits; path_hold: s.
      settle_band: tool band of the path's settling time, m.
      station: the Drake station (its controller bandwidth is replaced).

    Example:

    >>> from rmdrake.studies import ComplianceStudyConfig
    >>> config = ComplianceStudyConfig(calibration_payloads=[0.0, 5.0], n_targets=10)
    >>> config.calibration_payloads, config.plates
    ([0.0, 5.0], 6)
    """

    mean_error: float = 1.0e-2
    plates: int = 6
    noise: float = 1.0e-5
    n_validation: int = 500
    seed: int = 0
    stiffness_spread: float = 0.2
    calibration_payloads: list[float] = dataclasses.field(
        default_factory=lambda: [0.0, 4500.0]
    )
    test_payloads: list[float] = dataclasses.field(
        default_factory=lambda: [0.0, 2250.0, 4500.0]
    )
    n_targets: int = 50
    target_margin: float = 0.15
    min_singular: float = 0.05
    readings_in_diagram: bool = True
    readings_integration_schemes: list[str] = dataclasses.field(default_factory=list)
    diagram_targets: int = 5
    settle_time: float = 6.0
    speed: float = 0.5
    bandwidth: float = 0.0
    path_length: float = 0.5
    path_speed: float = 0.3
    path_hold: float = 10.0
    settle_band: float = 1.0e-5
    station: StationConfig = dataclasses.field(default_factory=measurement_config)


@dataclasses.dataclass
class Scenario:
    """A whole study: the robot and the sections to run (None = skipped).

    Attributes:
      robot: shipped robot name or robot YAML (relative to the scenario file).
      description: one line shown when the scenario runs.
      show: write the robot's Meshcat scene.
      calibration: the kinematic-calibration study.
      identification: the dynamic-identification study.
      compensation: the closed-loop compensation study (static accuracy);
        skipped unless given.
      compliance: the elastostatic study of an elastic arm; skipped unless
        given.

    Example:

    >>> from rmdrake.studies import CalibrationStudyConfig, Scenario
    >>> scenario = Scenario(robot="rv3sb", calibration=CalibrationStudyConfig(seeds=2),
    ...                 identification=None, compensation=None)
    ...
    >>> scenario.calibration.seeds, scenario.identification
    (2, None)
    """

    robot: str = "rv3sb"
    description: str = ""
    show: bool = True
    calibration: CalibrationStudyConfig | None = dataclasses.field(
        default_factory=CalibrationStudyConfig
    )
    identification: IdentificationStudyConfig | None = dataclasses.field(
        default_factory=IdentificationStudyConfig
    )
    compensation: CompensationStudyConfig | None = None
    compliance: ComplianceStudyConfig | None = None


class _TagTolerantLoader(BoundedSafeLoader):
    """The bounded safe loader (:mod:`rmdrake.io.yaml`) reading ``!Tag``
    mappings as plain mappings (the typed load that follows interprets them)."""


def _untagged(loader: yaml.SafeLoader, suffix: str, node: yaml.Node) -> Any:
    if isinstance(node, yaml.MappingNode):
        return loader.construct_mapping(node, deep=True)
    if isinstance(node, yaml.SequenceNode):
        return loader.construct_sequence(node, deep=True)
    return loader.construct_scalar(node)


_TagTolerantLoader.add_multi_constructor("!", _untagged)


def _dataclass_of(annotation: Any) -> type | None:
    """The dataclass an annotation names, through Optional (else None)."""
    if dataclasses.is_dataclass(annotation):
        return annotation
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if len(args) == 1 and dataclasses.is_dataclass(args[0]):
        return args[0]
    return None


def _check_keys(schema: type, data: Any, where: str) -> None:
    """Raises ValueError naming the dotted path of the first unknown key, or of
    the first section that is not a mapping (pydrake's typed load asserts on
    one)."""
    if not isinstance(data, dict):
        return
    hints = typing.get_type_hints(schema)
    for key, value in data.items():
        if key not in hints:
            close = difflib.get_close_matches(str(key), list(hints), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            fields = ", ".join(hints)
            raise ValueError(
                f"{where}.{key}: unknown key{hint}; expected one of: {fields}"
            )
        inner = _dataclass_of(hints[key])
        optional = type(None) in typing.get_args(hints[key])
        if (
            inner is not None
            and not isinstance(value, dict)
            and not (value is None and optional)
        ):
            raise ValueError(
                f"{where}.{key}: expected a mapping of {inner.__name__} fields, "
                f"found {type(value).__name__} {str(value)[:40]!r}"
            )
        if inner is not None:
            _check_keys(inner, value, f"{where}.{key}")


def _count(lo: int, hi: int) -> tuple:
    return (lambda v: lo <= v <= hi, f"expected an integer in {lo}..{hi:g}")


def _number(lo: float, hi: float, *, open_lo: bool = False) -> tuple:
    ok = (lambda v: lo < v <= hi) if open_lo else (lambda v: lo <= v <= hi)
    low = f"> {lo:g}" if open_lo else f">= {lo:g}"
    return (
        lambda v: math.isfinite(v) and ok(v),
        f"expected a number {low} and <= {hi:g}",
    )


_FRACTION = _number(0.0, 1.0, open_lo=True)
_SECONDS = _number(0.0, 3600.0)
VALUE_RULES: dict[str, tuple] = {
    # The same rule for a field of that name in every section, unless a
    # section's own entry (Class.field) says otherwise. Bounds are what the
    # physics and a day's run allow: counts that would allocate or run for
    # days are refused with the rest, before any file is written.
    "seeds": _count(1, 10_000),
    "TrackingStudyConfig.seeds": _count(0, 10_000),  # 0: no tracking runs
    "seed": _count(0, 2**32 - 1),
    "design_seed": _count(0, 2**32 - 1),
    "mean_error": _number(0.0, 1.0, open_lo=True),
    "plates": _count(1, 1_000),
    "per_plate": _count(1, 10_000),
    "noise": _number(0.0, 1.0),
    "n_validation": _count(1, 1_000_000),
    "de_maxiter": _count(1, 1_000_000),
    "de_popsize": _count(1, 10_000),
    "max_per_plate": _count(4, 10_000),
    "encoder_resolution": _number(0.0, 0.1),
    "derivative_cutoff": _number(0.0, 1e4, open_lo=True),
    "periods": _number(0.0, 1_000.0, open_lo=True),
    "design_time": _number(0.0, 1e6, open_lo=True),
    "design_maxiter": _count(1, 100_000),
    "design_popsize": _count(1, 1_000),
    "n_random": _count(0, 100_000),
    "size": _number(0.0, 100.0, open_lo=True),
    "speeds": _FRACTION,
    "speed": _FRACTION,
    "path_speed": _FRACTION,
    "bandwidths": _number(0.0, 1e4, open_lo=True),
    "bandwidth": _number(0.0, 1e4),  # 0: a quarter of the lowest mode
    "calibration_settle_time": _SECONDS,
    "settle_time": _number(0.0, 3600.0, open_lo=True),
    "path_hold": _SECONDS,
    "cube_side": _number(0.0, 100.0, open_lo=True),
    "cycles": _count(2, 1_000),
    "n_targets": _count(1, 100_000),
    "target_margin": _number(0.0, 0.49),
    "min_singular": _number(0.0, 1e6),
    "target_mean_error": _number(0.0, 1.0, open_lo=True),
    "stiffness_spread": _number(0.0, 10.0),
    "calibration_payloads": _number(0.0, 1e6),
    "test_payloads": _number(0.0, 1e6),
    "diagram_targets": _count(0, 100_000),
    "path_length": _number(0.0, 100.0),
    "settle_band": _number(0.0, 1.0, open_lo=True),
    "cube_q": _number(-1e3, 1e3),
    "normal": _number(-1e6, 1e6),
}
"""The value rules of :func:`check_scenario`: (predicate, what it expects) per
field name; a list is checked entry by entry."""

_CHOICES = {
    "CalibrationStudyConfig.methods": CALIBRATION_METHODS,
    "CalibrationStudyConfig.repeat_methods": CALIBRATION_METHODS,
    "IdentificationStudyConfig.methods": IDENTIFICATION_METHODS,
    "TrackingStudyConfig.paths": ("circle", "rectangle"),
    "ComplianceStudyConfig.readings_integration_schemes": tuple(
        GetIntegrationSchemes()
    ),
}


def check_scenario(scenario: Scenario, where: str = "scenario") -> None:
    """Checks every value of ``scenario`` against :data:`VALUE_RULES`, the
    known method and path names and the lists a study needs (tracking paths,
    speeds and bandwidths; compliance payloads), so that ``rmdrake run``
    refuses a bad value before its first file instead of when the study
    reaches it.

    Raises:
      ValueError: one line, the dotted field path, what it expects and what it
        found (``where: calibration.plates: expected an integer in 1..1000,
        found 0``).
    """
    _check_values(scenario, where)
    compensation = scenario.compensation
    tracking = compensation.tracking if compensation is not None else None
    if tracking is not None and tracking.seeds > 0:
        for key in ("paths", "speeds", "bandwidths"):
            if not getattr(tracking, key):
                raise ValueError(
                    f"{where}: compensation.tracking.{key}: expected one or more "
                    f"entries (one run each), found []; or `seeds: 0` to skip "
                    "the tracking runs"
                )
        normal = tracking.normal
        if len(normal) != 3 or not any(normal):
            raise ValueError(
                f"{where}: compensation.tracking.normal: expected 3 numbers, not "
                f"all zero (the path plane's normal), found {normal}"
            )
    compliance = scenario.compliance
    if compliance is not None:
        for key in ("calibration_payloads", "test_payloads"):
            if not getattr(compliance, key):
                raise ValueError(
                    f"{where}: compliance.{key}: expected one or more payload "
                    "masses, kg, found []"
                )
        schemes = compliance.readings_integration_schemes
        payloads = len(compliance.calibration_payloads)
        if schemes and len(schemes) != payloads:
            raise ValueError(
                f"{where}.compliance.readings_integration_schemes: expected one "
                f"scheme per calibration payload ({payloads}) or none, found "
                f"{len(schemes)}"
            )


def _check_values(config: Any, where: str) -> None:
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        path = f"{where}.{field.name}"
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            if type(value).__module__ == __name__:  # Drake's configs check theirs
                _check_values(value, path)
            continue
        key = f"{type(config).__name__}.{field.name}"
        if key in _CHOICES:
            bad = [v for v in value if v not in _CHOICES[key]]
            if bad or (not value and field.name == "methods"):
                raise ValueError(
                    f"{path}: expected one or more of {', '.join(_CHOICES[key])}, "
                    f"found {value}"
                )
            continue
        rule = VALUE_RULES.get(key) or VALUE_RULES.get(field.name)
        if rule is None or value is None or isinstance(value, (bool, str)):
            continue
        ok, expected = rule
        for v in value if isinstance(value, list) else [value]:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not ok(v):
                raise ValueError(f"{path}: {expected}, found {v!r}")


def scenario_names(path: str | os.PathLike = SHIPPED_SCENARIOS) -> list[str]:
    """The scenario names a scenario file defines, in file order.

    Example:

    >>> from rmdrake.studies import scenario_names
    >>> "paper" in scenario_names()
    True
    """
    raw = _read_raw(Path(path))
    return list(raw)


def _read_raw(path: Path) -> dict[str, Any]:
    raw = read_yaml(path, "scenario file", _TagTolerantLoader)
    if not isinstance(raw, dict) or not raw:
        raise ValueError(
            f"scenario file {path}: expected a mapping of scenario names to scenarios"
        )
    return raw


def load_scenario(
    path: str | os.PathLike = SHIPPED_SCENARIOS, name: str = "paper"
) -> Scenario:
    """Reads scenario ``name`` from a scenario file.

    A robot given as a relative path is resolved against the file's folder.

    Raises:
      ValueError: an unreadable file, an unknown scenario name (the known ones
        listed), an unknown key (its dotted path), or a value of the wrong type.

    Example:

    >>> from rmdrake.studies import load_scenario
    >>> scenario = load_scenario(name="paper")
    >>> scenario.robot, type(scenario.calibration).__name__
    ('rv3sb', 'CalibrationStudyConfig')
    """
    path = Path(path)
    raw = _read_raw(path)
    if name not in raw:
        known = ", ".join(map(str, raw))
        raise ValueError(f"scenario file {path}: no scenario '{name}' (has: {known})")
    _check_keys(Scenario, raw[name], f"{path.name}: {name}")
    try:
        scenario = yaml_load_typed(
            schema=Scenario, data=path.read_text(encoding="utf-8"), child_name=name
        )
    except (RuntimeError, TypeError, ValueError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"scenario '{name}' in {path}: {first}") from None
    check_scenario(scenario, f"scenario '{name}' in {path}")
    robot = scenario.robot
    if robot.endswith((".yaml", ".yml")) and not Path(robot).is_absolute():
        scenario.robot = str((path.parent / robot).resolve())
    return scenario
