"""Synthetic plane-constraint measurements: a range finder on the tool reading the
distance to a flat plate put at several places the robot can reach.

Frames and the validity rule of a reading (span, incidence cone, hit point on the
plate) are those of :mod:`rmdrake.calibration.plates.range_finder`: B = robot base,
E = tool frame (beam along z_E), P = plate frame (z_P the normal on the sensor's
side); the measured point is ``p_BM = p_BE + t z_BE`` for a reading t (m).

How plates and poses are generated (:func:`simulate_plates`), all from one seeded
``numpy.random.default_rng(seed)``:

1. plates: draw joint angles q_c in the middle 70 % of every joint range, keep
   those whose tool point is in front of the robot (radius >= 0.2 m from the
   z_B axis, height >= 0), and order them by farthest-point sampling of the tool
   position and direction, so that the plates differ in place and orientation;
   a plate's centre is mid-span ahead of the tool along z_E, its normal -z_E
   tilted by up to ``max_tilt``;
2. poses on it: draw target points on the plate (middle 80 %), beam
   directions within 85 % of the incidence cone, stand-offs within the middle
   80 % of the span and (``roll``) a random roll about the beam; solve the
   inverse kinematics for all candidates at once with
   :func:`rmdrake.kinematics.forward.solve_tool_ik` (damped Gauss-Newton, joint limits
   enforced by clipping) from q_c plus ``start_spread`` noise;
3. keep the candidates whose actual reading with the given model is valid
   (span, incidence, on the plate, within limits): ``pool`` x ``per_plate`` of
   them, of which ``selection="d-optimal"`` keeps ``per_plate`` per plate by
   :func:`~rmdrake.calibration.plates.pose_selection.select_d_optimal` and
   ``"first"`` the first valid ones; if a plate yields too few, the next
   plate pose is tried;
4. add Gaussian noise (sigma = ``noise``, m) to the readings.

A robot cell (``checker``, :class:`rmdrake.kinematics.clearance.ClearanceChecker`)
adds to the validity rule of step 3: the pose (its link angles) keeps
``clearance`` (m) from the cell. The random draws are the same with or without
it, so without a cell the output is unchanged.

Payloads and elastic joints: with ``payload`` masses (kg) the candidates of
step 2 take them in turn (candidate i the (i mod M)-th), so the kept readings
are split about evenly over them, and the readings carry a ``payload`` column.
The IK of step 2 gives the link angles q_l that aim the beam; an elastic true
robot (``compliance``) holds them at the motor angles
q_m = q_l - C tau(q_l) of :func:`rmdrake.dynamics.compliance.motor_angles` under that
reading's payload, and q_m is what the readings record (the encoders), so the
link side, not the encoder, obeys the validity rule. Rigid robot: q_m = q_l.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.calibration.plates.checks import MAX_PLATE_READINGS
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.pose_selection import select_d_optimal
from rmdrake.calibration.plates.range_finder import (
    RangeFinderSpec,
    beam_readings,
    ray_plane_distance,
)
from rmdrake.calibration.simulate import MAX_NOISE_SHARE, random_poses
from rmdrake.dynamics.compliance import link_angles, motor_angles, payload_choices
from rmdrake.kinematics.forward import robot_reach, tool_points, tool_poses
from rmdrake.kinematics.ik import solve_tool_ik
from rmdrake.limits import check_memory
from rmdrake.model.robot import RobotModel

if TYPE_CHECKING:
    from rmdrake.kinematics.clearance import ClearanceChecker

__all__ = [
    "MAX_PLATE_READINGS",
    "Plate",
    "SimulatedPlates",
    "check_plate_counts",
    "random_poses",
    "range_readings",
    "simulate_plates",
    "solve_tool_ik",  # re-exported; the one tool IK lives in rmdrake.kinematics
]


@dataclasses.dataclass(frozen=True)
class Plate:
    """A flat rectangular plate.

    Attributes:
      X_BP: (4, 4) pose of the plate frame P in the base B (origin at the plate
        centre, z_P the normal on the sensor's side), m.
      size: (2,) edge lengths along x_P and y_P, m (default: that of
        :class:`~rmdrake.calibration.plates.range_finder.RangeFinderSpec`).

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import Plate
    >>> plate = Plate(X_BP=np.eye(4), size=(0.2, 0.2))
    >>> plate.size, plate.X_BP.shape
    ((0.2, 0.2), (4, 4))
    """

    X_BP: np.ndarray
    size: tuple[float, float] = RangeFinderSpec.plate_size

    @property
    def normal(self) -> np.ndarray:
        """Unit normal z_P expressed in B."""
        return np.asarray(self.X_BP)[:3, 2]

    @property
    def offset(self) -> float:
        """h = n . p_BP (m): the plane is {p : n . p = h}."""
        return float(self.normal @ np.asarray(self.X_BP)[:3, 3])


@dataclasses.dataclass(frozen=True)
class SimulatedPlates:
    """Output of :func:`simulate_plates`.

    Attributes:
      data: the measurements (noisy readings), ready for calibration.
      plates: the true plates, one per plate id 0..P-1.
      p_BM: (N, 3) true (noise-free) measured points, m.
      true_distance: (N,) noise-free readings, m.
      incidence: (N,) beam incidence angles, rad.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_plates
    >>> sim = simulate_plates(load_robot("rv3sb"), plates=3, per_plate=4, seed=0)
    >>> len(sim.plates), sim.data.q.shape, sim.true_distance.shape
    (3, (12, 6), (12,))
    """

    data: PlaneMeasurements
    plates: list[Plate]
    p_BM: np.ndarray
    true_distance: np.ndarray
    incidence: np.ndarray

    def summary(self) -> str:
        """Readings and plates, their range (mm), largest incidence (deg) and
        sample noise (um) on one line, then each plate's centre (m) and normal."""
        t = self.true_distance
        noise = np.std(self.data.distance - t)
        lines = [
            f"{self.data.n_readings} readings on {len(self.plates)} plates; readings "
            f"{t.min() * 1e3:.1f}..{t.max() * 1e3:.1f} mm, incidence <= "
            f"{np.rad2deg(self.incidence.max()):.1f} deg, noise {noise * 1e6:.3g} um "
            f"(sample)"
        ]
        for i, plate in enumerate(self.plates):
            c, n = plate.X_BP[:3, 3], plate.normal
            lines.append(
                f"  plate {i}: centre ({c[0]:+.3f}, {c[1]:+.3f}, {c[2]:+.3f}) m, "
                f"normal ({n[0]:+.2f}, {n[1]:+.2f}, {n[2]:+.2f})"
            )
        return "\n".join(lines)


def range_readings(
    table: np.ndarray,
    q: np.ndarray,
    plates: list[Plate],
    plate_index: np.ndarray,
    *,
    sigma: np.ndarray | None = None,
) -> np.ndarray:
    """Noise-free readings (m) of a robot with MDH ``table`` and joint types
    ``sigma`` at joint positions q (N, n) on the plates
    ``plates[plate_index[i]]``; NaN where the beam misses the plane (the
    plate's extent is not checked here).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import range_readings, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> sim = simulate_plates(robot, plates=3, per_plate=4, noise=0.0, seed=0)
    >>> d = range_readings(robot.table, sim.data.q, sim.plates, sim.data.plane)
    >>> d.shape, bool(abs(d - sim.data.distance).max() < 1e-12)
    ((12,), True)
    """
    X_BE = tool_poses(table, q, sigma=sigma)
    normals = np.array([p.normal for p in plates])[plate_index]
    offsets = np.array([p.offset for p in plates])[plate_index]
    return ray_plane_distance(X_BE, normals, offsets)


def _random_directions(
    rng: np.random.Generator, axis: np.ndarray, max_angle: float, m: int
) -> np.ndarray:
    """(m, 3) unit vectors uniform on the spherical cap of half-angle max_angle
    about the unit vector ``axis``."""
    cos = rng.uniform(np.cos(max_angle), 1.0, m)
    sin = np.sqrt(1.0 - cos**2)
    phi = rng.uniform(0.0, 2 * np.pi, m)
    u = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    return (
        cos[:, None] * axis
        + (sin * np.cos(phi))[:, None] * u
        + (sin * np.sin(phi))[:, None] * v
    )


def _plate_candidates(
    model: RobotModel,
    rng: np.random.Generator,
    lo: np.ndarray,
    hi: np.ndarray,
    count: int,
) -> np.ndarray:
    """(count, n) plate-generating joint angles, ordered for spread.

    Draws joint angles uniformly in [lo, hi], keeps those whose tool point is in
    front of the robot (radius >= 0.2 m from the z_B axis, height >= 0), then
    orders them by farthest-point sampling on the feature (p_BE / reach, z_BE):
    each next plate is the one farthest from those already chosen, so the first
    P plates differ in place and in orientation.
    """
    table, sigma = model.table, model.sigma
    reach = robot_reach(model)
    kept = np.zeros((0, model.n_joints))
    for _ in range(50):
        q = rng.uniform(lo, hi, (4 * count, model.n_joints))
        X = tool_poses(table, q, sigma=sigma)
        p = X[:, :3, 3]
        ok = (np.hypot(p[:, 0], p[:, 1]) >= 0.2) & (p[:, 2] >= 0.0)
        kept = np.concatenate([kept, q[ok]])[:count]
        if kept.shape[0] >= count:
            break
    if kept.shape[0] == 0:
        raise ValueError("no joint angles put the tool in front of the robot")
    X = tool_poses(table, kept, sigma=sigma)
    feature = np.concatenate([X[:, :3, 3] / reach, X[:, :3, 2]], axis=1)
    order = [0]
    dist = np.linalg.norm(feature - feature[0], axis=1)
    for _ in range(kept.shape[0] - 1):
        nxt = int(np.argmax(dist))
        order.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(feature - feature[nxt], axis=1))
    return kept[order]


