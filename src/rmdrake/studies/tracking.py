"""Path tracking in closed loop: what each compensation layer buys.

The true robot in the Drake station runs a Cartesian path (a circle and a
rounded rectangle, :mod:`rmdrake.compensation.paths`) planned on the NOMINAL model, at
several speeds and two feedback bandwidths, under seven controllers that
differ in what they know (:data:`TRACKING_VARIANTS`):

========================  ==========  ===================  ==================
variant                   kinematics  inverse dynamics     friction feedfwd
========================  ==========  ===================  ==================
``nominal``               nominal     nominal              nominal
``kinematic``             calibrated  nominal              nominal
``dynamics_ols``          calibrated  identified (OLS)     nominal
``dynamics_physical``     calibrated  identified (phys.)   nominal
``friction``              calibrated  nominal              identified
``full``                  calibrated  identified (phys.)   identified
``oracle``                true        true                 true
========================  ==========  ===================  ==================

The dynamic layers are added in both orders (inertial parameters, then
friction; friction, then inertial parameters), since what one buys depends on
whether the other's error still dominates.

"calibrated" kinematics: the program is corrected online inside the
controller (:class:`~rmdrake.systems.correction.JointTargetCorrection`'s
rule, its updates solved ahead of the run: the program is known,
:class:`~rmdrake.systems.correction.PresolvedTargetCorrection`); the
OLS model is the physically consistent projection of the OLS base
parameters. Each run logs the true tool position p_WM (a ToolTracker, W = B)
and the controller's commanded joint positions q_c at the station's log period;
the tool path error is |p_WM(t) - p*(t)| against the path's own point at the
same instant, the joint tracking error |q(t) - q_c(t)|, both over [0, T].
The run starts with the plant at the controller's commanded state at t = 0.

The tracking runs of one true robot are steps, each returning a small frozen
dataclass: :func:`setup_step` (:class:`PathSetup`), per path and speed
:func:`plan_step` (a :class:`~rmdrake.compensation.paths.JointPathProgram`),
per bandwidth :func:`track_step` (:class:`VariantRuns`, each a :class:`PathRun` of
:func:`track_path`), :func:`errors_step` (:class:`PathErrors`) and, at the
fastest speed and softest gains, :func:`panel_step` (:class:`TrackingPanel`);
:func:`summarise_tracking` gathers them into a :class:`TrackingResult`, and the
writer :func:`write_tracking_files` writes the figure and the scene. One
(path, speed, bandwidth) cell of the grid (:func:`tracking_cells`), from its
plan to its errors, is :func:`track_program` (:class:`TrackedProgram`): the
closed-loop study runs each as a task, then :func:`tracking_result`.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.primitives import LogVectorOutput

from rmdrake.compensation.paths import (
    JointPathProgram,
    PlanarPath,
    min_jerk,
    plan_path_program,
)
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.robot import RobotModel
from rmdrake.report.plots import magnification, plot_path_tracking
from rmdrake.report.tables import target_check
from rmdrake.studies.closed_loop import ClosedLoopModels, start_at_command
from rmdrake.studies.scenarios import CompensationStudyConfig, TrackingStudyConfig
from rmdrake.systems.sensors import ToolTracker
from rmdrake.systems.station import MakeStation, simulation_progress
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    InverseDynamicsControllerConfig,
    StationConfig,
)
from rmdrake.systems.visualization import save_path_html

__all__ = [
    "TRACKING_VARIANTS",
    "PathErrors",
    "PathRun",
    "PathSetup",
    "TrackedProgram",
    "TrackingPanel",
    "TrackingResult",
    "VariantRuns",
    "controller_config",
    "errors_step",
    "panel_step",
    "plan_step",
    "setup_step",
    "showcase_cell",
    "summarise_tracking",
    "track_path",
    "track_program",
    "track_step",
    "tracking_cells",
    "tracking_result",
    "variant_models",
    "write_tracking_files",
]

TRACKING_VARIANTS = (
    "nominal",
    "kinematic",
    "dynamics_ols",
    "dynamics_physical",
    "friction",
    "full",
    "oracle",
)
"""The controllers compared (see the module docstring; ``oracle``: everything
true)."""
_FULL = TRACKING_VARIANTS.index("full")

TRACKING_LABELS = {
    "nominal": "nominal",
    "kinematic": "+ kinematic correction",
    "dynamics_ols": "+ identified dynamics (OLS)",
    "dynamics_physical": "+ identified dynamics (physical)",
    "friction": "+ identified friction only",
    "full": "full compensation",
    "oracle": "oracle (true models)",
}

_LAYERS = {
    "kinematic": {"identified_dynamics": False, "identified_friction": False},
    "dynamics_ols": {"identified_friction": False},
    "dynamics_physical": {"identified_friction": False},
    "friction": {"identified_dynamics": False},
    "full": {},
    "oracle": {},
}


def variant_models(
    models: ClosedLoopModels, variant: str
) -> tuple[RobotModel | None, RobotModel | None]:
    """(calibrated, identified) models ``variant``'s controller gets."""
    if variant == "nominal":
        return None, None
    if variant == "oracle":
        return models.true, models.true
    method = "ols" if variant == "dynamics_ols" else "physical"
    identified = None if variant == "kinematic" else models.identified[method]
    return models.calibrated, identified


