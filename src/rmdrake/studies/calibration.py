"""The kinematic-calibration study (Wang et al. 2016, §4, Table 1, Fig. 3).

One draw (:func:`draw_true_robot`): a "true" robot with errors on the study's
parameters (the 17 of Table 1 in the paper's scenario) drawn at random (lengths
and angles with the same standard deviation in mm and mrad) and scaled so that
the nominal model's mean tool-point error over the held-out poses is the
scenario's ``mean_error`` (1.6 mm in the paper's experiment); plate readings of
the true robot (:func:`simulate_plates`); held-out poses uniform within the
joint limits, never used by the calibration.

:func:`run_calibration_study` calibrates with the paper's method (DE on
volumes), LM and DE+LM, prints the table next to the paper's 1.6 mm -> 0.3 mm,
saves a Fig. 3-style PNG and a Meshcat HTML for the first seed, repeats over
the seeds and prints the median and 95th percentile of the mean tool error
after calibration. Its sizes and budgets come from a
:class:`~rmdrake.studies.scenarios.CalibrationStudyConfig`; each method's
estimator is built from the
:class:`~rmdrake.calibration.config.CalibrationConfig` they give. The studies
that calibrate on the way read theirs with :func:`plate_calibration`.

The study runs as steps, each returning a small frozen dataclass:
:func:`calibration_plan` (:class:`CalibrationPlan`, the checked seeds and
methods), then per seed :func:`calibrate_draw` (:class:`DrawCalibration`: the
draw and each method's :class:`MethodFit`), one task per seed
(:mod:`rmdrake.execution`); :func:`write_calibration_files` prints the table
and writes the files.

"""

from __future__ import annotations

import dataclasses
import functools
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.calibration.config import (
    CALIBRATION_METHODS,
    CalibrationConfig,
    PlaneLMConfig,
    plate_calibrator_config,
    with_de_options,
)
from rmdrake.calibration.parameters import resolve_parameters
from rmdrake.calibration.plates.calibrator import PlaneCalibrator
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.plates.simulate import (
    SimulatedPlates,
    random_poses,
    simulate_plates,
)
from rmdrake.calibration.validation import ValidationResult, tool_point_errors
from rmdrake.execution import SERIAL, Execution, TaskRunner
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.error_parameters import apply_deltas
from rmdrake.model.robot import RobotModel
from rmdrake.report.plots import plot_calibration_errors
from rmdrake.studies.scenarios import (
    CalibrationStudyConfig,
    PlateDrawConfig,
    drawn_parameters,
)
from rmdrake.systems.visualization import save_calibration_html

__all__ = [
    "PAPER_AFTER",
    "PAPER_BEFORE",
    "CalibrationDraw",
    "CalibrationPlan",
    "CalibrationStudyResult",
    "DrawCalibration",
    "MethodFit",
    "calibrate_draw",
    "calibration_plan",
    "draw_true_robot",
    "plate_calibration",
    "run_calibration_study",
    "write_calibration_files",
]

PAPER_BEFORE = 1.6e-3  # m, paper §4: mean position error before calibration
PAPER_AFTER = 0.3e-3  # m, after (experiment)
_LABELS = {
    "de": "paper: DE on volumes",
    "lm": "LM on plane distances",
    "de+lm": "DE + LM",
}


@dataclasses.dataclass(frozen=True)
class CalibrationDraw:
    """One draw of the study: a true robot, its readings, held-out poses.

    Attributes:
      seed: the scenario seed.
      nominal: the nominal robot (what the calibration starts from).
      true: the simulated true robot.
      names: the perturbed (and calibrated) error parameters.
      true_deltas: their true values, rad or m.
      simulation: the plates and readings of the true robot.
      q_validation: (M, n) held-out joint positions, rad or m.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.studies import CalibrationDraw, CalibrationStudyConfig
    >>> from rmdrake.studies import draw_true_robot
    >>> config = CalibrationStudyConfig(plates=4, per_plate=8, n_validation=10)
    >>> draw = draw_true_robot(load_robot("rv3sb"), config, seed=1)
    >>> isinstance(draw, CalibrationDraw), draw.true_deltas.shape
    (True, (17,))
    """

    seed: int
    nominal: RobotModel
    true: RobotModel
    names: list[str]
    true_deltas: np.ndarray
    simulation: SimulatedPlates
    q_validation: np.ndarray


