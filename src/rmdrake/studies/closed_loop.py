"""The paper's whole loop on one true robot, in Drake: calibrate, excite,
identify. What it returns (:class:`ClosedLoopModels`) is all a compensating
controller may know; the truth is kept beside it for the oracle.

Per seed (:func:`run_loop`):

1. A true robot: the calibration study's kinematic errors
   (:func:`~rmdrake.studies.calibration.draw_true_robot`) and the dynamics
   perturbed 10-30 % per link
   (:func:`~rmdrake.studies.identification.perturb_dynamics`).
2. LM calibration on ``params`` from plate readings taken in the diagram
   (:func:`~rmdrake.systems.measurement_runs.measure_plates_in_diagram`, poses
   planned on the nominal model), checked against the declared noise and
   physical bounds (a warning if implausible); the calibrated model's tool error on
   held-out joint angles, as the calibration study reports it.
3. An excitation designed by DE on the nominal model (one design, seeded by
   ``identification.design_seed``, for every true robot of the study) runs on
   the true robot in the same station (controller on the nominal model),
   logged with torque noise and encoder quantisation, qdd estimated from qd;
   OLS (projected to physically consistent standard parameters) and physically
   consistent least squares identify it with the station's Coulomb law; each
   identified model's torque error on the log's states (against the true
   model's torques, relative to their RMS) is reported.
"""

from __future__ import annotations

import copy
import dataclasses
import time
import warnings

import numpy as np
from pydrake.systems.framework import Context

from rmdrake.calibration.plates.estimators import make_calibrator
from rmdrake.calibration.validation import ValidationResult, tool_point_errors
from rmdrake.dynamics.identification import identified_model, identify
from rmdrake.dynamics.regressor import regressor, torques
from rmdrake.model.dynamic_parameters import standard_parameters
from rmdrake.model.robot import RobotModel
from rmdrake.studies.calibration import (
    CalibrationDraw,
    draw_true_robot,
    plate_calibration,
)
from rmdrake.studies.identification import (
    design_step,
    estimated_samples,
    perturb_dynamics,
    simulate_log,
)
from rmdrake.studies.scenarios import CompensationStudyConfig, stream
from rmdrake.systems.measurement_runs import (
    AddReadingLogger,
    SimulateReadings,
    measure_plates_in_diagram,
)
from rmdrake.systems.sensors import ToolTracker
from rmdrake.systems.station import MakeStation, Station
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    ControllerConfig,
    StationConfig,
)
from rmdrake.systems.station_sources import (
    require_effort,
    setpoint_times,
    setpoint_trajectory,
)

__all__ = [
    "IDENTIFIED_METHODS",
    "ClosedLoopModels",
    "LoopCalibration",
    "LoopIdentification",
    "LoopRecord",
    "TargetDrive",
    "calibrate_loop",
    "drive_to_targets",
    "identify_loop",
    "join_loop",
    "run_loop",
    "start_at_command",
    "true_robot",
]

IDENTIFIED_METHODS = ("ols", "physical")
"""The identification methods of the loop."""


@dataclasses.dataclass(frozen=True)
class ClosedLoopModels:
    """What the loop knows, and the truth it is compared with.

    Attributes:
      nominal: the nominal robot (programs are planned on it).
      true: the simulated true robot.
      calibrated: the calibrated kinematics (dynamics as nominal).
      identified: method (``ols``, ``physical``) -> the identified robot
        (nominal kinematics, physically consistent standard parameters).
    """

    nominal: RobotModel
    true: RobotModel
    calibrated: RobotModel
    identified: dict[str, RobotModel]


@dataclasses.dataclass(frozen=True)
class LoopRecord:
    """How well the loop learnt the true robot (SI units).

    Attributes:
      model_before, model_after, model_max_after: mean tool error of the
        nominal and mean and max of the calibrated model on held-out poses, m.
      readings: valid plate readings used.
      excitation_cond: cond(A) of the designed excitation.
      torque_error: method -> RMS of (identified - true) model torque over
        the log's states, relative to the RMS true torque.
      wall_time: wall time of the station runs and fits, s.
      excitation_warning: the design's wall-time budget warning (it stopped
        the design), else empty.
    """

    model_before: float
    model_after: float
    model_max_after: float
    readings: int
    excitation_cond: float
    torque_error: dict[str, float]
    wall_time: float
    excitation_warning: str = ""