def _frame_from_z(z: np.ndarray, origin: np.ndarray, rng: np.random.Generator):
    x = np.cross(z, rng.standard_normal(3))
    x /= np.linalg.norm(x)
    X = np.eye(4)
    X[:3, 0], X[:3, 1], X[:3, 2], X[:3, 3] = x, np.cross(z, x), z, origin
    return X


def simulate_plates(
    model: RobotModel,
    *,
    plates: int = 5,
    per_plate: int = 12,
    noise: float = 2e-6,
    seed: int = 0,
    spec: RangeFinderSpec | None = None,
    max_tilt: float = float(np.deg2rad(15.0)),
    roll: bool = True,
    start_spread: float = 0.3,
    selection: str = "d-optimal",
    pool: int = 4,
    planning_model: RobotModel | None = None,
    max_attempts: int = 200,
    payload: float | list[float] | None = None,
    checker: ClearanceChecker | None = None,
    clearance: float = 0.0,
) -> SimulatedPlates:
    """Simulates plane-constraint measurements of a (true) robot.

    See the module docstring for the procedure. Readings are computed with the
    exact ray-plate intersection of ``model``'s kinematics, then noise is added.

    Args:
      model: the robot being measured (the "true" robot in a simulation study).
      plates: number of plate locations P (ids 0..P-1).
      per_plate: readings per plate.
      noise: standard deviation of the reading noise, m.
      seed: seed of every random choice.
      spec: range finder span, incidence cone and plate size (default: a
        :class:`~rmdrake.calibration.plates.range_finder.RangeFinderSpec` with
        its defaults).
      max_tilt: largest tilt of a plate's normal from the tool axis at its
        generating pose, rad.
      roll: give each pose a random roll about the beam (6-DOF IK); without
        it the roll is whatever the IK finds near the plate's pose (5-DOF).
      start_spread: standard deviation of the IK start around the plate's
        generating joint angles, rad (larger: more varied configurations).
      selection: ``d-optimal``: draw ``pool`` x ``per_plate`` valid poses per
        plate and keep ``per_plate`` per plate by
        :func:`~rmdrake.calibration.plates.pose_selection.select_d_optimal`
        (what a careful experimenter does: spread the poses); ``first``: keep
        the first valid ones (plain random poses).
      pool: candidate factor of the D-optimal selection.
      planning_model: the model used to plan the selection (the nominal, as on
        a real robot); default ``model``. Validity is always checked with
        ``model``.
      max_attempts: plate poses tried before giving up.
      payload: kg at the tool, one mass or several (the readings split over
        them, see the module docstring); None: no payload column (0 kg).
      checker, clearance: the robot's cell and the distance (m) every kept
        pose keeps from it; None: no cell.

    Raises:
      ValueError: bad arguments (a payload on a robot without a ``payload``
        entry), or the robot cannot reach enough plates.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import simulate_plates
    >>> sim = simulate_plates(load_robot("rv3sb"), plates=5, per_plate=12, seed=0)
    >>> sim.data.q.shape, sorted(set(sim.data.plane.tolist()))
    ((60, 6), [0, 1, 2, 3, 4])
    """
    spec = spec or RangeFinderSpec()
    _check_arguments(selection, plates, per_plate, noise, spec)
    payloads = _PayloadTurns(payload_choices(model, payload))
    rng = np.random.default_rng(seed)
    lo, hi = model.limits.lower, model.limits.upper
    want = per_plate * (pool if selection == "d-optimal" else 1)
    check_memory(  # the candidate poses and their tool frames
        float(plates) * want * (model.n_joints + 32),
        f"{plates} plates x {per_plate} readings ({want} candidate poses each)",
        "lower per_plate (a calibration needs tens of readings per plate)",
    )
    candidates = _plate_candidates(
        model, rng, lo + 0.15 * (hi - lo), hi - 0.15 * (hi - lo), 8 * plates
    )
    out_plates, pooled = _place_plates(
        model,
        rng,
        candidates,
        _PoseDraw(
            spec=spec,
            per_plate=per_plate,
            want=want,
            roll=roll,
            start_spread=start_spread,
            payloads=payloads,
            checker=checker,
            clearance=clearance,
        ),
        plates=plates,
        max_tilt=max_tilt,
        max_attempts=max_attempts,
    )
    found = _Readings.concatenate(pooled)
    plane = np.concatenate([np.full(r.q.shape[0], i) for i, r in enumerate(pooled)])
    keep = _select_readings(
        planning_model or model, found, plane, out_plates, per_plate, selection
    )
    found, plane = found.take(keep), plane[keep]
    if payloads.masses is not None:
        _check_loads_carried(model, payloads.masses, found.mass)
    reading = found.t + noise * rng.standard_normal(found.t.size)
    data = PlaneMeasurements(
        plane, found.q, reading, None if payloads.masses is None else found.mass
    )
    q_l = link_angles(model, found.q, found.mass)
    return SimulatedPlates(
        data=data,
        plates=out_plates,
        p_BM=tool_points(model.table, q_l, found.t, sigma=model.sigma),
        true_distance=found.t,
        incidence=found.incidence,
    )