def plate_calibration(config: PlateDrawConfig) -> CalibrationConfig:
    """The plate calibration inside a study that calibrates on the way (the
    closed-loop study's ``compensation:`` and the elastic-arm study's
    ``compliance:`` scenario sections, both :class:`PlateDrawConfig`): LM on
    the point-to-plane distances
    (:class:`~rmdrake.calibration.config.PlaneLMConfig`) of ``params``, its
    sanity checks against the range finder's declared ``noise`` (m). The true
    robot's draw is :func:`draw_true_robot` of the same config."""
    return CalibrationConfig(
        params=config.params, noise=config.noise, calibrator=PlaneLMConfig()
    )


def draw_true_robot(
    nominal: RobotModel, config: PlateDrawConfig, seed: int
) -> CalibrationDraw:
    """Draws the true robot, its plate readings and the held-out poses.

    Args:
      nominal: the nominal robot (what the calibration starts from).
      config: parameters, error size, plates, readings, noise (m) and the
        number of held-out poses.
      seed: seeds the true errors, the plates and the held-out poses (three
        independent streams of ``numpy.random.SeedSequence(seed)``).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.studies import CalibrationStudyConfig, draw_true_robot
    >>> config = CalibrationStudyConfig(plates=4, per_plate=8, n_validation=10)
    >>> draw = draw_true_robot(load_robot("rv3sb"), config, seed=0)
    >>> len(draw.names), draw.simulation.data.q.shape, draw.q_validation.shape
    (17, (32, 6), (10, 6))
    """
    names = resolve_parameters(nominal, drawn_parameters(config.params))
    s_err, s_plates, s_val = (
        int(c.generate_state(1)[0]) for c in np.random.SeedSequence(seed).spawn(3)
    )
    q_val = random_poses(nominal, config.n_validation, s_val)
    deltas = 1e-3 * np.random.default_rng(s_err).standard_normal(len(names))
    for _ in range(3):  # the error is nearly linear in the deltas
        e = tool_point_errors(apply_deltas(nominal, names, deltas), nominal, q_val)
        deltas *= config.mean_error / e.mean
    true = apply_deltas(nominal, names, deltas)
    sim = simulate_plates(
        true,
        plates=config.plates,
        per_plate=config.per_plate,
        noise=config.noise,
        seed=s_plates,
        planning_model=nominal,
    )
    return CalibrationDraw(seed, nominal, true, names, deltas, sim, q_val)


@dataclasses.dataclass
class CalibrationStudyResult:
    """Outcome of :func:`run_calibration_study`.

    Attributes:
      methods: the methods run.
      seeds: the scenario seeds.
      mean_before, max_before: (S,) nominal model's tool errors per seed, m.
      mean_after, max_after: method -> (S,) calibrated model's errors, m.
      times: method -> (S,) fit wall times, s.
      png, html: written files (None when not written).
      first: the first seed's scenario.
      estimators: method -> fitted estimator of the first seed.
      aligned: errors were measured after a best-fit rigid alignment.

    Example:

    >>> import dataclasses
    >>> from rmdrake.studies import CalibrationStudyResult
    >>> [f.name for f in dataclasses.fields(CalibrationStudyResult)][:4]
    ['methods', 'seeds', 'mean_before', 'max_before']
    """

    methods: list[str]
    seeds: list[int]
    mean_before: np.ndarray
    max_before: np.ndarray
    mean_after: dict[str, np.ndarray]
    max_after: dict[str, np.ndarray]
    times: dict[str, np.ndarray]
    png: Path | None = None
    html: Path | None = None
    first: CalibrationDraw | None = None
    estimators: dict[str, Any] = dataclasses.field(default_factory=dict)
    aligned: bool = False

    def table(self) -> str:
        """The first seed's table and the statistics over the seeds."""
        mm = 1e3
        lines = [
            f"{'method':<24} {'mean before':>11} {'max before':>10} "
            f"{'mean after':>10} {'max after':>9} {'time [s]':>9}",
        ]
        for m in self.methods:
            b0, bmax = self.mean_before[0] * mm, self.max_before[0] * mm
            a0, amax = self.mean_after[m][0] * mm, self.max_after[m][0] * mm
            lines.append(
                f"{_LABELS.get(m, m):<24} {b0:8.3f} mm {bmax:7.3f} mm {a0:7.4f} mm"
                f" {amax:6.4f} mm {self.times[m][0]:9.3f}"
            )
        lines.append(
            f"{'paper (experiment)':<24} {PAPER_BEFORE * mm:8.3f} mm {'':>10} "
            f"{PAPER_AFTER * mm:7.4f} mm"
        )
        lines.append("")
        lines.append(
            "over the seeds: mean tool error after calibration [mm] (and fit time)"
        )
        lines.append(
            f"{'method':<24} {'seeds':>5} {'median':>8} {'95th pct':>9} "
            f"{'worst':>8} {'median time [s]':>16}"
        )
        for m in self.methods:
            ran = ~np.isnan(self.mean_after[m])
            e = self.mean_after[m][ran] * mm
            lines.append(
                f"{_LABELS.get(m, m):<24} {ran.sum():5d} {np.median(e):8.4f} "
                f"{np.percentile(e, 95):9.4f} {e.max():8.4f} "
                f"{np.median(self.times[m][ran]):16.3f}"
            )
        b = self.mean_before * mm
        lines.append(
            f"{'before (nominal)':<24} {b.size:5d} {np.median(b):8.4f} "
            f"{np.percentile(b, 95):9.4f} {b.max():8.4f}"
        )
        return "\n".join(lines)


