"""Plane-constraint readings taken in the Drake diagram: the true robot is driven
point to point through planned joint configurations, settles at each, and its
range finder, encoders and a tool tracker are read there.

This is the diagram form of :func:`rmdrake.calibration.plates.simulate.simulate_plates`
(which computes readings directly from the kinematics at the planned joint
angles): here the joint angles come from the encoders of a simulated arm that
a servo brought, more or less exactly, to the planned configuration, and the
readings from the :class:`~rmdrake.systems.sensors.RangeFinder` on the
MultibodyPlant.

The run (:func:`measure_plates_in_diagram`):

1. the planned configurations of every plate, plate after plate, become one
   :func:`~rmdrake.systems.station_sources.setpoint_trajectory` from t = 0:
   for each reading a quintic move (by default as short as ``speed`` times the
   joint limits allow, so the moves between plates take longer than those on
   a plate), then a hold of ``settle_time``; the true robot's actuators must
   be able to deliver it (:func:`~rmdrake.systems.station_sources.require_effort`:
   ``motion_effort`` <= 1 on every joint, else ValueError before anything is
   simulated);
2. :func:`~rmdrake.systems.station.MakeStation` builds the station on it, and
   adds one RangeFinder per plate (``range_finder_<p>``, the plate pose and
   the spec as its Context parameters) and a ToolTracker (``tool_tracker``),
   each with its ``AddToBuilder``;
3. a Multiplexer gathers [encoder q (n); distances (P); valid flags (P);
   tracker p_WM (3)] into a Drake ``VectorLogSink`` (``log_readings``, made by
   ``LogVectorOutput``) that publishes on forced publish events only. The run
   advances the Simulator to each hold's end t_i
   (:func:`~rmdrake.systems.station_sources.setpoint_times`; the integrator
   lands exactly on it) and forces the logger's publish there: one sample per
   reading, at a known time, with q, the distances and p_WM of the same state
   at the same instant. Reading i keeps the distance of its own plate's finder.

Whether the arm has settled by t_i is the servo's business: the settle error
``q - q_desired`` is reported, and it does not bias the readings, which are
taken where the arm really is, at the encoder angles. The next move starts at
t_i with zero velocity and acceleration, so the sample sees the hold's end.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Sequence

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.geometry import Meshcat, MeshcatVisualizer
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import (
    ApplySimulatorConfig,
    InitializeParams,
    ResetIntegratorFromFlags,
    Simulator,
    SimulatorConfig,
)
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    OutputPort,
    TriggerType,
)
from pydrake.systems.primitives import (
    Adder,
    Gain,
    LogVectorOutput,
    Multiplexer,
    RandomSource,
    VectorLogSink,
)

from rmdrake.arrays import as_finite_array
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.range_finder import RangeFinderSpec
from rmdrake.calibration.plates.simulate import Plate
from rmdrake.dynamics.joint_log import JointLog
from rmdrake.model.robot import RobotModel
from rmdrake.progress import progress_iter
from rmdrake.systems.sensors import RangeFinder, ToolTracker
from rmdrake.systems.station import MakeStation, Station
from rmdrake.systems.station_config import StationConfig
from rmdrake.systems.station_sources import (
    require_effort,
    setpoint_move_times,
    setpoint_times,
    setpoint_trajectory,
)

__all__ = [
    "MEASUREMENT_V_EPS",
    "AddReadingLogger",
    "MeasurementRun",
    "SimulateReadings",
    "measure_plates_in_diagram",
    "measurement_config",
    "use_integration_scheme",
]

MEASUREMENT_V_EPS = 5e-2
"""Coulomb smoothing width of the true robot in measurement runs, rad/s."""

MEASUREMENT_MAX_STEP = 2e-2
"""Largest integration step of measurement runs, s."""


def measurement_config() -> StationConfig:
    """The default StationConfig of :func:`measure_plates_in_diagram`: the
    station defaults but a Coulomb smoothing width ``v_eps`` of
    :data:`MEASUREMENT_V_EPS` = 0.05 rad/s (3 deg/s) instead of 0.001, and a
    largest step of :data:`MEASUREMENT_MAX_STEP` = 20 ms instead of the log
    period (6.7 ms).

    Why: a hold is the worst case of the smooth Coulomb friction for an explicit
    integrator. At rest it acts as a damper fc / v_eps on the joint inertia J,
    time constant J v_eps / fc (1e-5 s on the RV-3SB wrist at 0.001 rad/s), which
    Runge-Kutta 3 must resolve: on the RV-3SB a hold costs about 30000 steps per
    simulated second at 0.001 rad/s, 3000 at 0.01 and 700 at 0.05 (implicit
    integrators throughout are erratic on the moves; on the holds alone Radau3
    is the faster: ``StationConfig.hold_integration_scheme``). The moves run at rad/s,
    where the friction is at full Coulomb level either way, and the readings
    are taken at rest at the encoder angles, so the smoothing changes how
    the servo settles, not what the sensors read.

    The step: a run read at chosen instants (``joint_log=False``) has no
    150 Hz log events to end its steps, so a heavy arm's slow moves and every
    hold integrated by Radau3 (``StationConfig.hold_integration_scheme``) are
    bounded by the largest step alone. 20 ms is faster than 10 ms with the
    readings the same (to 1.2e-11 rad on demo_rh, whose servo settles to
    3e-10 rad in 0.5 s holds either way, 2e-11 rad on its elastic twin,
    7e-9 rad on the RV-3SB, and the RV-3SB's tracked paths, whose steps error
    control keeps shorter, to 5e-8 m); 50 ms is no faster (error control
    takes over).

    Example:

    >>> from rmdrake.systems import measurement_config
    >>> config = measurement_config()
    >>> config.v_eps, config.simulator.max_step_size
    (0.05, 0.02)
    """
    config = StationConfig(v_eps=MEASUREMENT_V_EPS)
    config.simulator.max_step_size = MEASUREMENT_MAX_STEP
    return config


@dataclasses.dataclass(frozen=True)
class MeasurementRun:
    """Output of :func:`measure_plates_in_diagram`: one entry per planned reading
    (plate after plate, in the order given), N in all.

    Attributes:
      data: the valid readings, ready for calibration: plate ids, encoder
        angles (rad) and distances (m).
      valid: (N,) bool, the range finder's validity flag at each reading.
      plane: (N,) plate id (index into the plates given).
      t: (N,) reading times, s (the ends of the holds).
      q_desired: (N, n) planned joint angles, rad.
      q: (N, n) encoder angles at the readings, rad.
      distance: (N,) readings, m (NaN where invalid, noise included).
      p_WM: (N, 3) tool-tracker positions at the readings, m, in W.
      log: the station's joint log of the whole run (``log_period``), or
        None when run with ``joint_log=False``.
      move_time: (N,) duration of the move before each reading, s.
      settle_time: duration of each hold, s.
      wall_time: wall-clock time of the simulation, s.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_poses
    >>> from rmdrake.calibration.plates.simulate import Plate
    >>> from rmdrake.systems import measure_plates_in_diagram
    >>> robot = load_robot("rv3sb")
    >>> q = np.array([[0.0, 0.3, 1.2, 0.0, 0.5, 0.0]])
    >>> X_BP = tool_poses(robot.table, q)[0] @ np.diag([1.0, -1.0, -1.0, 1.0])
    >>> X_BP[:3, 3] -= 0.03 * X_BP[:3, 2]  # 30 mm along the beam, facing the sensor
    >>> run = measure_plates_in_diagram(
    ...     true_model=robot, plates=[Plate(X_BP)], poses=[q], settle_time=0.2
    ... )
    >>> run.q.shape, run.data.n_readings, run.log is not None
    ((1, 6), 1, True)
    """

    data: PlaneMeasurements
    valid: np.ndarray
    plane: np.ndarray
    t: np.ndarray
    q_desired: np.ndarray
    q: np.ndarray
    distance: np.ndarray
    p_WM: np.ndarray
    log: JointLog | None
    move_time: np.ndarray
    settle_time: float
    wall_time: float

    @property
    def settle_error(self) -> np.ndarray:
        """(n,) largest |q - q_desired| per joint over the readings, rad."""
        return np.abs(self.q - self.q_desired).max(axis=0)


def AddReadingLogger(
    builder: DiagramBuilder, ports: Sequence[OutputPort], name: str = "log_readings"
) -> VectorLogSink:
    """Adds a Multiplexer of the vector ``ports`` (named ``readings``) and a
    Drake ``VectorLogSink`` named ``name`` on it (``LogVectorOutput``) that
    publishes on forced publish events only; returns the sink. A sample is
    the concatenation of the ports' values, in order, at the instant of
    :func:`SimulateReadings`' forced publish."""
    readings = builder.AddNamedSystem(
        "readings", Multiplexer([port.size() for port in ports])
    )
    for i, port in enumerate(ports):
        builder.Connect(port, readings.get_input_port(i))
    logger = LogVectorOutput(readings.get_output_port(), builder, {TriggerType.kForced})
    logger.set_name(name)
    return logger