@dataclasses.dataclass(frozen=True)
class PathRun:
    """One closed-loop run along a path (SI units, B = W).

    Attributes:
      t: (K,) log times in [0, T], s.
      p_WM: (K, 3) attained tool positions, m.
      p_target: (K, 3) the path's points at t, m.
      q, q_c: (K, n) measured and commanded joint positions, rad or m.
      wall_time: wall-clock time of the simulation, s.
    """

    t: np.ndarray
    p_WM: np.ndarray
    p_target: np.ndarray
    q: np.ndarray
    q_c: np.ndarray
    wall_time: float

    @property
    def tool_error(self) -> np.ndarray:
        """(K,) |p_WM - p_target|, m."""
        return np.linalg.norm(self.p_WM - self.p_target, axis=1)

    @property
    def tool_rms(self) -> float:
        """RMS tool path error, m."""
        return float(np.sqrt(np.mean(self.tool_error**2)))

    @property
    def joint_rms(self) -> float:
        """Largest over the joints of the RMS of q - q_c, rad (or m)."""
        return float(np.sqrt(np.mean((self.q - self.q_c) ** 2, axis=0)).max())


def controller_config(
    variant: str, bandwidth: float, *, correction_ahead: bool = True
) -> InverseDynamicsControllerConfig | CompensationControllerConfig:
    """The station controller of ``variant`` with feedback ``bandwidth`` rad/s
    (``correction_ahead``: as ``CompensationControllerConfig``'s)."""
    if variant not in TRACKING_VARIANTS:
        raise ValueError(
            f"variant: expected one of {', '.join(TRACKING_VARIANTS)}, "
            f"found {variant!r}"
        )
    if variant == "nominal":
        return InverseDynamicsControllerConfig(bandwidth=bandwidth)
    return CompensationControllerConfig(
        bandwidth=bandwidth, correction_ahead=correction_ahead, **_LAYERS[variant]
    )


def track_path(
    config: StationConfig,
    program: JointPathProgram,
    models: ClosedLoopModels,
    variant: str,
    *,
    bandwidth: float,
    meshcat: Meshcat | None = None,
    correction_ahead: bool = True,
) -> PathRun:
    """Runs ``program`` on the true robot under ``variant``'s controller (see
    the module docstring); ``config`` gives the station (its controller is
    replaced), ``meshcat`` draws the robot while it runs;
    ``correction_ahead`` False solves the online correction in the
    simulation's steps instead of ahead (the same motion, slower)."""
    config = copy.deepcopy(config)
    config.simulator.start_time = 0.0
    config.controller = controller_config(
        variant, bandwidth, correction_ahead=correction_ahead
    )
    if meshcat is not None:
        config.simulator.target_realtime_rate = 1.0  # watchable live
    calibrated, identified = variant_models(models, variant)
    period = config.log_period

    def add_loggers(builder, plant, signals):
        tracker = ToolTracker.AddToBuilder(builder, plant)
        controller = builder.GetSubsystemByName("controller")
        return [
            LogVectorOutput(port, builder, period)
            for port in (
                tracker.get_output_port(),
                controller.GetOutputPort("commanded_state"),
                signals["q"],
            )
        ]

    station = MakeStation(
        config,
        true_model=models.true,
        trajectory=program.trajectory,
        nominal_model=models.nominal,
        calibrated_model=calibrated,
        identified_model=identified,
        meshcat=meshcat,
        add_systems=add_loggers,
        joint_logs=False,
    )
    context = station.CreateDefaultContext()
    start_at_command(station, context)  # the corrected start, for a correction
    simulator = Simulator(station.diagram, context)
    ApplySimulatorConfig(config.simulator, simulator)
    w0 = time.perf_counter()
    with simulation_progress(simulator, program.duration):
        simulator.Initialize()
        simulator.AdvanceTo(program.duration)
    wall = time.perf_counter() - w0
    logs = [logger.FindLog(context) for logger in station.extras]
    t = logs[0].sample_times()
    n = models.true.n_joints
    p_WM, x_c, q = (log.data().T for log in logs)
    return PathRun(
        t=t,
        p_WM=p_WM,
        p_target=program.tool_points(t),
        q=q,
        q_c=x_c[:, :n],
        wall_time=wall,
    )