def _method_config(
    method: str, seed: int, config: CalibrationStudyConfig
) -> CalibrationConfig:
    """The calibration config of ``method`` (``de``, ``lm``, ``de+lm``) in the
    calibration study: its ``params``; a DE seeded by the scenario ``seed``,
    with the study's ``de_maxiter``, ``de_popsize`` and ``max_per_plate`` where
    given (None: the method's budget), no progress bar.

    Raises:
      ValueError: an unknown method.
    """
    budget = {
        "maxiter": config.de_maxiter,
        "popsize": config.de_popsize,
        "max_per_plate": config.max_per_plate,
    }
    calibrator = with_de_options(
        plate_calibrator_config(method),
        seed=seed,
        **{k: v for k, v in budget.items() if v is not None},
    )
    return CalibrationConfig(params=config.params, calibrator=calibrator)


def _save_html(scenario: CalibrationDraw, estimator, path: Path) -> Path:
    """Robot at the readings, true plates, points predicted before (red) and
    after (green) calibration, their deviations from the true points x 100."""
    data = scenario.simulation.data
    p_true = scenario.simulation.p_BM
    gain = 100.0
    nominal, model = scenario.nominal, estimator.model_
    p_before = tool_points(nominal.table, data.q, data.distance, sigma=nominal.sigma)
    p_after = tool_points(model.table, data.q, data.distance, sigma=model.sigma)
    plates = [(pl.X_BP, pl.size) for pl in scenario.simulation.plates]
    sets = {
        "true_points": (p_true, (0.1, 0.3, 0.9, 1.0)),
        "before_x100": (p_true + gain * (p_before - p_true), (0.9, 0.1, 0.1, 1.0)),
        "after_x100": (p_true + gain * (p_after - p_true), (0.1, 0.7, 0.2, 1.0)),
    }
    return save_calibration_html(scenario.nominal, data.q, plates, sets, path)


@dataclasses.dataclass(frozen=True)
class CalibrationPlan:
    """The study's checked sizes (:func:`calibration_plan`).

    Attributes:
      seeds: the scenario seeds, 0 to ``seeds`` - 1.
      methods: the methods run on the first seed, in the scenario's order.
      repeat: those of ``methods`` run again on every other seed.
    """

    seeds: tuple[int, ...]
    methods: tuple[str, ...]
    repeat: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class MethodFit:
    """One method's calibration of one draw.

    Attributes:
      estimator: the fitted estimator (its ``model_`` is the calibrated robot).
      time: wall time of the fit, s.
      after: the calibrated model's tool-point errors against the true robot
        at the held-out poses, m; after a best-fit rigid alignment
        (``after.aligned``) when some perturbed parameter is not identified.
    """

    estimator: PlaneCalibrator
    time: float
    after: ValidationResult