def SimulateReadings(
    station: Station,
    logger: VectorLogSink,
    t_read: np.ndarray,
    *,
    settle_time: float = 0.0,
    progress: bool = False,
) -> tuple[np.ndarray, Context, float]:
    """Simulates ``station`` from its default Context (time 0 when built by
    :func:`measure_plates_in_diagram`'s config), advancing the Simulator to
    each reading time ``t_read`` (s, increasing; the integrator lands exactly
    on it) and forcing ``logger``'s publish there (a logger from
    :func:`AddReadingLogger`, inside the station). ``settle_time``: s of the
    hold, the arm commanded at rest, that ends at each reading (at most the
    time since the previous one); the holds are integrated with the station
    config's ``hold_integration_scheme`` (unless ""), the moves with its
    ``simulator`` (:func:`use_integration_scheme`), when the station has no
    other logger and no Meshcat: a change of scheme re-initializes the
    Simulator, which would publish again what is due at that instant (a
    periodic log's sample). With a ``settle_time``, the moves are integrated
    at the config's ``move_accuracy`` (unless 0), the holds at the
    simulator's accuracy. ``progress`` shows the readings taken and the time
    left (False: only when the process has been silent for the progress
    interval, :func:`rmdrake.progress.progress_bar`'s ``lazy``).

    Returns:
      (samples (N, k): one row per reading time, the logged vector of the
      state at that instant; the root Context after the run (the station's
      own loggers hold the whole run); the wall-clock time of the simulation
      in s).

    Raises:
      RuntimeError: the log does not hold exactly one sample per reading time.
    """
    context = station.CreateDefaultContext()
    simulator = Simulator(station.diagram, context)
    config = station.config.simulator
    ApplySimulatorConfig(config, simulator)
    move = config.integration_scheme
    hold = station.config.hold_integration_scheme or move
    name = logger.get_name()
    others = [s for s in station.diagram.GetSystems() if s.get_name() != name]
    if any(isinstance(s, (MeshcatVisualizer, VectorLogSink)) for s in others):
        hold = move
    fast = station.config.move_accuracy if settle_time > 0 else 0.0
    moving = (move, fast or config.accuracy)
    holding = (hold, config.accuracy)
    logger_context = logger.GetMyContextFromRoot(context)
    w0 = time.perf_counter()
    simulator.Initialize()
    now = (move, config.accuracy)
    # progress False: still shown when the process has been silent an interval
    for t in progress_iter(t_read, desc="readings in Drake", lazy=not progress):
        for until, wanted in ((t - settle_time, moving), (t, holding)):
            if until > context.get_time():
                integrator = simulator.get_mutable_integrator()
                if wanted[0] != now[0]:
                    use_integration_scheme(simulator, config, *wanted)
                elif wanted[1] != now[1] and not integrator.get_fixed_step_mode():
                    integrator.set_target_accuracy(wanted[1])
                now = wanted
                simulator.AdvanceTo(until)
        logger.ForcedPublish(logger_context)
    wall = time.perf_counter() - w0
    log = logger.FindLog(context)
    if not np.array_equal(log.sample_times(), t_read):
        raise RuntimeError("the reading log does not hold one sample per reading")
    return log.data().T, context, wall