@dataclasses.dataclass(frozen=True)
class LoopCalibration:
    """Step 2 of the loop on one true robot (:func:`calibrate_loop`).

    Attributes:
      true: the true robot of the seed (step 1).
      calibrated: the calibrated kinematics (dynamics as nominal).
      before, after: held-out tool errors of the nominal and the calibrated
        model (``tool_point_errors``), m.
      readings: valid plate readings used.
      wall_time: of the station run and the fit, s.
    """

    true: RobotModel
    calibrated: RobotModel
    before: ValidationResult
    after: ValidationResult
    readings: int
    wall_time: float


@dataclasses.dataclass(frozen=True)
class LoopIdentification:
    """Step 3 of the loop on one true robot (:func:`identify_loop`).

    Attributes:
      identified: method (``ols``, ``physical``) -> the identified robot.
      excitation_cond: cond(A) of the designed excitation.
      torque_error: method -> relative RMS torque error against the true
        model on the log's states.
      wall_time: of the design, the station run and the fits, s.
      excitation_warning: the design's wall-time budget warning (it stopped
        the design), else empty.
    """

    identified: dict[str, RobotModel]
    excitation_cond: float
    torque_error: dict[str, float]
    wall_time: float
    excitation_warning: str = ""


def true_robot(
    nominal: RobotModel, config: CompensationStudyConfig, seed: int
) -> tuple[RobotModel, CalibrationDraw]:
    """Step 1 of the loop: (the true robot of ``seed``, the calibration
    study's draw it comes from, with its plates and held-out poses)."""
    draw = draw_true_robot(nominal, config, seed)
    true = perturb_dynamics(draw.true, stream(seed, 1), name=f"{nominal.name}_true")
    return true, draw


def _seeded_station(config: CompensationStudyConfig, seed: int) -> StationConfig:
    station = copy.deepcopy(config.station)
    station.sensors.seed = int(seed)
    return station


def calibrate_loop(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    seed: int,
    *,
    progress: bool = True,
) -> LoopCalibration:
    """Steps 1-2 of the loop (module docstring) on the true robot of
    ``seed``, in ``config.station`` with its sensors seeded by ``seed``, the
    calibration settings read by :func:`~rmdrake.studies.calibration.
    plate_calibration`; ``progress`` shows the readings taken. Independent of
    :func:`identify_loop` (a task of its own)."""
    w0 = time.perf_counter()
    station = _seeded_station(config, seed)
    fit = plate_calibration(config)
    true, draw = true_robot(nominal, config, seed)
    sim = draw.simulation
    # Poses planned on a joint limit are pulled 5 mrad (5 mm on a slide) inside
    # it: the servo overshoots by ~1 mrad, and a reading beyond a limit is
    # flagged.
    lo, hi = nominal.limits.lower + 5e-3, nominal.limits.upper - 5e-3
    q_plan = np.clip(sim.data.q, lo, hi)
    poses = [q_plan[sim.data.plane == p] for p in range(len(sim.plates))]
    run = measure_plates_in_diagram(
        station,
        true_model=true,
        plates=sim.plates,
        poses=poses,
        nominal_model=nominal,
        reading_noise=config.noise,
        settle_time=config.calibration_settle_time,
        progress=progress,
        speed=config.speed,
        joint_log=False,
    )
    est = make_calibrator(fit, nominal).fit(run.data)
    sanity = est.sanity_  # against the range finder's declared noise (fit.noise)
    if not sanity.ok:
        warnings.warn(
            f"seed {seed}: the calibration is implausible: "
            + "; ".join(sanity.reasons),
            stacklevel=2,
        )
    align = bool(set(draw.names) - set(est.names_))
    before = tool_point_errors(nominal, true, draw.q_validation)
    after = tool_point_errors(est.model_, true, draw.q_validation, align=align)
    return LoopCalibration(
        true,
        est.model_,
        before,
        after,
        int(run.data.q.shape[0]),
        time.perf_counter() - w0,
    )


