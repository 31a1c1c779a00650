"""The compliance study's report: its printed tables and its files
(``payload_errors.png``, ``deflection_field.png``, ``compliance.html``,
``results.yaml``; see :mod:`rmdrake.studies.elastic_arm`)."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml

from rmdrake.dynamics.compliance import link_angles, with_payload_mass
from rmdrake.io.atomic import atomic_write_text
from rmdrake.report.plots import plot_deflection_field, plot_payload_errors
from rmdrake.studies.elastic_arm.pickup import (
    PICKUP_ESTIMATOR_PERIOD,
    PICKUP_FORGETTING,
)
from rmdrake.studies.elastic_arm.results import (
    ComplianceStudyResult,
    ElasticCalibration,
    InsertionRuns,
    StaticAccuracy,
)
from rmdrake.studies.elastic_arm.variants import VARIANTS
from rmdrake.studies.scenarios import ComplianceStudyConfig
from rmdrake.systems.visualization import save_robot_states_html

__all__ = ["mm", "write_compliance_files", "write_files"]


def mm(x: float) -> str:
    """``x`` m in mm, three decimals: ``mm(0.0123)`` is ``"12.300"``."""
    return f"{1e3 * x:.3f}"


def write_compliance_files(
    out_dir: str | os.PathLike,
    config: ComplianceStudyConfig,
    result: ComplianceStudyResult,
    *,
    calibration: ElasticCalibration,
    static: StaticAccuracy,
    insertion: InsertionRuns | None,
    echo: Callable[[str], None] = print,
) -> list[Path]:
    """Prints the study's tables (calibration checks, stiffness, static and
    station accuracy, the move and the pick-up), writes its files into
    ``out_dir`` (created if missing; :func:`write_files`), prints their names
    and returns them."""
    out = Path(out_dir)
    heaviest = float(max(config.test_payloads))
    for name, verdict in calibration.verdicts.items():
        echo(f"calibration {name}: {verdict}")
    echo("joint  stiffness true  identified  error")
    pairs = zip(result.stiffness, result.stiffness_identified, strict=True)
    for j, (kt, kh) in enumerate(pairs, start=1):
        err = "not seen" if np.isnan(kh) else f"{100 * (kh / kt - 1):+.2f} %"
        echo(f"{j:5d}  {kt:14.4g}  {kh:10.4g}  {err}")
    echo(
        "calibrated kinematics (no load), mean tool error: "
        + ", ".join(f"{k} {mm(v)} mm" for k, v in calibration.geometric.items())
    )
    static_errors = result.static
    echo(f"static tool error over {config.n_targets} held-out targets, mean (max) mm:")
    names = [v.name for v in VARIANTS]
    echo("payload kg  " + "  ".join(f"{v:>18s}" for v in names))
    for mass in config.test_payloads:
        cells = [
            f"{mm(static_errors[(v, mass)].mean())} "
            f"({mm(static_errors[(v, mass)].max())})"
            for v in names
        ]
        echo(f"{mass:10g}  " + "  ".join(f"{c:>18s}" for c in cells))
    deflection = result.deflection
    echo(
        f"tool deflection under {heaviest:g} kg at the nominal commands: mean "
        f"{mm(deflection.mean())} mm, max {mm(deflection.max())} mm"
    )
    k = min(config.diagram_targets, config.n_targets)
    if k > 0:
        echo(
            f"in the Drake station ({k} targets, {heaviest:g} kg), mean mm: "
            + ", ".join(f"{v} {mm(e.mean())}" for v, e in result.diagram.items())
            + f"; largest gap to the static prediction {mm(result.diagram_gap)} mm"
        )
    if insertion is not None:
        echo(
            f"insertion: {config.path_length:g} m along the tool axis in "
            f"{insertion.program.duration:.1f} s, then {config.path_hold:g} s of "
            f"hold, {heaviest:g} kg"
        )
        echo("variant        path max mm  final mm  oscillation mm  settling s")
        for variant, r in insertion.results.items():
            echo(
                f"{variant:13s} {mm(r.max_error):>11s}  {mm(r.final_error):>8s}  "
                f"{mm(r.oscillation):>14s}  {r.settling_time:10.2f}"
            )
    pickup = result.pickup
    if pickup is not None:
        echo(
            f"pick-up of {heaviest:g} kg while holding a target: tool error "
            f"{mm(pickup.before)} mm before, {mm(pickup.told)} mm after with the "
            f"controller's payload mass updated ({mm(pickup.untold)} mm left at "
            f"0), peak {mm(pickup.peak)} mm, settled in {pickup.settling_time:.1f} s"
        )
        echo(
            f"  estimating (payload estimator, {1 / PICKUP_ESTIMATOR_PERIOD:g} Hz, "
            f"forgetting {PICKUP_FORGETTING:g}): {mm(pickup.estimating)} mm "
            f"after, peak {mm(pickup.estimating_peak)} mm, settled in "
            f"{pickup.estimating_settling_time:.1f} s; estimated "
            f"{pickup.estimated_mass:.1f} kg"
        )
    out.mkdir(parents=True, exist_ok=True)
    files = write_files(result, config, out, static.q_nominal[0], static.q_compensated)
    for f in files:
        echo(f"wrote {f}")
    return files


def write_files(
    result: ComplianceStudyResult,
    config: ComplianceStudyConfig,
    out: Path,
    q0: np.ndarray,
    q_comp: np.ndarray,
) -> list[Path]:
    """Writes the study's PNGs, Meshcat page and ``results.yaml`` (module
    docstring) into the existing folder ``out``, silently; ``q0`` (n,) is a
    target's nominal configuration and ``q_comp`` (n,) the elastostatic
    variant's motor command for it with the largest payload, rad."""
    heaviest = float(max(config.test_payloads))
    files = [
        plot_payload_errors(
            {
                v.label: {m: result.static[(v.name, m)] for m in config.test_payloads}
                for v in VARIANTS
            },
            out / "payload_errors.png",
        ),
        plot_deflection_field(
            with_payload_mass(result.true, heaviest),
            heaviest,
            out / "deflection_field.png",
        ),
    ]
    # Meshcat: nominal target pose (grey), the sagging arm (nominal commands, red)
    # and the compensated one (green), the deflection magnified so that it shows
    # on an 8 m arm.
    true_m = with_payload_mass(result.true, heaviest)
    sag = link_angles(true_m, q0, heaviest) - q0
    comp = link_angles(true_m, q_comp, heaviest)
    scale = 20.0
    files.append(
        save_robot_states_html(
            true_m,
            {
                "nominal": (q0, 0.5),
                f"sagging x{scale:g}": (q0 + scale * sag, 1.0),
                f"compensated x{scale:g}": (q0 + scale * (comp - q0), 0.6),
            },
            out / "compliance.html",
            note=(
                f"{heaviest:g} kg payload (see-through spheres); link deflections "
                f"x{scale:g}; where the compensated arm reaches the nominal pose "
                "it covers the grey one"
            ),
        )
    )
    summary = {
        "lowest_mode_rad_s": result.mode,
        "bandwidth_rad_s": result.bandwidth,
        "readings": result.readings,
        "stiffness_true": result.stiffness.tolist(),
        "stiffness_identified": [
            None if np.isnan(v) else float(v) for v in result.stiffness_identified
        ],
        "deflection_mm": {
            "mean": 1e3 * float(result.deflection.mean()),
            "max": 1e3 * float(result.deflection.max()),
        },
        "static_mean_mm": {
            v.name: {
                float(m): 1e3 * result.mean(v.name, m) for m in config.test_payloads
            }
            for v in VARIANTS
        },
        "diagram_mean_mm": {
            v: 1e3 * float(e.mean()) for v, e in result.diagram.items()
        },
        "diagram_gap_mm": 1e3 * result.diagram_gap,
        "path": {
            v: {k: float(x) for k, x in dataclasses.asdict(r).items()}
            for v, r in result.path.items()
        },
        "pickup": None
        if result.pickup is None
        else {k: float(x) for k, x in dataclasses.asdict(result.pickup).items()},
    }
    files.append(
        atomic_write_text(
            out / "results.yaml", yaml.safe_dump(summary, sort_keys=False)
        )
    )
    return files