def use_integration_scheme(
    simulator: Simulator,
    config: SimulatorConfig,
    scheme: str,
    accuracy: float | None = None,
) -> None:
    """Replaces an initialized ``simulator``'s integrator, mid-run, by Drake's
    ``scheme`` with ``config``'s largest step, error control and accuracy (as
    ``ApplySimulatorConfig``, which would also reset the Context's time), or
    ``accuracy`` instead; the Context is kept and initialization events do not
    run again."""
    integrator = ResetIntegratorFromFlags(simulator, scheme, config.max_step_size)
    # A scheme without error estimation is in fixed-step mode from the start.
    if not config.use_error_control and not integrator.get_fixed_step_mode():
        integrator.set_fixed_step_mode(True)
    if not integrator.get_fixed_step_mode():
        integrator.set_target_accuracy(
            config.accuracy if accuracy is None else accuracy
        )
    simulator.Initialize(InitializeParams(suppress_initialization_events=True))


def _add_noise(
    builder: DiagramBuilder, port: OutputPort, std: float, period: float
) -> OutputPort:
    """``port + std * w``, w standard normal from a RandomSource, a new sample
    every ``period`` s (systems ``range_noise``, ``range_noise_std``,
    ``noisy_distances``)."""
    size = port.size()
    source = builder.AddNamedSystem(
        "range_noise", RandomSource(RandomDistribution.kGaussian, size, period)
    )
    scale = builder.AddNamedSystem("range_noise_std", Gain(std, size))
    builder.Connect(source.get_output_port(), scale.get_input_port())
    total = builder.AddNamedSystem("noisy_distances", Adder(2, size))
    builder.Connect(port, total.get_input_port(0))
    builder.Connect(scale.get_output_port(), total.get_input_port(1))
    return total.get_output_port()