def identify_loop(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    seed: int,
    *,
    progress: bool = True,
) -> LoopIdentification:
    """Step 3 of the loop (module docstring) with ``config.identification``
    on the true robot of ``seed`` (:func:`true_robot`), in ``config.station``
    with its sensors seeded by ``seed``; ``progress`` shows the simulated
    seconds of the excitation run and the generations of its design.
    Independent of :func:`calibrate_loop`."""
    w0 = time.perf_counter()
    station = _seeded_station(config, seed)
    true, _ = true_robot(nominal, config, seed)
    ident = config.identification
    design = design_step(nominal, ident, progress=progress)
    traj = design.trajectory
    t, q, qd, qdd = traj.sample(1.0 / station.log_period)
    width = float(station.v_eps)
    peak = np.abs(
        torques(nominal, q, qd, qdd, standard_parameters(nominal), coulomb_width=width)
    ).max(axis=0)
    log = simulate_log(
        station,
        true,
        nominal,
        traj,
        torque_noise=ident.noise * peak,
        encoder_resolution=ident.encoder_resolution,
        seed=stream(seed, 5),
        periods=ident.periods,
        progress=progress,
    )
    samples = estimated_samples(log, ident.derivative_cutoff)
    tau_true = torques(
        true, log.q, log.qd, log.qdd, standard_parameters(true), coulomb_width=width
    )
    rms_true = np.sqrt(np.mean(tau_true**2))
    # The identified models share the nominal kinematics: one regressor.
    Y = regressor(nominal, log.q, log.qd, log.qdd, coulomb_width=width)
    models, errors = {}, {}
    for method in IDENTIFIED_METHODS:
        r = identify(nominal, samples, method=method, coulomb_width=width)
        models[method] = identified_model(nominal, r, notes={"study": "closed loop"})
        tau = Y @ standard_parameters(models[method])
        errors[method] = float(np.sqrt(np.mean((tau - tau_true) ** 2)) / rms_true)
    return LoopIdentification(
        models,
        float(design.cond),
        errors,
        time.perf_counter() - w0,
        design.result.budget_warning,
    )


def start_at_command(
    station: Station, context: Context, *, payload_mass: float | None = None
) -> None:
    """Puts the station's plant where its controller aims at the context's
    time (the corrected or pre-deflected start): a forced discrete update
    first solves an online correction, then
    :meth:`~rmdrake.systems.station.Station.SetInitialState` at the
    controller's ``commanded_state`` (``payload_mass``: as there)."""
    station.diagram.ExecuteForcedEvents(context, publish=False)
    controller = station.diagram.GetSubsystemByName("controller")
    x_c = controller.GetOutputPort("commanded_state").Eval(
        controller.GetMyContextFromRoot(context)
    )
    station.SetInitialState(context, x_c, payload_mass=payload_mass)


def run_loop(
    nominal: RobotModel,
    config: CompensationStudyConfig,
    seed: int,
    *,
    progress: bool = True,
) -> tuple[ClosedLoopModels, LoopRecord]:
    """Runs the loop for ``seed`` (see the module docstring) in
    ``config.station`` with its sensors seeded by ``seed``: :func:`calibrate_loop`
    and :func:`identify_loop`, joined by :func:`join_loop`; ``progress`` shows
    its station runs' progress (off in a task on a worker)."""
    return join_loop(
        nominal,
        calibrate_loop(nominal, config, seed, progress=progress),
        identify_loop(nominal, config, seed, progress=progress),
    )


