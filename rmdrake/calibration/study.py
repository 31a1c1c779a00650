"""The paper's kinematic-calibration study (Wang et al. 2016, §4, Table 1, Fig. 3).

Scenario (:func:`paper_scenario`): the RV-3SB; a "true" robot with errors on the
17 parameters of Table 1 drawn at random (lengths and angles with the same
standard deviation in mm and mrad) and scaled so that the nominal model's mean
tool-point error over the held-out poses is 1.6 mm, as in the paper's
experiment; 5 plate locations x 12 readings (:func:`simulate_plates`); reading
noise 2 um. Held-out poses: uniform within the joint limits, never used by the
calibration.

:func:`run_paper_study` calibrates with the paper's method (DE on volumes), LM
and DE+LM, prints the table next to the paper's 1.6 mm -> 0.3 mm, saves a Fig.
3-style PNG and a Meshcat HTML for the first seed, repeats over the seeds and
prints the median and 95th percentile of the mean tool error after calibration.
``rmdrake demo`` and ``examples/kinematic_calibration.py`` call it.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.calibration.estimators import make_calibrator
from rmdrake.calibration.measurements import (
    SimulatedPlates,
    random_poses,
    simulate_plates,
)
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.kinematics import tool_points
from rmdrake.robot import (
    RobotModel,
    apply_deltas,
    error_parameter_names,
    load_robot,
)

__all__ = [
    "PAPER_AFTER",
    "PAPER_BEFORE",
    "PaperScenario",
    "StudyResult",
    "paper_scenario",
    "run_paper_study",
]

PAPER_BEFORE = 1.6e-3  # m, paper §4: mean position error before calibration
PAPER_AFTER = 0.3e-3  # m, after (experiment)
_LABELS = {
    "de": "paper: DE on volumes",
    "lm": "LM on plane distances",
    "de+lm": "DE + LM",
}


@dataclasses.dataclass(frozen=True)
class PaperScenario:
    """One draw of the paper's scenario.

    Attributes:
      seed: the scenario seed.
      nominal: the nominal robot (what the calibration starts from).
      true: the simulated true robot.
      names: the 17 error parameters.
      true_deltas: their true values, rad or m.
      simulation: the plates and readings of the true robot.
      q_validation: (M, n) held-out joint angles, rad.
    """

    seed: int
    nominal: RobotModel
    true: RobotModel
    names: list[str]
    true_deltas: np.ndarray
    simulation: SimulatedPlates
    q_validation: np.ndarray


def paper_scenario(
    seed: int,
    *,
    model: RobotModel | None = None,
    mean_error: float = PAPER_BEFORE,
    plates: int = 5,
    per_plate: int = 12,
    noise: float = 2e-6,
    n_validation: int = 1000,
) -> PaperScenario:
    """Draws the paper's scenario for one seed (see the module docstring).

    Args:
      seed: seeds the true errors, the plates and the held-out poses (three
        independent streams of ``numpy.random.SeedSequence(seed)``).
      model: nominal robot (default: the shipped ``rv3sb``).
      mean_error: nominal-vs-true mean tool-point error to size the errors, m.
      plates, per_plate, noise: the measurement (noise in m).
      n_validation: number of held-out poses.
    """
    nominal = model if model is not None else load_robot("rv3sb")
    names = error_parameter_names(nominal, "paper")
    s_err, s_plates, s_val = (
        int(c.generate_state(1)[0]) for c in np.random.SeedSequence(seed).spawn(3)
    )
    q_val = random_poses(nominal, n_validation, s_val)
    deltas = 1e-3 * np.random.default_rng(s_err).standard_normal(len(names))
    for _ in range(3):  # the error is nearly linear in the deltas
        e = tool_point_errors(apply_deltas(nominal, names, deltas), nominal, q_val)
        deltas *= mean_error / e.mean
    true = apply_deltas(nominal, names, deltas)
    sim = simulate_plates(
        true,
        plates=plates,
        per_plate=per_plate,
        noise=noise,
        seed=s_plates,
        planning_model=nominal,
    )
    return PaperScenario(seed, nominal, true, names, deltas, sim, q_val)


@dataclasses.dataclass
class StudyResult:
    """Outcome of :func:`run_paper_study`.

    Attributes:
      methods: the methods run.
      seeds: the scenario seeds.
      mean_before, max_before: (S,) nominal model's tool errors per seed, m.
      mean_after, max_after: method -> (S,) calibrated model's errors, m.
      times: method -> (S,) fit wall times, s.
      png, html: written files (None when not written).
      first: the first seed's scenario.
      estimators: method -> fitted estimator of the first seed.
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
    first: PaperScenario | None = None
    estimators: dict[str, Any] = dataclasses.field(default_factory=dict)

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


def _calibrator_options(method: str, seed: int, smoke: bool) -> dict[str, Any]:
    options: dict[str, Any] = {"params": "paper"}
    if method != "lm":
        options["seed"] = seed
    if smoke and method != "lm":
        options.update(maxiter=3, popsize=5, max_per_plate=10)
    return options