@dataclasses.dataclass
class TrackingResult:
    """Path tracking on one true robot (SI units).

    Attributes:
      seed: the scenario seed.
      paths, speeds, bandwidths: the runs' axes (bandwidths in rad/s).
      duration, peak_tool_speed: (P, S) of each planned program, s and m/s.
      tool_rms, tool_max, joint_rms: (P, S, B, V) for V = the variants, m
        and rad or m (joint: the largest per-joint RMS of q - q_c).
      wall_time: of all the runs, s.
      files: the figure and the Meshcat scene written.
    """

    seed: int
    paths: list[str]
    speeds: list[float]
    bandwidths: list[float]
    duration: np.ndarray
    peak_tool_speed: np.ndarray
    tool_rms: np.ndarray
    tool_max: np.ndarray
    joint_rms: np.ndarray
    wall_time: float = 0.0
    files: list[Path] = dataclasses.field(default_factory=list)

    def _ratio(self, p: int, a: str, b: str) -> float:
        """tool RMS of a / of b on path p, fastest speed, softest gains."""
        rms = self._soft_fastest_rms(p)
        return rms[a] / rms[b]

    def _soft_fastest_rms(self, p: int) -> dict[str, float]:
        """variant -> tool RMS on path p at the fastest speed, softest gains, mm."""
        rms = self.tool_rms[p, -1, int(np.argmin(self.bandwidths))]
        return {v: float(rms[i]) * 1e3 for i, v in enumerate(TRACKING_VARIANTS)}

    def _stiff_full_rms(self, p: int) -> float:
        """The full compensation's tool RMS on path p at the fastest speed and
        stiffest gains, mm."""
        return float(self.tool_rms[p, -1, int(np.argmax(self.bandwidths)), _FULL] * 1e3)

    def full_over_floor(self, p: int) -> float:
        """The full compensation's tool RMS on path p at the fastest speed and
        softest gains over its floor (the study's target: <= 2)."""
        return self._soft_fastest_rms(p)["full"] / self._floor(p)

    def _floor(self, p: int) -> float:
        """The floor of the full compensation's tool RMS on path p at the
        fastest speed and softest gains, mm: the larger of the oracle's RMS
        there and the full compensation's at the stiffest gains (where the
        feedback removes the dynamic error and the calibrated kinematics' own
        error on the path is what remains: no dynamics model can go below it).
        With one bandwidth the floor is the oracle alone."""
        oracle = self._soft_fastest_rms(p)["oracle"]
        if len(set(self.bandwidths)) < 2:
            return oracle
        return max(oracle, self._stiff_full_rms(p))

    def _dynamics_gap(self, p: int, rms: dict[str, float]) -> str:
        """The target on what the identified dynamics leave: the full
        compensation's RMS at the fastest speed and softest gains within 2x of
        its floor (:meth:`full_over_floor`)."""
        floor, ratio = self._floor(p), self.full_over_floor(p)
        if len(set(self.bandwidths)) < 2:
            return target_check(
                "full / oracle =",
                ratio,
                "<=",
                2,
                reason=f"RMS full compensation {rms['full']:.4f} mm, oracle "
                f"{rms['oracle']:.4f} mm: the oracle has the true models, the full "
                "compensation this run's calibrated and identified ones",
            )
        stiff = self._stiff_full_rms(p)
        return target_check(
            f"full / floor ({floor:.4f} mm) =",
            ratio,
            "<=",
            2,
            reason=f"RMS full compensation {rms['full']:.4f} mm; floor "
            f"{floor:.4f} mm = max(oracle {rms['oracle']:.4f} mm, full compensation "
            f"at {max(self.bandwidths):g} rad/s {stiff:.4f} mm: the calibrated "
            "kinematics' own error on this path)",
        )

    def table(self) -> str:
        """RMS (max) tool path error per variant, speed and bandwidth in mm;
        what each layer buys; the study's pass checks."""
        mm = 1e3
        lines = [f"path tracking, seed {self.seed}: RMS (max) tool path error [mm]"]
        for p, kind in enumerate(self.paths):
            for b, w in enumerate(self.bandwidths):
                heads = "".join(
                    f"  {f'{s:g} ({self.duration[p, i]:.2f} s)':>19}"
                    for i, s in enumerate(self.speeds)
                )
                lines += ["", f"{kind}, bandwidth {w:g} rad/s, speed (T): {heads}"]
                for v, variant in enumerate(TRACKING_VARIANTS):
                    cells = "".join(
                        f"  {self.tool_rms[p, i, b, v] * mm:8.4f} "
                        f"({self.tool_max[p, i, b, v] * mm:8.4f})"
                        for i in range(len(self.speeds))
                    )
                    lines.append(f"  {TRACKING_LABELS[variant]:<34}{cells}")
        lines.append("")
        for p, kind in enumerate(self.paths):
            r = functools.partial(self._ratio, p)
            steps = (
                f"kinematic correction x{r('nominal', 'kinematic'):.3g}; then "
                f"inertial parameters x{r('kinematic', 'dynamics_physical'):.3g} "
                f"and friction x{r('dynamics_physical', 'full'):.3g}, or friction "
                f"x{r('kinematic', 'friction'):.3g} and inertial parameters "
                f"x{r('friction', 'full'):.3g}"
            )
            rms = self._soft_fastest_rms(p)
            reduction = target_check(
                "nominal / full =",
                r("nominal", "full"),
                ">=",
                10,
                reason=f"RMS nominal {rms['nominal']:.4f} mm, full compensation "
                f"{rms['full']:.4f} mm",
            )
            gap = self._dynamics_gap(p, rms)
            lines += [
                f"{kind}, fastest speed, softest gains, RMS reduction by {steps}",
                f"  targets: {reduction}; {gap}",
            ]
        return "\n".join(lines)