@dataclasses.dataclass(frozen=True)
class DrawCalibration:
    """One seed of the study (:func:`calibrate_draw`).

    Attributes:
      draw: the true robot, its readings and the held-out poses.
      before: the nominal model's tool-point errors there, m.
      fits: method -> its :class:`MethodFit`.
    """

    draw: CalibrationDraw
    before: ValidationResult
    fits: dict[str, MethodFit]


def run_calibration_study(
    nominal: RobotModel,
    config: CalibrationStudyConfig,
    out_dir: str | os.PathLike,
    *,
    progress: bool = True,
    echo: Callable[[str], None] = print,
    execution: Execution | TaskRunner = SERIAL,
) -> CalibrationStudyResult:
    """Runs the study and writes its figures (see module docstring).

    The steps: :func:`calibration_plan`, then :func:`calibrate_draw` for each
    seed (every method on the first, ``repeat_methods`` on the others), one
    task per seed, then :func:`write_calibration_files`.

    Args:
      nominal: the nominal robot.
      config: seeds, parameters, measurement sizes, methods and budgets.
      out_dir: folder for ``kinematic_calibration_fig3.png`` and
        ``kinematic_calibration.html`` (created if missing).
      progress: show a progress bar over the seeds.
      echo: where the table and messages go.
      execution: where the seeds' tasks run (default: in this process); the
        result is the same wherever they run (the fit times aside).

    Raises:
      ValueError: no seeds, or a method name that is not one of
        :data:`~rmdrake.calibration.config.CALIBRATION_METHODS`.

    Example:

    >>> from rmdrake.studies import CalibrationStudyConfig
    >>> config = CalibrationStudyConfig(seeds=2, methods=["lm"], n_validation=100)
    >>> config.seeds, config.methods
    (2, ['lm'])

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake import load_robot
        from rmdrake.studies import run_calibration_study
        result = run_calibration_study(load_robot("rv3sb"), config, "out")
        print(result.table())
    """
    out = Path(out_dir)
    plan = calibration_plan(nominal, config)
    out.mkdir(parents=True, exist_ok=True)
    seed_list = list(plan.seeds)
    S = len(seed_list)
    methods = list(plan.methods)
    result = CalibrationStudyResult(
        methods=methods,
        seeds=seed_list,
        mean_before=np.zeros(S),
        max_before=np.zeros(S),
        mean_after={m: np.full(S, np.nan) for m in methods},
        max_after={m: np.full(S, np.nan) for m in methods},
        times={m: np.full(S, np.nan) for m in methods},
    )
    calls = [
        functools.partial(
            calibrate_draw,
            nominal,
            config,
            seed,
            plan.methods if s == 0 else plan.repeat,
        )
        for s, seed in enumerate(seed_list)
    ]
    with TaskRunner(execution, tasks=S, echo=echo) as runner:
        runs = runner.run_calls(calls, desc="seeds", progress=progress)
    first: DrawCalibration | None = None
    for s, run in enumerate(runs):
        result.mean_before[s], result.max_before[s] = run.before.mean, run.before.max
        for m, fit in run.fits.items():
            result.times[m][s] = fit.time
            result.aligned = result.aligned or fit.after.aligned
            result.mean_after[m][s] = fit.after.mean
            result.max_after[m][s] = fit.after.max
        if s == 0:
            first = run
            result.first = run.draw
            result.estimators = {m: fit.estimator for m, fit in run.fits.items()}
    assert first is not None  # plan.seeds is never empty
    result.png, result.html = write_calibration_files(
        out, config, result, first, echo=echo
    )
    return result


def calibration_plan(
    nominal: RobotModel, config: CalibrationStudyConfig
) -> CalibrationPlan:
    """Checks the study's seeds, methods and parameter names against
    ``nominal`` before anything runs.

    Raises:
      ValueError: no seeds, a method name that is not one of
        :data:`~rmdrake.calibration.config.CALIBRATION_METHODS`, or
        a parameter name ``nominal`` does not have.
    """
    seeds = tuple(range(config.seeds))
    if not seeds:
        raise ValueError("calibration.seeds: expected at least one seed")
    methods = tuple(config.methods)
    for m in [*methods, *config.repeat_methods]:
        if m not in CALIBRATION_METHODS:
            raise ValueError(
                f"calibration method '{m}': expected one of "
                f"{', '.join(CALIBRATION_METHODS)}"
            )
    repeat = tuple(m for m in config.repeat_methods if m in methods)
    resolve_parameters(nominal, drawn_parameters(config.params))  # bad names
    return CalibrationPlan(seeds, methods, repeat)