# ---- the steps of simulate_plates, in order -----------------------------------------


def check_plate_counts(plates: int, per_plate: int) -> None:
    """Refuses counts below 1 or over :data:`MAX_PLATE_READINGS` readings in
    all (one line naming the counts and the cap).

    >>> check_plate_counts(5, 12)
    """
    if plates < 1 or per_plate < 1:
        raise ValueError("plates and per_plate: expected positive counts")
    if float(plates) * per_plate > MAX_PLATE_READINGS:
        raise ValueError(
            f"plates x per_plate: {plates} x {per_plate} = "
            f"{float(plates) * per_plate:.3g} readings is over the cap of "
            f"{MAX_PLATE_READINGS} readings (a calibration takes tens per plate); "
            "give fewer plates or per_plate"
        )


def _check_arguments(
    selection: str, plates: int, per_plate: int, noise: float, spec: RangeFinderSpec
) -> None:
    """Refuses an unknown ``selection``, counts below 1 or over their cap
    (:func:`check_plate_counts`), a negative ``noise``
    (m) and one over :data:`MAX_NOISE_SHARE` of the range finder's span, of
    :func:`simulate_plates`."""
    if selection not in ("d-optimal", "first"):
        raise ValueError(
            f"selection: expected 'd-optimal' or 'first', found {selection!r}"
        )
    check_plate_counts(plates, per_plate)
    if noise < 0:
        raise ValueError(f"noise: expected >= 0 m, found {noise}")
    lo, hi = spec.span
    if noise > MAX_NOISE_SHARE * (hi - lo):
        raise ValueError(
            f"noise: {noise:g} m is over {MAX_NOISE_SHARE:g} of the range finder's "
            f"span ({lo * 1e3:g} to {hi * 1e3:g} mm): readings would leave it; the "
            "noise is a standard deviation in m"
        )