def _save_html(scenario: PaperScenario, estimator, path: Path) -> Path:
    """Robot at the readings, true plates, points predicted before (red) and
    after (green) calibration, their deviations from the true points x 100."""
    from rmdrake.systems.visualization import save_calibration_html

    data = scenario.simulation.data
    p_true = scenario.simulation.p_BM
    gain = 100.0
    p_before = tool_points(scenario.nominal.table, data.q, data.distance)
    p_after = tool_points(estimator.model_.table, data.q, data.distance)
    plates = [(pl.X_BP, pl.size) for pl in scenario.simulation.plates]
    sets = {
        "true_points": (p_true, (0.1, 0.3, 0.9, 1.0)),
        "before_x100": (p_true + gain * (p_before - p_true), (0.9, 0.1, 0.1, 1.0)),
        "after_x100": (p_true + gain * (p_after - p_true), (0.1, 0.7, 0.2, 1.0)),
    }
    return save_calibration_html(scenario.nominal, data.q, plates, sets, path)


def run_paper_study(
    out_dir: str | os.PathLike,
    *,
    seeds: int | Sequence[int] = 20,
    methods: Sequence[str] = ("de", "lm", "de+lm"),
    repeat_methods: Sequence[str] | None = None,
    smoke: bool = False,
    html: bool = True,
    progress: bool = True,
    echo: Callable[[str], None] = print,
) -> StudyResult:
    """Runs the paper's study and writes its figures (see module docstring).

    Args:
      out_dir: folder for ``kinematic_calibration_fig3.png`` and
        ``kinematic_calibration.html`` (created if missing).
      seeds: number of seeds (0..S-1) or the seeds themselves.
      methods: any of ``de``, ``lm``, ``de+lm``.
      repeat_methods: the methods run on the seeds after the first (default:
        all of ``methods``); e.g. ``("lm", "de+lm")`` skips the paper's DE,
        the slowest, on the repeats.
      smoke: a seconds-long run for tests (2 seeds at most, 5 plates x 8
        readings, 100 held-out poses, a token DE budget); same outputs.
      html: write the Meshcat HTML (opens a Meshcat server on localhost).
      progress: show a progress bar over the seeds.
      echo: where the table and messages go.

    Returns:
      The :class:`StudyResult`.
    """
    from tqdm.auto import tqdm

    from rmdrake.plots import plot_calibration_errors

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    seed_list = list(range(seeds)) if isinstance(seeds, int) else list(seeds)
    if smoke:
        seed_list = seed_list[:2]
    if not seed_list:
        raise ValueError("seeds: expected at least one seed")
    repeat = list(methods) if repeat_methods is None else list(repeat_methods)
    for m in [*methods, *repeat]:
        make_calibrator(m, load_robot("rv3sb"))  # validates the method names
    repeat = [m for m in repeat if m in methods]
    scenario_kw: dict[str, Any] = {}
    if smoke:
        scenario_kw = {"per_plate": 8, "n_validation": 100}
    S = len(seed_list)
    result = StudyResult(
        methods=list(methods),
        seeds=seed_list,
        mean_before=np.zeros(S),
        max_before=np.zeros(S),
        mean_after={m: np.full(S, np.nan) for m in methods},
        max_after={m: np.full(S, np.nan) for m in methods},
        times={m: np.full(S, np.nan) for m in methods},
    )
    first_errors: dict[str, np.ndarray] = {}
    for s, seed in enumerate(tqdm(seed_list, desc="seeds", disable=not progress)):
        scenario = paper_scenario(seed, **scenario_kw)
        before = tool_point_errors(
            scenario.nominal, scenario.true, scenario.q_validation
        )
        result.mean_before[s], result.max_before[s] = before.mean, before.max
        for m in methods if s == 0 else repeat:
            est = make_calibrator(
                m, scenario.nominal, **_calibrator_options(m, seed, smoke)
            )
            t0 = time.perf_counter()
            est.fit(scenario.simulation.data)
            result.times[m][s] = time.perf_counter() - t0
            after = tool_point_errors(est.model_, scenario.true, scenario.q_validation)
            result.mean_after[m][s], result.max_after[m][s] = after.mean, after.max
            if s == 0:
                result.estimators[m] = est
                first_errors[m] = after.errors
        if s == 0:
            result.first = scenario
            first_before = before.errors
    first = result.first
    data = first.simulation.data
    P = data.plate_ids.size
    noise = np.std(data.distance - first.simulation.true_distance)
    echo(
        f"Paper scenario: {first.nominal.name}, {len(first.names)} error parameters "
        f"(Table 1), {P} plates x {data.n_readings // P} readings, noise "
        f"{noise * 1e6:.1f} um (sample), {first.q_validation.shape[0]} held-out "
        f"poses; seed "
        f"{seed_list[0]}. All 17 parameters are identifiable and the truth has no "
        f"base-frame error, so no rigid alignment is applied."
    )
    if smoke:
        echo(
            "(smoke run: 5 plates x 8 readings and a token DE budget of 3 "
            "generations; the DE figures are meaningless here)"
        )
    echo(result.table())
    n_plot = min(100, first_before.size)
    labelled = {_LABELS.get(m, m): e[:n_plot] for m, e in first_errors.items()}
    result.png = plot_calibration_errors(
        first_before[:n_plot],
        labelled,
        out / "kinematic_calibration_fig3.png",
        title=(
            f"Fig. 3 (simulated): tool position error at {n_plot} held-out poses, "
            f"{first.nominal.name}, seed {seed_list[0]}"
        ),
        reference={"paper before": PAPER_BEFORE, "paper after": PAPER_AFTER},
    )
    echo(f"wrote {result.png}")
    if html and methods:
        best = "de+lm" if "de+lm" in methods else list(methods)[-1]
        result.html = _save_html(
            first, result.estimators[best], out / "kinematic_calibration.html"
        )
        echo(
            f"wrote {result.html} (plates, true points in blue, predicted points "
            f"before in red and after {best} in green, deviations x 100)"
        )
    return result