def measure_plates_in_diagram(
    config: StationConfig | None = None,
    *,
    true_model: RobotModel,
    plates: Sequence[Plate],
    poses: Sequence[np.ndarray],
    nominal_model: RobotModel | None = None,
    spec: RangeFinderSpec | None = None,
    move_time: float | np.ndarray | None = None,
    settle_time: float = 0.5,
    speed: float = 0.5,
    min_move_time: float = 0.2,
    q_start: np.ndarray | None = None,
    reading_noise: float = 0.0,
    p_EM: Sequence[float] = (0.0, 0.0, 0.0),
    tracker_noise: float = 0.0,
    meshcat: Meshcat | None = None,
    progress: bool = False,
    joint_log: bool = True,
) -> MeasurementRun:
    """Simulates a plane-constraint measurement campaign in the station diagram
    (see the module docstring for the run and the timing of the readings).

    Args:
      config: the station's options (default :func:`measurement_config`);
        copied, with the start time set to 0. Its ``sensors`` apply: encoder
        resolution on the recorded q, ``seed`` for every noise of the run.
      true_model: the robot measured (its true kinematics and dynamics).
      plates: the P plates, plate p with id p: pose X_BP (= X_WP) and size.
      poses: for each plate, an (m_p, n) array of joint configurations in rad
        (e.g. planned on the nominal model), visited in order.
      nominal_model: the controller's model (default ``true_model``).
      spec: span and incidence cone of the range finder (plate sizes come from
        ``plates``); default ``RangeFinderSpec()``.
      move_time: s, of every move or (N,) of each; default for each move the
        shortest that keeps it within ``speed`` times the true model's
        velocity and acceleration limits
        (:func:`~rmdrake.systems.station_sources.setpoint_move_times`), at
        least ``min_move_time``.
      min_move_time: s, the shortest default move.
      settle_time: s of each hold before its reading (> 0).
      speed: fraction of the joint limits for the default move_time, in (0, 1].
      q_start: (n,) rad, where the arm starts; default the first pose.
      reading_noise: std of Gaussian noise on the distances, m.
      p_EM: tool-tracker marker offset in the tool frame, m.
      tracker_noise: std of the tool tracker's noise, m.
      meshcat: if given, the robot is drawn there while simulating.
      progress: show the readings taken and the time left.
      joint_log: keep the station's joint log of the whole run
        (``MeasurementRun.log``); False: no log (None), and a faster run (the
        log's 150 Hz publish events bound the integrator's steps); the
        readings then differ by the integration error (4e-8 rad on the RV-3SB
        after 0.5 s holds).

    Returns:
      :class:`MeasurementRun` (data = the valid readings).

    Raises:
      ValueError: poses that do not match the plates or the joint count, bad
        times or noise, a planned motion the true robot's actuators cannot
        deliver (``motion_effort`` > 1 on a joint: the message names it), and
        those of ``MakeStation``.

    Example:

    >>> import numpy as np
    >>> from rmdrake import load_robot, tool_poses
    >>> from rmdrake.calibration.plates.simulate import Plate
    >>> from rmdrake.systems import measure_plates_in_diagram
    >>> robot = load_robot("rv3sb")
    >>> q = np.array([[0.0, 0.3, 1.2, 0.0, 0.5, 0.0]])
    >>> X_BP = tool_poses(robot.table, q)[0] @ np.diag([1.0, -1.0, -1.0, 1.0])
    >>> X_BP[:3, 3] -= 0.03 * X_BP[:3, 2]  # 30 mm along the beam, facing the sensor
    >>> run = measure_plates_in_diagram(
    ...     true_model=robot, plates=[Plate(X_BP)], poses=[q], settle_time=0.2
    ... )
    >>> bool(run.valid.all()), run.distance.round(4).tolist()
    (True, [0.03])
    """
    config = measurement_config() if config is None else copy.deepcopy(config)
    config.simulator.start_time = 0.0
    spec = RangeFinderSpec() if spec is None else spec
    n, P = true_model.n_joints, len(plates)
    if P == 0 or len(poses) != P:
        raise ValueError(
            f"poses: expected one array of joint angles per plate ({P} plates), "
            f"found {len(poses)}"
        )
    arrays = [as_finite_array(q, f"poses[{p}]", (None, n)) for p, q in enumerate(poses)]
    q_plan = np.concatenate(arrays)
    plane = np.repeat(np.arange(P), [a.shape[0] for a in arrays])
    N = q_plan.shape[0]
    if N == 0:
        raise ValueError("poses: expected at least one joint configuration")
    for name, std in (
        ("reading_noise", reading_noise),
        ("tracker_noise", tracker_noise),
    ):
        if not std >= 0:
            raise ValueError(f"{name}: expected a std >= 0 m, found {std}")
    if not 0 < speed <= 1:
        raise ValueError(f"speed: expected a fraction in (0, 1], found {speed}")
    if not settle_time > 0:
        raise ValueError(f"settle_time: expected > 0 s, found {settle_time}")
    if move_time is None:
        limits = true_model.limits
        need = setpoint_move_times(
            q_plan,
            velocity=speed * limits.velocity,
            acceleration=speed * limits.acceleration,
            q_start=q_start,
        )
        move_time = np.maximum(need, min_move_time)
    trajectory = setpoint_trajectory(
        q_plan, move_time=move_time, settle_time=settle_time, q_start=q_start
    )
    require_effort(true_model, trajectory, v_eps=float(config.v_eps))
    t_read = setpoint_times(N, move_time=move_time, settle_time=settle_time)
    moves = np.broadcast_to(np.asarray(move_time, dtype=float), (N,)).copy()
    # Noise held for the shortest interval between readings: a fresh draw each.
    period = float(np.min(np.diff(t_read, prepend=0.0)))

    def add_sensors(
        builder: DiagramBuilder, plant: MultibodyPlant, signals: dict
    ) -> VectorLogSink:
        finders = [
            RangeFinder.AddToBuilder(
                builder,
                plant,
                spec=dataclasses.replace(spec, plate_size=tuple(plate.size)),
                X_WP=RigidTransform(np.asarray(plate.X_BP, dtype=float)),
                name=f"range_finder_{p}",
            )
            for p, plate in enumerate(plates)
        ]
        tracker = ToolTracker.AddToBuilder(
            builder, plant, p_EM=p_EM, noise=tracker_noise, noise_period=period
        )
        parts = {}
        for key in ("distance", "valid"):
            mux = builder.AddNamedSystem(f"{key}s", Multiplexer([1] * P))
            for p, finder in enumerate(finders):
                builder.Connect(finder.GetOutputPort(key), mux.get_input_port(p))
            parts[key] = mux.get_output_port()
        if reading_noise > 0:
            parts["distance"] = _add_noise(
                builder, parts["distance"], reading_noise, period
            )
        ports = [
            signals["q"],
            parts["distance"],
            parts["valid"],
            tracker.get_output_port(),
        ]
        return AddReadingLogger(builder, ports)

    station = MakeStation(
        config,
        true_model=true_model,
        trajectory=trajectory,
        nominal_model=nominal_model,
        meshcat=meshcat,
        add_systems=add_sensors,
        joint_logs=joint_log,
    )
    return _run(station, q_plan, plane, P, t_read, moves, float(settle_time), progress)