def _check_loads_carried(
    model: RobotModel, masses: np.ndarray, carried: np.ndarray
) -> None:
    """Refuses readings in which a requested payload (kg) has no reading: the
    arm bent under it beyond every plate (a 1e9 kg load on the elastic arm
    once left only the 0 kg readings, written with exit 0)."""
    missing = [m for m in np.unique(masses) if not np.any(carried == m)]
    if missing:
        raise ValueError(
            f"payload: no reading with {', '.join(f'{m:g}' for m in missing)} kg: "
            f"robot '{model.name}' reaches no plate carrying it (its joints bend "
            "or the load is beyond its rating); give the payloads it carries, in kg"
        )


class _PayloadTurns:
    """The payloads (kg) of the candidate poses, the masses in turn across all
    plates (candidate i the (i mod M)-th); 0 kg without masses.

    Attributes:
      masses: (M,) payload masses, kg, or None (no payload column).
      turn: the next candidate's payload index.
    """

    def __init__(self, masses: np.ndarray | None) -> None:
        self.masses = masses
        self.turn = 0

    def take(self, m: int) -> np.ndarray:
        """(m,) payloads of the next m candidates, kg."""
        if self.masses is None:
            return np.zeros(m)
        mass = self.masses[(self.turn + np.arange(m)) % self.masses.size]
        self.turn += m
        return mass