def calibrate_draw(
    nominal: RobotModel,
    config: CalibrationStudyConfig,
    seed: int,
    methods: tuple[str, ...],
) -> DrawCalibration:
    """One seed: draws the true robot (:func:`draw_true_robot` with ``seed``),
    calibrates ``methods`` in turn on its readings (their DE seeded by
    ``seed``) and measures the tool-point errors before and after at the
    held-out poses, m. Perturbed parameters the readings cannot see (a
    base-frame change, absorbed by the plate poses) leave a rigid offset: that
    method's errors are measured after a best-fit rigid alignment. It runs as
    a task: its result, fitted estimators included, pickles."""
    draw = draw_true_robot(nominal, config, seed)
    before = tool_point_errors(draw.nominal, draw.true, draw.q_validation)
    fits = {}
    for m in methods:
        est = make_calibrator(_method_config(m, seed, config), draw.nominal)
        t0 = time.perf_counter()
        est.fit(draw.simulation.data)
        elapsed = time.perf_counter() - t0
        align = bool(set(draw.names) - set(est.names_))
        after = tool_point_errors(est.model_, draw.true, draw.q_validation, align=align)
        fits[m] = MethodFit(est, elapsed, after)
    return DrawCalibration(draw, before, fits)


def write_calibration_files(
    out_dir: str | os.PathLike,
    config: CalibrationStudyConfig,
    result: CalibrationStudyResult,
    first: DrawCalibration,
    *,
    echo: Callable[[str], None] = print,
) -> tuple[Path, Path | None]:
    """Prints the scenario line and :meth:`CalibrationStudyResult.table`, and
    writes into ``out_dir`` (created if missing) the first seed's
    ``kinematic_calibration_fig3.png`` (tool position error, m, at up to 100
    held-out poses, before and after each method) and, if ``config.html``,
    ``kinematic_calibration.html`` (Meshcat: the plates and the tool points
    before and after ``de+lm``, or the last method, deviations x 100),
    printing their names.

    Returns:
      (png, html): the written files, html None when not written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    draw = first.draw
    data = draw.simulation.data
    P = data.plate_ids.size
    noise = np.std(data.distance - draw.simulation.true_distance)
    echo(
        f"Scenario: {draw.nominal.name}, {len(draw.names)} error parameters "
        f"({config.params}), true errors sized to a mean tool error of "
        f"{config.mean_error * 1e3:.3g} mm, {P} plates x {data.n_readings // P} "
        f"readings, noise {noise * 1e6:.1f} um (sample), "
        f"{draw.q_validation.shape[0]} held-out poses; first seed "
        f"{result.seeds[0]}. "
        + (
            "Some perturbed parameters are not identifiable (absorbed by the "
            "plate poses): errors are measured after a best-fit rigid alignment."
            if result.aligned
            else "Every perturbed parameter is identified; no rigid alignment."
        )
    )
    if config.de_maxiter is not None and config.de_maxiter < 50:
        echo(
            f"(DE budget of {config.de_maxiter} generations: the DE figures are "
            "not meaningful at this budget)"
        )
    echo(result.table())
    before = first.before.errors
    n_plot = min(100, before.size)
    labelled = {
        _LABELS.get(m, m): fit.after.errors[:n_plot] for m, fit in first.fits.items()
    }
    png = plot_calibration_errors(
        before[:n_plot],
        labelled,
        out / "kinematic_calibration_fig3.png",
        title=(
            f"Fig. 3 (simulated): tool position error at {n_plot} held-out poses, "
            f"{draw.nominal.name}, seed {result.seeds[0]}"
        ),
        reference={"paper before": PAPER_BEFORE, "paper after": PAPER_AFTER},
    )
    echo(f"wrote {png}")
    html = None
    methods = result.methods
    if config.html and methods:
        best = "de+lm" if "de+lm" in methods else list(methods)[-1]
        html = _save_html(
            draw, first.fits[best].estimator, out / "kinematic_calibration.html"
        )
        echo(
            f"wrote {html} (plates, true points in blue, predicted points "
            f"before in red and after {best} in green, deviations x 100)"
        )
    return png, html