def _run(
    station: Station,
    q_plan: np.ndarray,
    plane: np.ndarray,
    P: int,
    t_read: np.ndarray,
    move_time: np.ndarray,
    settle_time: float,
    progress: bool,
) -> MeasurementRun:
    """Simulates ``station``, forcing the reading logger's publish at each
    reading time ``t_read`` (``progress``: shown); unpacks the logs."""
    N, n = q_plan.shape
    samples, context, wall = SimulateReadings(
        station, station.extras, t_read, settle_time=settle_time, progress=progress
    )
    q = samples[:, :n]
    distance = samples[np.arange(N), n + plane]
    valid = samples[np.arange(N), n + P + plane] > 0.5
    p_WM = samples[:, n + 2 * P :]
    # The joint sensors' logs (an elastic robot's station also logs q_link).
    joint_log = None
    if station.loggers:
        signals = ("q", "qd", "qdd", "tau")
        logs = {k: station.loggers[k].FindLog(context) for k in signals}
        joint_log = JointLog(
            t=logs["q"].sample_times(),
            **{key: value.data().T for key, value in logs.items()},
        )
    return MeasurementRun(
        data=PlaneMeasurements(plane[valid], q[valid], distance[valid]),
        valid=valid,
        plane=plane,
        t=t_read,
        q_desired=q_plan,
        q=q,
        distance=distance,
        p_WM=p_WM,
        log=joint_log,
        move_time=move_time,
        settle_time=settle_time,
        wall_time=wall,
    )