def _plane_frame(normal: object) -> np.ndarray:
    """R_BP with z along ``normal`` and x along base y x normal (or base x
    when the normal is along base y)."""
    z = np.asarray(normal, dtype=float)
    if z.shape != (3,) or not np.isfinite(z).all() or np.linalg.norm(z) == 0:
        raise ValueError(f"tracking.normal: expected a nonzero 3-vector, found {z}")
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0], z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0, 0])
    return np.column_stack([x, np.cross(z, x), z])


def _save_html(
    models: ClosedLoopModels,
    runs: dict[str, PathRun],
    path: Path,
    meshcat: Meshcat | None = None,
) -> Path:
    """The true robot following the full-compensation run, with the commanded
    path (grey) and the nominal (red) and full-compensation (green) attained
    paths, their deviations magnified (the factor is in the lines' names; the
    green one covers the grey where the compensation holds the path)."""
    full, nominal = runs["full"], runs["nominal"]
    x = magnification(np.ptp(full.p_target, axis=0).max(), nominal.tool_error.max())
    lines = {"commanded": (full.p_target, (0.5, 0.5, 0.5, 1.0))}
    for name, run, rgba in (
        ("nominal", nominal, (0.85, 0.1, 0.1, 1.0)),
        ("full_compensation", full, (0.1, 0.7, 0.1, 1.0)),
    ):
        points = run.p_target + x * (run.p_WM - run.p_target)
        lines[f"{name}_deviation_x{x:g}"] = (points, rgba)
    return save_path_html(models.true, full.t, full.q, lines, path, meshcat=meshcat)