@dataclasses.dataclass(frozen=True)
class _PoseDraw:
    """How :func:`_plate_readings` draws the poses on a plate (arguments of
    :func:`simulate_plates`).

    Attributes:
      spec: the range finder and plate.
      per_plate: readings a plate must give.
      want: valid readings kept per plate (the D-optimal pool), >= per_plate.
      roll: give each pose a random roll about the beam.
      start_spread: std of the IK start around the plate's joint angles, rad.
      payloads: the candidates' payloads, in turn.
      checker, clearance: the cell a pose keeps ``clearance`` (m) from, or
        None.
    """

    spec: RangeFinderSpec
    per_plate: int
    want: int
    roll: bool
    start_spread: float
    payloads: _PayloadTurns
    checker: ClearanceChecker | None = None
    clearance: float = 0.0


@dataclasses.dataclass(frozen=True)
class _Readings:
    """Valid readings on plates.

    Attributes:
      q: (M, n) joint positions the encoders read, rad or m.
      t: (M,) noise-free readings, m.
      incidence: (M,) beam incidence angles, rad.
      mass: (M,) payloads, kg.
    """

    q: np.ndarray
    t: np.ndarray
    incidence: np.ndarray
    mass: np.ndarray

    @staticmethod
    def concatenate(parts: list[_Readings]) -> _Readings:
        """The readings of ``parts``, one after the other."""
        return _Readings(
            q=np.concatenate([p.q for p in parts]),
            t=np.concatenate([p.t for p in parts]),
            incidence=np.concatenate([p.incidence for p in parts]),
            mass=np.concatenate([p.mass for p in parts]),
        )

    def take(self, index: slice | np.ndarray) -> _Readings:
        """The readings at ``index`` (a slice, mask or index array)."""
        return _Readings(
            q=self.q[index],
            t=self.t[index],
            incidence=self.incidence[index],
            mass=self.mass[index],
        )


def _place_plates(
    model: RobotModel,
    rng: np.random.Generator,
    candidates: np.ndarray,
    draw: _PoseDraw,
    *,
    plates: int,
    max_tilt: float,
    max_attempts: int,
) -> tuple[list[Plate], list[_Readings]]:
    """Places a plate at each plate-generating joint angles of ``candidates``
    (rad or m) in turn (:func:`_place_plate`) and draws readings on it
    (:func:`_plate_readings`), skipping a plate with fewer than
    ``draw.per_plate``, until ``plates`` plates are placed.

    Returns:
      (plates, readings): the placed plates, and the ``draw.want`` or fewer
      valid readings on each.

    Raises:
      ValueError: ``max_attempts`` plates tried (or every candidate) first.
    """
    spec = draw.spec
    out_plates: list[Plate] = []
    pooled: list[_Readings] = []
    attempts = 0
    while len(out_plates) < plates:
        attempts += 1
        if attempts > min(max_attempts, len(candidates)):
            raise ValueError(
                f"could not place {plates} reachable plates with "
                f"{draw.per_plate} valid readings each (span {spec.span} m, "
                f"incidence <= {np.rad2deg(spec.max_incidence):.0f} deg)"
            )
        q_c = candidates[attempts - 1]
        plate = _place_plate(model, rng, q_c, spec, max_tilt)
        got = _plate_readings(model, rng, plate, q_c, draw)
        if got.q.shape[0] < draw.per_plate:
            continue
        pooled.append(got)
        out_plates.append(plate)
    return out_plates, pooled


