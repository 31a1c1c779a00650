"""Runs a whole :class:`~rmdrake.studies.scenarios.Scenario`: the robot, the
kinematic-calibration study, the dynamic-identification study and the
closed-loop compensation study, each section into its own folder."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from rmdrake.execution import SERIAL, Execution, TaskRunner
from rmdrake.model.error_parameters import is_compliance_name
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.pipelines.show import robot_summary, save_robot_html
from rmdrake.studies.calibration import run_calibration_study
from rmdrake.studies.compensation import (
    cube_step,
    run_static_accuracy_study,
    start_static_accuracy_study,
)
from rmdrake.studies.elastic_arm.study import run_compliance_study
from rmdrake.studies.identification import run_identification_study
from rmdrake.studies.scenarios import (
    CalibrationStudyConfig,
    PlateDrawConfig,
    Scenario,
    drawn_parameters,
)
from rmdrake.systems.visualization import with_own_meshcat

__all__ = ["check_scenario_robot", "files_written", "run_scenario", "written_summary"]

#: Up to this many files, the final line lists each; beyond, a count per folder.
LISTED_FILES = 12


def run_scenario(
    scenario: Scenario,
    out_dir: str | os.PathLike,
    *,
    name: str = "scenario",
    meshcat: bool = False,
    execution: Execution | TaskRunner = SERIAL,
) -> Path:
    """Runs every section of ``scenario`` that is not None; returns the folder.
    ``meshcat``: open a Meshcat server and show the closed-loop tracking run
    there live (its URL is printed). ``execution``: where the calibration,
    compensation and compliance studies run their independent pieces (seeds,
    station runs) as tasks (default: in this process); one runner serves
    them all, so a local cluster starts at most once (for the default
    ``Execution()``, when a study's first piece shows its work outweighs the
    start-up) and stops at the end. With workers (the default execution
    starts them then), the compensation study's tasks are started before the
    identification study, which runs here meanwhile: they need nothing of
    each other. The results do not depend on it.

    Files: ``<robot>.html`` (the robot), ``kinematics/`` (calibration study),
    ``dynamics/`` (identification study), ``compensation/`` (compensation
    study), ``compliance/`` (elastostatic study), under ``out_dir``; the last
    lines printed name the HTML and PNG files written (:func:`written_summary`).

    Raises:
      ValueError: a bad robot or a scenario value this robot cannot run
        (:func:`check_scenario_robot`, naming the key), before any file.

    Example:

    >>> from rmdrake.studies import load_scenario
    >>> scenario = load_scenario(name="paper")
    >>> scenario.robot
    'rv3sb'

    The whole run (it takes minutes, so the doctests do not run it)::

        from rmdrake.studies import run_scenario
        run_scenario(scenario, "out", name="paper")
    """
    out = Path(out_dir)
    model = load_robot(scenario.robot)  # fails before anything is written
    check_scenario_robot(scenario, model, f"scenario '{name}'")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a folder")
    t0, started = time.perf_counter(), time.time()
    print(f"== rmdrake scenario '{name}' into {out}/")
    if scenario.description:
        print(scenario.description)
    sections = (
        (scenario.calibration, run_calibration_study, "kinematics",
         "Kinematic calibration by plane constraints (paper §2, Fig. 3)"),
        (scenario.identification, run_identification_study, "dynamics",
         "Dynamic identification with Drake as the robot (§3, Fig. 4, 6, 7)"),
        (scenario.compensation, run_static_accuracy_study, "compensation",
         "Closed loop in Drake: static accuracy (ISO 9283) and path tracking"),
        (scenario.compliance, run_compliance_study, "compliance",
         "Elastic joints: elastostatic calibration and deflection compensation"),
    )  # fmt: skip
    # Entered before the first file: a scheduler that does not answer (or a
    # local cluster that cannot start) ends the run with nothing written.
    with TaskRunner(execution, echo=print) as runner:
        out.mkdir(parents=True, exist_ok=True)
        section = 1
        if scenario.show:
            print(f"\n== {section}. The robot")
            print(robot_summary(model))
            path, count = save_robot_html(model, out / f"{model.name}.html")
            print(f"wrote {path} ({count} poses, open it in a browser)")
            section += 1
        ahead = None  # the closed loop's tasks, started ahead
        for config, run, folder, title in sections:
            if config is None:
                continue
            if (
                folder == "dynamics"
                and scenario.compensation is not None
                and not meshcat
                and runner.start_cluster()
            ):
                # The closed loop needs nothing of this section: its tasks go
                # to the workers now, while this process identifies.
                ahead = start_static_accuracy_study(
                    model, scenario.compensation, runner
                )
            print(f"\n== {section}. {title}")
            # identification: one chain of steps, no seeds or variants to hand out
            where = {} if folder == "dynamics" else {"execution": runner}
            if folder == "compensation" and ahead is not None:
                where["started"] = ahead
            if folder == "compensation" and meshcat:
                with_own_meshcat(run, model, config, out / folder, live=True, **where)
            else:
                run(model, config, out / folder, **where)
            section += 1
    took = time.perf_counter() - t0
    print(f"\n== done in {took:.0f} s; {written_summary(out, started)}")
    return out


def check_scenario_robot(
    scenario: Scenario, model: RobotModel, where: str = "scenario"
) -> None:
    """Checks, before any file is written or any long step runs, that every
    section of ``scenario`` can run on ``model`` (its loaded robot): each
    parameter set resolves on the robot and, unless ``full`` or ``auto`` (which
    choose), is identifiable from the section's plate readings (drawn on the
    nominal robot); ``params: auto`` comes with LM methods; the identification
    and compensation studies have dynamics to identify and a station that
    builds on the robot (an elastic arm's controller, below its lowest
    structural mode); the compliance study has an elastic robot with a
    payload; the compensation study's cube is reachable (``cube_q``,
    ``cube_side``: :func:`~rmdrake.studies.compensation.cube_step`). The
    values alone are checked by
    :func:`~rmdrake.studies.scenarios.check_scenario` when the scenario
    loads.

    Raises:
      ValueError: one line, ``where``, the section's key and the fix
        (``scenario 'mine': calibration.params: paper is rank 16 of 17 on
        robot 'myarm' ...: write `calibration: {params: auto}` ...``).
    """
    if scenario.compliance is not None and (
        model.compliance is None or model.payload is None
    ):
        lacks = "payload" if model.compliance else "compliance (joint stiffness)"
        raise ValueError(
            f"{where}: compliance: robot '{model.name}' has no {lacks} entry, which "
            "the compliance study needs; write `compliance: null` or choose an "
            "elastic robot (demo_rh_elastic)"
        )
    sections = {
        "calibration": scenario.calibration,
        "compensation": scenario.compensation,
        "compliance": scenario.compliance,
    }
    for key, config in sections.items():
        if config is not None:
            _check_parameters(model, config, f"{where}: {key}", key)
    dynamic = {
        "identification": scenario.identification,
        "compensation": scenario.compensation,
    }
    for key, config in dynamic.items():
        if config is None:
            continue
        if model.dynamics is None:
            raise ValueError(
                f"{where}: {key}: robot '{model.name}' has no 'dynamics' section (13 "
                f"standard parameters per link), which the {key} study needs; add "
                f"one to the robot or write `{key}: null`"
            )
        _check_station(model, config.station, f"{where}: {key}.station")
    if scenario.compensation is not None:
        try:  # the cube's points, reachable with the fixed orientation
            cube_step(model, scenario.compensation)
        except ValueError as e:
            raise ValueError(f"{where}: {e}") from None


def _check_parameters(
    model: RobotModel, config: PlateDrawConfig, where: str, key: str
) -> None:
    """:func:`check_scenario_robot`'s rule on one section's ``params``."""
    from rmdrake.calibration.parameters import resolve_parameters
    from rmdrake.calibration.plates.identifiability import analyse_identifiability
    from rmdrake.calibration.plates.simulate import simulate_plates

    params = config.params
    auto = f"write `{key}: {{params: auto}}` (the parameters the readings see, "
    auto += "chosen by cross-validation, as the CLI's calibrate)"
    try:
        names = resolve_parameters(model, drawn_parameters(params))
    except ValueError as e:
        raise ValueError(f"{where}.params: {e}; or {auto}") from None
    if params == "auto" and isinstance(config, CalibrationStudyConfig):
        if "de" in config.methods or "de" in config.repeat_methods:
            raise ValueError(
                f"{where}.methods: de cannot take params auto (the paper's DE alone "
                "cannot cross-validate its choice): use lm and de+lm, or name the "
                "parameters (params: paper, full or a comma-separated list)"
            )
    if params in ("full", "auto"):
        return  # these choose the identifiable subset
    names = [n for n in names if not is_compliance_name(n)]  # MDH: the rank
    try:
        data = simulate_plates(
            model, plates=config.plates, per_plate=config.per_plate, noise=0.0
        ).data
    except ValueError as e:
        raise ValueError(f"{where}.plates, per_plate: {e}") from None
    report = analyse_identifiability(model, data, names)
    lost = [n for n in report.dropped if not is_compliance_name(n)]
    if lost:
        kept = ",".join(n for n in names if n not in lost)
        why = report.dropped[lost[0]].split(" (")[0]
        raise ValueError(
            f"{where}.params: {params} is rank {report.rank} of {len(names)} on robot "
            f"'{model.name}': drop {', '.join(lost)} ({why}); {auto}, or list the "
            f"{len(names) - len(lost)} it sees: `params: {kept}`"
        )


def _check_station(model: RobotModel, station: object, where: str) -> None:
    """Builds ``station`` (a StationConfig) on a true robot drawn from
    ``model`` with a random excitation, as the identification steps do, so
    that a controller the robot cannot take (an elastic arm's) is refused
    now; ValueError names ``where``."""
    from rmdrake.excitation.random import random_fourier_trajectory
    from rmdrake.studies.identification import perturb_dynamics
    from rmdrake.systems.station import MakeStation

    if model.compliance is None or not np.any(model.compliance.elastic):
        return  # a rigid arm takes every controller
    try:
        MakeStation(
            station,
            true_model=perturb_dynamics(model, 0),
            trajectory=random_fourier_trajectory(model, seed=0),
            nominal_model=model,
        )
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def files_written(out_dir: str | os.PathLike, since: float) -> list[Path]:
    """The ``.html`` and ``.png`` files under ``out_dir`` modified at or after
    ``since`` (seconds since the epoch, as ``time.time()``), relative to
    ``out_dir``, sorted: what a run wrote, not what an earlier run left."""
    out = Path(out_dir)
    found = [
        p
        for pattern in ("*.html", "*.png")
        for p in out.rglob(pattern)
        if p.is_file() and p.stat().st_mtime >= since - 1.0  # coarse clocks
    ]
    return sorted(p.relative_to(out) for p in found)


def written_summary(out_dir: str | os.PathLike, since: float) -> str:
    """What the run wrote to look at, for its last line: each ``.html`` and
    ``.png`` under ``out_dir`` (relative, sorted; :func:`files_written`), or,
    past :data:`LISTED_FILES` of them, their count per folder."""
    files = files_written(out_dir, since)
    where = f"{Path(out_dir)}/"
    if not files:
        return f"no HTML or PNG written in {where}"
    if len(files) <= LISTED_FILES:
        listed = "".join(f"\n  {p}" for p in files)
        return f"open these in {where} (HTML in a browser):{listed}"
    per_folder: dict[str, list[str]] = {}
    for p in files:
        folder = "./" if p.parent == Path(".") else f"{p.parent}/"
        per_folder.setdefault(folder, []).append(p.suffix)
    counts = "".join(
        f"\n  {folder}: {kinds.count('.html')} HTML, {kinds.count('.png')} PNG"
        for folder, kinds in sorted(per_folder.items())
    )
    return f"{len(files)} files to open in {where} (HTML in a browser):{counts}"