@dataclasses.dataclass(frozen=True)
class PathSetup:
    """Where one true robot's paths run (:func:`setup_step`; B = W).

    Attributes:
      q_cube: (n,) joint positions the programs are planned from
        (``cube_q``), rad or m.
      p_BC: (3,) the paths' centre C, the nominal tool position at q_cube, m.
      R_BE: (3, 3) the tool orientation held along the paths (the nominal
        one at q_cube).
      R_BP: (3, 3) the path plane's frame P (z along ``tracking.normal``).
    """

    q_cube: np.ndarray
    p_BC: np.ndarray
    R_BE: np.ndarray
    R_BP: np.ndarray


@dataclasses.dataclass(frozen=True)
class VariantRuns:
    """Every variant's run of one program at one feedback bandwidth
    (:func:`track_step`).

    Attributes:
      bandwidth: rad/s.
      runs: variant -> its run, in :data:`TRACKING_VARIANTS` order.
    """

    bandwidth: float
    runs: dict[str, PathRun]


@dataclasses.dataclass(frozen=True)
class PathErrors:
    """How the variants tracked one program at one bandwidth
    (:func:`errors_step`), in :data:`TRACKING_VARIANTS` order.

    Attributes:
      tool_rms, tool_max: (V,) RMS and max of |p_WM - p*| (W = B), m.
      joint_rms: (V,) the largest per-joint RMS of q - q_c, rad or m.
      wall_time: (V,) wall-clock time of each run, s.
    """

    tool_rms: np.ndarray
    tool_max: np.ndarray
    joint_rms: np.ndarray
    wall_time: np.ndarray


@dataclasses.dataclass(frozen=True)
class TrackingPanel:
    """One column of the tracking figure (:func:`panel_step`).

    Attributes:
      title: the path, its peak tool speed (m/s) and the bandwidth (rad/s).
      u: (K,) fraction of the path done at each log time.
      target: (K, 3) the commanded points p* in the path's frame P, about C, m.
      attained: variant label -> (K, 3) its attained points p_WM in P, about
        C, m.
    """

    title: str
    u: np.ndarray
    target: np.ndarray
    attained: dict[str, np.ndarray]


def setup_step(nominal: RobotModel, config: CompensationStudyConfig) -> PathSetup:
    """The paths' centre and tool orientation, the nominal tool pose X_BE at
    ``config.cube_q``, and the plane's frame of ``config.tracking.normal``.

    Raises:
      ValueError: a normal that is not a nonzero 3-vector.
    """
    q_cube = np.asarray(config.cube_q, dtype=float)
    X = tool_poses(nominal.table, q_cube[None], sigma=nominal.sigma)[0]
    R_BP = _plane_frame(config.tracking.normal)
    return PathSetup(q_cube, X[:3, 3], X[:3, :3], R_BP)


def plan_step(
    nominal: RobotModel,
    setup: PathSetup,
    tracking: TrackingStudyConfig,
    kind: str,
    speed: float,
) -> JointPathProgram:
    """The joint program of the path ``kind`` (``tracking.size`` m, centred at
    C in the plane P), planned on the nominal model with R_BE held, as fast
    as ``speed`` times the joint velocity and acceleration limits allow."""
    path = PlanarPath(kind, setup.p_BC, setup.R_BP, tracking.size)
    return plan_path_program(
        nominal, path, setup.R_BE, q_seed=setup.q_cube, speed=speed
    )


def track_step(
    config: StationConfig,
    program: JointPathProgram,
    models: ClosedLoopModels,
    *,
    bandwidth: float,
    meshcat: Meshcat | None = None,
) -> VariantRuns:
    """Runs ``program`` under each variant's controller with feedback
    ``bandwidth`` rad/s (:func:`track_path`); ``meshcat`` draws the
    full-compensation run live."""
    runs = {}
    for variant in TRACKING_VARIANTS:
        live = meshcat if variant == "full" else None
        runs[variant] = track_path(
            config, program, models, variant, bandwidth=bandwidth, meshcat=live
        )
    return VariantRuns(bandwidth, runs)