def join_loop(
    nominal: RobotModel,
    calibration: LoopCalibration,
    identification: LoopIdentification,
) -> tuple[ClosedLoopModels, LoopRecord]:
    """The loop's models and record from its two independent halves of one
    seed (their wall times added)."""
    models = ClosedLoopModels(
        nominal, calibration.true, calibration.calibrated, identification.identified
    )
    record = LoopRecord(
        model_before=float(calibration.before.mean),
        model_after=float(calibration.after.mean),
        model_max_after=float(calibration.after.max),
        readings=calibration.readings,
        excitation_cond=identification.excitation_cond,
        torque_error=identification.torque_error,
        wall_time=calibration.wall_time + identification.wall_time,
        excitation_warning=identification.excitation_warning,
    )
    return models, record


@dataclasses.dataclass(frozen=True)
class TargetDrive:
    """Joint targets driven to one after another, each held before it is read
    (:func:`drive_to_targets`; the program is
    :func:`~rmdrake.systems.station_sources.setpoint_trajectory`'s).

    Attributes:
      q: (K, n) joint targets, rad or m.
      move_time: duration of each move, s: (K,) or one for all.
      settle_time: hold at each target before its reading, s.
      q_start: (n,) where the program starts, rad or m.

    Example: ``TargetDrive(q, move_time=2.0, settle_time=0.5, q_start=q[0])``.
    """

    q: np.ndarray
    move_time: np.ndarray | float
    settle_time: float
    q_start: np.ndarray


def drive_to_targets(
    config: StationConfig,
    drive: TargetDrive,
    *,
    true_model: RobotModel,
    nominal_model: RobotModel,
    identified_model: RobotModel | None = None,
    calibrated_model: RobotModel | None = None,
    controller: ControllerConfig | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Drives the true robot through the joint targets of ``drive`` in the
    station (controller on ``nominal_model``) and reads the encoders and a
    ToolTracker at the end of each hold (forced publish at the hold's end, as
    the measurement runs do).

    With ``identified_model``, the controller is a
    ``CompensationControllerConfig`` without online correction (the targets
    are corrected already) on its dynamics and friction. ``controller`` (a
    controller config) replaces the station's controller instead, with
    ``calibrated_model`` and ``identified_model`` passed to the station (e.g.
    a compensation controller pre-deflecting an elastic arm).

    Example::

        drive = TargetDrive(q, move_time=2.0, settle_time=0.5, q_start=q[0])
        q_read, p_WM, wall = drive_to_targets(
            measurement_config(), drive, true_model=true, nominal_model=nominal
        )

    Returns:
      (q (K, n) encoder positions, rad or m; p_WM (K, 3) attained tool
      positions, m, in W = B; wall-clock time of the simulation, s).

    Raises:
      ValueError: before anything is simulated, when the true robot's
        actuators cannot deliver the planned moves (``require_effort``: the
        joint that gives way is named), as the measurement runs refuse them.
    """
    config = copy.deepcopy(config)
    config.simulator.start_time = 0.0
    if controller is not None:
        config.controller = copy.deepcopy(controller)
    elif identified_model is not None:
        config.controller = CompensationControllerConfig(
            bandwidth=config.controller.bandwidth, kinematic_correction=False
        )
    n = true_model.n_joints
    move_time, settle_time = drive.move_time, drive.settle_time
    trajectory = setpoint_trajectory(
        drive.q, move_time=move_time, settle_time=settle_time, q_start=drive.q_start
    )
    require_effort(true_model, trajectory, v_eps=float(config.v_eps))
    t_read = setpoint_times(len(drive.q), move_time=move_time, settle_time=settle_time)

    def add_tracker(builder, plant, signals):
        tracker = ToolTracker.AddToBuilder(builder, plant)
        return AddReadingLogger(builder, [signals["q"], tracker.get_output_port()])

    station = MakeStation(
        config,
        true_model=true_model,
        trajectory=trajectory,
        nominal_model=nominal_model,
        identified_model=identified_model,
        calibrated_model=calibrated_model,
        add_systems=add_tracker,
        joint_logs=False,
    )
    samples, _, wall = SimulateReadings(
        station, station.extras, t_read, settle_time=settle_time
    )
    return samples[:, :n], samples[:, n:], wall