def _place_plate(
    model: RobotModel,
    rng: np.random.Generator,
    q_c: np.ndarray,
    spec: RangeFinderSpec,
    max_tilt: float,
) -> Plate:
    """The plate of generating joint angles ``q_c`` (rad or m): centred mid-span
    ahead of the tool along z_E, its normal -z_E tilted by up to ``max_tilt``
    (rad) in a random direction, its x_P axis random."""
    X_c = tool_poses(model.table, q_c, sigma=model.sigma)[0]
    p_c, z_c = X_c[:3, 3], X_c[:3, 2]
    normal = -_random_directions(rng, z_c, max_tilt, 1)[0]
    lo_s, hi_s = spec.span
    centre = p_c + 0.5 * (lo_s + hi_s) * z_c
    return Plate(_frame_from_z(normal, centre, rng), spec.plate_size)


def _plate_readings(
    model: RobotModel,
    rng: np.random.Generator,
    plate: Plate,
    q_c: np.ndarray,
    draw: _PoseDraw,
) -> _Readings:
    """The first ``draw.want`` valid readings on ``plate`` from up to four
    rounds of :func:`_candidate_readings` (fewer when the rounds find fewer)."""
    got: list[_Readings] = []
    for _ in range(4):
        m = max(4 * draw.per_plate, 2 * draw.want)
        got.append(_candidate_readings(model, rng, plate, q_c, m, draw))
        if sum(len(g.t) for g in got) >= draw.want:
            break
    return _Readings.concatenate(got).take(slice(None, draw.want))


def _candidate_readings(
    model: RobotModel,
    rng: np.random.Generator,
    plate: Plate,
    q_c: np.ndarray,
    m: int,
    draw: _PoseDraw,
) -> _Readings:
    """The valid ones of ``m`` candidate readings on ``plate``.

    Draws target points (middle 80 % of the plate), beam directions (within
    85 % of the incidence cone), stand-offs (middle 80 % of the span) and, with
    ``draw.roll``, a roll about the beam; solves the tool IK from q_c (rad or
    m) plus ``draw.start_spread`` noise for the link angles, and records the
    motor angles under each candidate's payload. Valid: the link side's
    reading obeys the range finder's rule (and keeps the clearance from the
    cell) and the motor angles are within the joint limits.
    """
    spec, table = draw.spec, model.table
    lo, hi = model.limits.lower, model.limits.upper
    lo_s, hi_s = spec.span
    size = np.array(spec.plate_size)
    centre, normal = plate.X_BP[:3, 3], plate.normal
    uv = rng.uniform(-0.4 * size, 0.4 * size, (m, 2))
    targets = centre + uv @ plate.X_BP[:3, :2].T
    beam = _random_directions(rng, -normal, 0.85 * spec.max_incidence, m)
    stand = rng.uniform(lo_s + 0.1 * (hi_s - lo_s), hi_s - 0.1 * (hi_s - lo_s), m)
    x_axis = None
    if draw.roll:
        # A random roll about the beam: exercises the wrist.
        x_axis = np.cross(beam, rng.standard_normal((m, 3)))
        x_axis /= np.linalg.norm(x_axis, axis=1, keepdims=True)
    q0 = q_c + draw.start_spread * rng.standard_normal((m, q_c.size))
    q = solve_tool_ik(
        model,
        np.clip(q0, lo, hi),
        targets - stand[:, None] * beam,
        beam,
        x_axis,
    ).q
    t, inc, ok = beam_readings(
        tool_poses(table, q, sigma=model.sigma), plate.X_BP, spec
    )
    mass = draw.payloads.take(m)
    if draw.checker is not None:  # the link side keeps clear of the cell
        ok &= draw.checker.clear(q, draw.clearance)
    q = motor_angles(model, q, mass)  # the encoders of an elastic robot
    ok &= np.all((q >= lo) & (q <= hi), axis=1)
    return _Readings(q=q[ok], t=t[ok], incidence=inc[ok], mass=mass[ok])


def _select_readings(
    planning_model: RobotModel,
    found: _Readings,
    plane: np.ndarray,
    plates: list[Plate],
    per_plate: int,
    selection: str,
) -> np.ndarray:
    """Indices of the ``per_plate`` readings kept per plate among ``found``
    (on plates ``plane``, ids into ``plates``): by
    :func:`~rmdrake.calibration.plates.pose_selection.select_d_optimal` with
    ``planning_model`` (``selection="d-optimal"``), or the first ones."""
    if selection == "d-optimal":
        return select_d_optimal(
            planning_model,
            PlaneMeasurements(plane, found.q, found.t),
            [pl.normal for pl in plates],
            per_plate,
        )
    return np.concatenate(
        [np.flatnonzero(plane == p)[:per_plate] for p in range(len(plates))]
    )