def errors_step(runs: VariantRuns) -> PathErrors:
    """The tool path errors (m) and joint tracking errors (rad or m) of each
    variant's run."""
    done = [runs.runs[v] for v in TRACKING_VARIANTS]
    return PathErrors(
        tool_rms=np.array([r.tool_rms for r in done]),
        tool_max=np.array([r.tool_error.max() for r in done]),
        joint_rms=np.array([r.joint_rms for r in done]),
        wall_time=np.array([r.wall_time for r in done]),
    )


def panel_step(
    kind: str, program: JointPathProgram, runs: VariantRuns, setup: PathSetup
) -> TrackingPanel:
    """The commanded and attained tool points of ``runs`` in the path's frame
    P about its centre C (p_PM = R_BP^T (p_WM - p_BC), m), against the
    fraction of the path done."""
    plane = {v: (r.p_WM - setup.p_BC) @ setup.R_BP for v, r in runs.runs.items()}
    nominal = runs.runs["nominal"]
    return TrackingPanel(
        title=(
            f"{kind}, {program.peak_tool_speed:.2f} m/s peak, {runs.bandwidth:g} rad/s"
        ),
        u=min_jerk(nominal.t / program.duration),
        target=(nominal.p_target - setup.p_BC) @ setup.R_BP,
        attained={TRACKING_LABELS[v]: x for v, x in plane.items()},
    )


def summarise_tracking(
    seed: int,
    tracking: TrackingStudyConfig,
    programs: dict[tuple[int, int], JointPathProgram | TrackedProgram],
    errors: dict[tuple[int, int, int], PathErrors],
) -> TrackingResult:
    """The runs' errors on the (path, speed, bandwidth, variant) grid as a
    :class:`TrackingResult` (no files yet): ``programs`` (their ``duration``,
    s, and ``peak_tool_speed``, m/s) by (path, speed) index, ``errors`` by
    (path, speed, bandwidth) index in the order run."""
    P, S, B, V = (
        len(tracking.paths), len(tracking.speeds), len(tracking.bandwidths),
        len(TRACKING_VARIANTS),
    )  # fmt: skip
    shape = (P, S, B, V)
    result = TrackingResult(
        seed, list(tracking.paths), list(tracking.speeds),
        list(tracking.bandwidths), np.zeros((P, S)), np.zeros((P, S)),
        np.zeros(shape), np.zeros(shape), np.zeros(shape),
    )  # fmt: skip
    for (p, i), program in programs.items():
        result.duration[p, i] = program.duration
        result.peak_tool_speed[p, i] = program.peak_tool_speed
    for (p, i, b), e in errors.items():
        result.tool_rms[p, i, b] = e.tool_rms
        result.tool_max[p, i, b] = e.tool_max
        result.joint_rms[p, i, b] = e.joint_rms
        for wall in e.wall_time:
            result.wall_time += float(wall)
    return result


