"""The heavy arm bends: elastostatic calibration and deflection compensation
(scenario ``demo_rh_compliance``).

The paper's motivation (its §1) is a blanket-handling arm whose errors come
"from geometric dimensions, dynamic motion, as well as joint and link
deformations". This study puts a number on the last: on an elastic arm
(``RobotModel.compliance``) with geometric errors, what a rigid calibration
(the paper's model) leaves under load, and what an elastostatic one (the joint
compliances identified with the geometry) and the compensation controller's
pre-deflection buy.

Steps (:func:`run_compliance_study`):

1. The truth: the robot's kinematics with the calibration study's errors on
   ``params`` and its joint stiffness scaled per joint by 1 + spread N(0, 1).
   The nominal model (what every controller and calibration starts from) is
   the robot without compliance: the paper's rigid model.
2. Plate readings with each payload of ``calibration_payloads``, taken in the
   Drake station (the true elastic arm settles at each configuration under a
   controller whose bandwidth is a quarter of its lowest structural mode; the
   encoders read the motor side, the range finder sees the link side).
3. LM calibration of the rigid model (``params``) and of the elastostatic one
   (``params`` and ``c<j>``), both on all the readings.
4. Static tool accuracy on held-out targets (full tool poses) at each of
   ``test_payloads``, the payload held at the tool. The variants command the
   motor side:

   - ``nominal``: the nominal IK (the targets' own configurations);
   - ``rigid``: the targets solved on the rigid calibration;
   - ``elastostatic``: solved on the elastostatic calibration, then
     pre-deflected by its compliances at the payload
     (:func:`rmdrake.dynamics.compliance.motor_angles`);
   - ``oracle``: solved on the true kinematics and pre-deflected by the true
     compliances.

   The attained tool position is where the true arm rests with its motors
   there (:func:`rmdrake.dynamics.compliance.link_angles`); the first
   ``diagram_targets`` targets are also driven in the station at the largest
   payload, with the compensation controller pre-deflecting online, and the
   tool tracker's reading is compared with that static prediction.
5. An insertion-like move along the tool's approach axis with the largest
   payload in the station, each variant's controller tracking it online
   (kinematic correction and pre-deflection inside the controller): the tool
   path error, the residual oscillation after the stop (largest distance from
   the final rest position after the programme ends) and its settling time
   (last time outside ``settle_band`` of the final position).
6. A module picked up mid-task: the compensation controller holds the first
   target with no payload; then the largest payload appears on the true arm's
   tool (its payload body's inertia, a Context parameter) and on the
   controller's ``payload_mass`` source at the same instant (and, for
   comparison, not on the controller's): the tool error before, after, its
   peak and its settling time.

Files: ``payload_errors.png`` (tool error per target, per model and payload),
``deflection_field.png`` (tool deflection of the nominal controller with the
largest payload over the workspace), ``compliance.html`` (Meshcat: the
nominal, deflected and compensated arm, deflection magnified),
``results.yaml``.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.plates.simulate import range_readings
from rmdrake.calibration.validation import tool_point_errors
from rmdrake.compensation.correction import correct_targets
from rmdrake.dynamics.compliance import (
    joint_compliances,
    link_angles,
    lowest_structural_mode,
    motor_angles,
    with_payload_mass,
)
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.robot import Compliance, RobotModel
from rmdrake.studies.calibration import draw_true_robot, plate_calibration
from rmdrake.studies.closed_loop import stream
from rmdrake.studies.compensation import held_out_configurations
from rmdrake.studies.compliance_config import ComplianceStudyConfig
from rmdrake.studies.elastic_arm_runs import (
    VARIANTS,
    PathResult,
    PickupResult,
    drive_variant,
    insertion_program,
    run_path,
    run_pickup,
    station_config,
    write_files,
)
from rmdrake.systems.measurement_runs import measure_plates_in_diagram
from rmdrake.systems.station_config import (
    InverseDynamicsControllerConfig,
)

__all__ = ["VARIANTS", "ComplianceStudyResult", "run_compliance_study"]


@dataclasses.dataclass
class ComplianceStudyResult:
    """Outcome of :func:`run_compliance_study` (SI units).

    Attributes:
      true, rigid, elastic: the true robot and the two calibrated models.
      readings: plate readings used (all payloads).
      stiffness: (n,) true stiffness; stiffness_identified: (n,) the
        elastostatic calibration's (NaN where not identified), N m/rad.
      static: (variant, payload kg) -> (K,) tool errors at the targets, m.
      deflection: (K,) tool deflection of the nominal commands with the
        largest payload (rest against rigid), m.
      diagram: variant -> (k,) tool errors of the station runs, m.
      diagram_gap: largest |station - static prediction| over those, m.
      mode: lowest structural mode of the nominal robot, rad/s; bandwidth:
        the controllers', rad/s.
      path: variant -> :class:`PathResult`.
      pickup: the module picked up mid-task (:class:`PickupResult`), or None.
      files: written files.
    """

    true: RobotModel
    rigid: RobotModel
    elastic: RobotModel
    readings: int
    stiffness: np.ndarray
    stiffness_identified: np.ndarray
    static: dict[tuple[str, float], np.ndarray]
    deflection: np.ndarray
    diagram: dict[str, np.ndarray]
    diagram_gap: float
    mode: float
    bandwidth: float
    path: dict[str, PathResult]
    pickup: PickupResult | None = None
    files: list[Path] = dataclasses.field(default_factory=list)

    def mean(self, variant: str, payload: float) -> float:
        """Mean static tool error of ``variant`` at ``payload`` kg, m."""
        return float(np.mean(self.static[(variant, payload)]))


def _truth(robot: RobotModel, config: ComplianceStudyConfig):
    """(nominal rigid model, true elastic robot, calibration draw)."""
    if robot.compliance is None or robot.payload is None:
        raise ValueError(
            f"robot '{robot.name}': the compliance study needs a robot with "
            "compliance (joint stiffness) and a payload entry"
        )
    nominal = dataclasses.replace(robot, compliance=None)
    draw = draw_true_robot(nominal, plate_calibration(config)[0], config.seed)
    rng = np.random.default_rng(stream(config.seed, 7))
    k = robot.compliance.stiffness
    factor = np.clip(1 + config.stiffness_spread * rng.standard_normal(k.size), 0.5, 2)
    true = dataclasses.replace(
        draw.true, name=f"{robot.name}_true", compliance=Compliance(k * factor)
    )
    return nominal, true, draw


def _readings(robot, nominal, true, draw, config, bandwidth) -> PlaneMeasurements:
    """The plate readings of every calibration payload, taken in the station
    (or from the static model), with their payload column. The configurations
    planned on the nominal model are pre-sagged for each payload with the
    robot's design stiffness (``robot.compliance``, not the truth's), as an
    operator aims the range finder at a plate under load."""
    sim = draw.simulation
    lo, hi = nominal.limits.lower + 5e-3, nominal.limits.upper - 5e-3
    parts = []
    for k, mass in enumerate(config.calibration_payloads):
        true_m, nominal_m = (
            with_payload_mass(true, mass),
            with_payload_mass(nominal, mass),
        )
        q_plan = np.clip(
            motor_angles(with_payload_mass(robot, mass), sim.data.q, mass), lo, hi
        )
        if config.readings_in_diagram:
            station = station_config(
                config, bandwidth, InverseDynamicsControllerConfig()
            )
            station.sensors.seed = stream(config.seed, 10 + k)
            run = measure_plates_in_diagram(
                station,
                true_model=true_m,
                plates=sim.plates,
                poses=[q_plan[sim.data.plane == p] for p in range(len(sim.plates))],
                nominal_model=nominal_m,
                reading_noise=config.noise,
                settle_time=config.settle_time,
                speed=config.speed,
            )
            data = run.data
        else:
            q_l = link_angles(true_m, q_plan, mass)
            rng = np.random.default_rng(stream(config.seed, 10 + k))
            d = range_readings(
                true.table, q_l, sim.plates, sim.data.plane, sigma=true.sigma
            )
            d = d + config.noise * rng.standard_normal(d.size)
            hit = np.isfinite(d)  # the beam may miss a plate the arm sags off
            data = PlaneMeasurements(sim.data.plane[hit], q_plan[hit], d[hit])
        parts.append((data, mass))
    return PlaneMeasurements(
        np.concatenate([d.plane for d, _ in parts]),
        np.concatenate([d.q for d, _ in parts]),
        np.concatenate([d.distance for d, _ in parts]),
        payload=np.concatenate([np.full(d.n_readings, m) for d, m in parts]),
    )


def _calibrate(
    nominal: RobotModel,
    data: PlaneMeasurements,
    config: ComplianceStudyConfig,
    echo: Callable[[str], None],
) -> tuple[RobotModel, RobotModel]:
    """(rigid, elastostatic) calibrated models, by LM
    (:func:`~rmdrake.studies.calibration.plate_calibration`). The rigid one is
    the paper's: ``params`` from the readings of the lightest payload (a rigid
    model fitted to readings under several loads is told a contradiction; its
    fit on all of them is reported, not used). The elastostatic one: ``params``
    and every joint's compliance (those the readings cannot see are dropped by
    the identifiability analysis) from all readings. Each is checked against
    the declared reading noise (m)."""
    rigid = plate_calibration(config)[1]
    elastic = dataclasses.replace(rigid, compliance=True)
    unloaded = data.subset(data.payload == data.payload.min())
    fits = {
        "rigid (lightest payload)": make_calibrator(rigid, nominal).fit(unloaded),
        "rigid (all payloads)": make_calibrator(rigid, nominal).fit(data),
        "elastostatic": make_calibrator(elastic, nominal).fit(data),
    }
    for name, est in fits.items():
        check = est.check(noise=rigid.noise)
        verdict = "plausible" if check.ok else "flagged: " + "; ".join(check.reasons)
        echo(f"calibration {name}: {verdict}")
    return fits["rigid (lightest payload)"].model_, fits["elastostatic"].model_


def _link_targets(models, q_nom, targets) -> dict[str, np.ndarray]:
    """Link-side joint targets (K, n) of each variant: the nominal IK (the
    targets' own configurations ``q_nom``), or the full tool poses ``targets``
    solved on the variant's model, seeded there."""
    p, R = targets[:, :3, 3], targets[:, :3, :3]
    out = {"nominal": q_nom}
    for variant in VARIANTS[1:]:
        model = models[_MODEL_OF[variant]]
        out[variant] = correct_targets(model, p, q_seed=q_nom, orientation=R).q
    return out


def _command(variant, models, q_link, mass):
    """Motor-side commands of ``variant`` for its link-side targets: pre-deflected
    at ``mass`` kg by its model's compliances where it has them."""
    model = models[_MODEL_OF[variant]]
    if model.compliance is None:
        return q_link
    return motor_angles(with_payload_mass(model, mass), q_link, mass)


_MODEL_OF = {
    "nominal": "nominal",
    "rigid": "rigid",
    "elastostatic": "elastic",
    "oracle": "true",
}
"""The model each variant plans and pre-deflects with (keys of ``models``)."""


def _attained(true: RobotModel, q_m: np.ndarray, mass: float) -> np.ndarray:
    """(K, 3) tool positions of the true arm at rest with its motors at q_m."""
    q_l = link_angles(with_payload_mass(true, mass), q_m, mass)
    return tool_poses(true.table, q_l, sigma=true.sigma)[:, :3, 3]


def _mm(x: float) -> str:
    return f"{1e3 * x:.3f}"


def run_compliance_study(
    robot: RobotModel,
    config: ComplianceStudyConfig,
    out_dir: str | os.PathLike,
    *,
    echo: Callable[[str], None] = print,
) -> ComplianceStudyResult:
    """Runs the study (module docstring) on ``robot`` (elastic, with a payload
    entry), prints its tables and writes its files into ``out_dir``.

    Raises:
      ValueError: a rigid robot or one without a payload, bad configuration
        values, and what the station and the calibration refuse.
    """
    out = Path(out_dir)
    nominal, true, draw = _truth(robot, config)
    out.mkdir(parents=True, exist_ok=True)
    heaviest = float(max(config.test_payloads))
    home = np.clip(np.zeros(robot.n_joints), robot.limits.lower, robot.limits.upper)
    mode = lowest_structural_mode(with_payload_mass(robot, heaviest), home, heaviest)
    bandwidth = config.bandwidth or 0.25 * mode
    echo(
        f"true robot: {_mm(config.mean_error)} mm mean geometric error; stiffness "
        f"{np.array2string(true.compliance.stiffness, precision=3)} N m/rad; lowest "
        f"structural mode {mode:.1f} rad/s ({mode / 2 / np.pi:.2f} Hz) with "
        f"{heaviest:g} kg, controllers' bandwidth {bandwidth:.2f} rad/s"
    )
    w0 = time.perf_counter()
    data = _readings(robot, nominal, true, draw, config, bandwidth)
    echo(
        f"readings: {data.n_readings} with payloads {config.calibration_payloads} kg "
        f"({'in the Drake station' if config.readings_in_diagram else 'static'}; "
        f"{time.perf_counter() - w0:.0f} s)"
    )
    rigid, elastic = _calibrate(nominal, data, config, echo)
    c_true, c_hat = joint_compliances(true), joint_compliances(elastic)
    k_hat = np.where(c_hat > 0, 1.0 / np.where(c_hat > 0, c_hat, 1.0), np.nan)
    models = {"nominal": nominal, "rigid": rigid, "elastic": elastic, "true": true}
    echo("joint  stiffness true  identified  error")
    for j, (kt, kh) in enumerate(zip(1.0 / c_true, k_hat, strict=True), start=1):
        err = "not seen" if np.isnan(kh) else f"{100 * (kh / kt - 1):+.2f} %"
        echo(f"{j:5d}  {kt:14.4g}  {kh:10.4g}  {err}")
    geometric = {
        name: tool_point_errors(m, true, draw.q_validation).mean
        for name, m in (("rigid", rigid), ("elastostatic", elastic))
    }
    echo(
        "calibrated kinematics (no load), mean tool error: "
        + ", ".join(f"{k} {_mm(v)} mm" for k, v in geometric.items())
    )

    q_nom = held_out_configurations(
        nominal,
        config.n_targets,
        margin=config.target_margin,
        min_singular=config.min_singular,
        seed=stream(config.seed, 8),
    )
    targets = tool_poses(nominal.table, q_nom, sigma=nominal.sigma)
    static: dict[tuple[str, float], np.ndarray] = {}
    q_link = _link_targets(models, q_nom, targets)
    for mass in config.test_payloads:
        for variant in VARIANTS:
            q_m = _command(variant, models, q_link[variant], mass)
            p = _attained(true, q_m, mass)
            static[(variant, mass)] = np.linalg.norm(p - targets[:, :3, 3], axis=1)
    echo(f"static tool error over {config.n_targets} held-out targets, mean (max) mm:")
    echo("payload kg  " + "  ".join(f"{v:>18s}" for v in VARIANTS))
    for mass in config.test_payloads:
        cells = [
            f"{_mm(static[(v, mass)].mean())} ({_mm(static[(v, mass)].max())})"
            for v in VARIANTS
        ]
        echo(f"{mass:10g}  " + "  ".join(f"{c:>18s}" for c in cells))
    q_rest = link_angles(with_payload_mass(true, heaviest), q_nom, heaviest)
    deflection = np.linalg.norm(
        tool_poses(true.table, q_rest, sigma=true.sigma)[:, :3, 3]
        - tool_poses(true.table, q_nom, sigma=true.sigma)[:, :3, 3],
        axis=1,
    )
    echo(
        f"tool deflection under {heaviest:g} kg at the nominal commands: mean "
        f"{_mm(deflection.mean())} mm, max {_mm(deflection.max())} mm"
    )

    diagram: dict[str, np.ndarray] = {}
    gap = 0.0
    k = min(config.diagram_targets, config.n_targets)
    if k > 0:
        for variant in VARIANTS:
            # elastostatic and oracle: the controller pre-deflects online
            q_c = q_link[variant][:k]
            p = drive_variant(config, variant, models, q_c, heaviest, bandwidth)
            diagram[variant] = np.linalg.norm(p - targets[:k, :3, 3], axis=1)
            predicted = static[(variant, heaviest)][:k]
            gap = max(gap, float(np.abs(diagram[variant] - predicted).max()))
        echo(
            f"in the Drake station ({k} targets, {heaviest:g} kg), mean mm: "
            + ", ".join(f"{v} {_mm(e.mean())}" for v, e in diagram.items())
            + f"; largest gap to the static prediction {_mm(gap)} mm"
        )

    path_results: dict[str, PathResult] = {}
    if config.path_length > 0:
        program = insertion_program(nominal, q_nom[0], targets[0], config)
        echo(
            f"insertion: {config.path_length:g} m along the tool axis in "
            f"{program.duration:.1f} s, then {config.path_hold:g} s of hold, "
            f"{heaviest:g} kg"
        )
        echo("variant        path max mm  final mm  oscillation mm  settling s")
        for variant in VARIANTS:
            r = run_path(config, variant, models, program, heaviest, bandwidth)
            path_results[variant] = r
            echo(
                f"{variant:13s} {_mm(r.max_error):>11s}  {_mm(r.final_error):>8s}  "
                f"{_mm(r.oscillation):>14s}  {r.settling_time:10.2f}"
            )
    pickup = None
    if config.path_length > 0:
        pickup = run_pickup(
            config,
            models,
            q_link["elastostatic"][0],
            targets[0, :3, 3],
            heaviest,
            bandwidth,
        )
        echo(
            f"pick-up of {heaviest:g} kg while holding a target: tool error "
            f"{_mm(pickup.before)} mm before, {_mm(pickup.told)} mm after with the "
            f"controller's payload mass updated ({_mm(pickup.untold)} mm left at "
            f"0), peak {_mm(pickup.peak)} mm, settled in {pickup.settling_time:.1f} s"
        )
    result = ComplianceStudyResult(
        true=true,
        rigid=rigid,
        elastic=elastic,
        readings=data.n_readings,
        stiffness=1.0 / c_true,
        stiffness_identified=k_hat,
        static=static,
        deflection=deflection,
        diagram=diagram,
        diagram_gap=gap,
        mode=mode,
        bandwidth=bandwidth,
        path=path_results,
        pickup=pickup,
    )
    q_comp = _command("elastostatic", models, q_link["elastostatic"][0], heaviest)
    result.files = write_files(result, config, out, q_nom[0], q_comp)
    for f in result.files:
        echo(f"wrote {f}")
    return result