def write_tracking_files(
    out: Path,
    models: ClosedLoopModels,
    seed: int,
    panels: list[TrackingPanel],
    shown: VariantRuns | None,
    *,
    html: bool,
    meshcat: Meshcat | None = None,
    echo: Callable[[str], None] = print,
) -> list[Path]:
    """The writer: ``tracking_seed<seed>.png`` (``panels``, m in each path's
    frame P; a later panel replaces an earlier one of the same title) and, if
    ``html`` and a showcase run is ``shown``, ``tracking_seed<seed>.html`` (the
    true robot following it, built on ``meshcat`` if given) into ``out``
    (created if missing); prints and returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    files = [
        plot_path_tracking(
            {x.title: (x.u, x.target, x.attained) for x in panels},
            out / f"tracking_seed{seed}.png",
            title=(
                f"{models.nominal.name}: commanded vs attained tool paths, seed "
                f"{seed} (fastest speed, softest gains)"
            ),
        )
    ]
    if html and shown is not None:
        files.append(
            _save_html(models, shown.runs, out / f"tracking_seed{seed}.html", meshcat)
        )
    echo(f"wrote {', '.join(str(f) for f in files)}")
    return files


@dataclasses.dataclass(frozen=True)
class TrackedProgram:
    """One cell of the tracking grid (:func:`track_program`): a program run
    under every variant at one bandwidth, as plain data (a task's result).

    Attributes:
      cell: (path, speed, bandwidth) indices.
      duration: the program's T, s.
      peak_tool_speed: its peak tool speed, m/s.
      errors: the variants' errors (:func:`errors_step`).
      panel: the figure's column, at the fastest speed and softest gains
        (else None).
      shown: the runs, for the showcase cell (first path, fastest speed,
        softest gains; else None).
    """

    cell: tuple[int, int, int]
    duration: float
    peak_tool_speed: float
    errors: PathErrors
    panel: TrackingPanel | None
    shown: VariantRuns | None


def tracking_cells(tracking: TrackingStudyConfig) -> list[tuple[int, int, int]]:
    """The (path, speed, bandwidth) indices of the grid, in the order run."""
    return [
        (p, i, b)
        for p in range(len(tracking.paths))
        for i in range(len(tracking.speeds))
        for b in range(len(tracking.bandwidths))
    ]


def showcase_cell(tracking: TrackingStudyConfig, cell: tuple[int, int, int]) -> bool:
    """Whether ``cell`` (path, speed, bandwidth indices) is the showcase: the
    first path at the fastest speed, softest gains (drawn live on a Meshcat,
    and in the HTML)."""
    p, i, b = cell
    return p == 0 and i == len(tracking.speeds) - 1 and b == _softest(tracking)


def _softest(tracking: TrackingStudyConfig) -> int:
    return int(np.argmin(tracking.bandwidths))


def track_program(
    models: ClosedLoopModels,
    config: CompensationStudyConfig,
    cell: tuple[int, int, int],
    *,
    meshcat: Meshcat | None = None,
) -> TrackedProgram:
    """One cell (path, speed, bandwidth indices) of ``config.tracking``'s grid:
    :func:`setup_step` and :func:`plan_step` (the program, planned here: it
    holds a Drake trajectory, which does not pickle), :func:`track_step` and
    :func:`errors_step`, and :func:`panel_step` at the fastest speed and
    softest gains; ``meshcat`` draws the showcase cell's full-compensation
    run live."""
    tracking = config.tracking
    p, i, b = cell
    kind = tracking.paths[p]
    setup = setup_step(models.nominal, config)
    program = plan_step(models.nominal, setup, tracking, kind, tracking.speeds[i])
    showcase = showcase_cell(tracking, cell)
    runs = track_step(
        config.station,
        program,
        models,
        bandwidth=tracking.bandwidths[b],
        meshcat=meshcat if showcase else None,
    )
    panel = None
    if i == len(tracking.speeds) - 1 and b == _softest(tracking):
        panel = panel_step(kind, program, runs, setup)
    return TrackedProgram(
        cell,
        float(program.duration),
        float(program.peak_tool_speed),
        errors_step(runs),
        panel,
        runs if showcase else None,
    )


def tracking_result(
    models: ClosedLoopModels,
    config: CompensationStudyConfig,
    out: Path,
    tracked: list[TrackedProgram],
    *,
    seed: int,
    meshcat: Meshcat | None = None,
    echo: Callable[[str], None] = print,
) -> TrackingResult:
    """The :class:`TrackingResult` of one true robot's ``tracked`` cells (of
    :func:`track_program`, in :func:`tracking_cells` order) and its files,
    written into ``out`` by :func:`write_tracking_files`:
    ``tracking_seed<seed>.png`` and, if asked, ``tracking_seed<seed>.html``
    (built on ``meshcat`` if given).

    Example, one true robot's runs in this process::

        tracked = [
            track_program(models, config, cell)
            for cell in tracking_cells(config.tracking)
        ]
        result = tracking_result(models, config, out, tracked, seed=0)
    """
    tracking = config.tracking
    programs = {(t.cell[0], t.cell[1]): t for t in tracked}
    errors = {t.cell: t.errors for t in tracked}
    panels = [t.panel for t in tracked if t.panel is not None]
    shown = next((t.shown for t in tracked if t.shown is not None), None)
    result = summarise_tracking(seed, tracking, programs, errors)
    result.files.extend(
        write_tracking_files(
            out,
            models,
            seed,
            panels,
            shown,
            html=tracking.html,
            meshcat=meshcat,
            echo=echo,
        )
    )
    return result
