"""Is a calibration believable? What the sanity checks of every kind share:
the bounds (:class:`CalibrationBounds`: dof, noise ratios, physical bounds in
m and rad), the report (:class:`SanityReport`, ``sanity_`` of every
estimator; ``rmdrake calibrate`` refuses a failed one unless forced) and the
checks that do not depend on the measurement: a degenerate Jacobian
(:func:`degenerate_reason`), corrections beyond physical bounds
(:func:`out_of_bounds_reason`), studentized residuals
(:func:`studentized_residuals`) and the residual against the noise
(:func:`residual_over_noise`). Each kind runs them on its own fit: the plates
in :mod:`rmdrake.calibration.plates.sanity` (whose docstring explains the
rules), the points in :mod:`rmdrake.calibration.points.checks`, the sockets
in :meth:`rmdrake.calibration.sockets.lm.SocketLM.check`.

Example::

    reason = out_of_bounds_reason(["dd2"], np.array([0.2]), 0.05, 0.09)
    # '1 correction(s) beyond physical bounds (...): dd2 = 200 mm'
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.kinematics.forward import robot_reach
from rmdrake.model.error_parameters import is_compliance_name
from rmdrake.model.units import MAX_LENGTH

__all__ = [
    "MAX_INSTRUMENT_RANGE",
    "MAX_MARKER",
    "POINT_MAX_NOISE",
    "SOCKET_MAX_NOISE",
    "CalibrationBounds",
    "SanityReport",
    "check_joint_values",
    "degenerate_reason",
    "out_of_bounds_reason",
    "residual_over_noise",
    "robot_reach",
    "studentized_residuals",
]

MAX_INSTRUMENT_RANGE = 100.0
"""m: the farthest a believable reading is from the instrument's origin (laser
trackers measure to 80 m at most, motion-capture rooms are smaller)."""

MAX_MARKER = 1.0
"""m: the farthest a marker is from the tool frame's origin (a target on a
tool, or a rigid body on a hand)."""

POINT_MAX_NOISE = 0.02
"""m: the largest believable robust scatter of the points about the fitted
model (20 mm: trackers read to tens of microns, motion capture to tenths of a
mm, and a robot's non-geometric errors are millimetres)."""

SOCKET_MAX_NOISE = 1e-3
"""m: the largest believable seating scatter per coordinate of a ball seated
by hand in a socket, about the fitted model (1 mm: a ball sits in its socket
to tenths of a mm; MUKCa's real Panda scatters 0.15 mm about its calibrated
model). A socket calibration whose estimated noise exceeds it, or a declared
``--noise`` above it, is refused: the data contradict each other (sockets
mixed up between placements, a wrong known distance, distances in mm), which
no noise explains."""


@dataclasses.dataclass(frozen=True)
class CalibrationBounds:
    """What a believable kinematic calibration satisfies.

    Attributes:
      angle: rad, largest |dalpha|, |dtheta|, |dbeta| (5 deg). Machined axes
        are parallel or square to a few hundredths of a degree and a joint's
        zero is mastered to well under a degree; 5 deg is many times either,
        while a wrong fit is typically tens of degrees off (+-90 deg collapses).
      length: m, with ``length_fraction``: largest |dd|, |dr| is ``length`` +
        ``length_fraction`` x the robot's reach (:func:`robot_reach`): 20 mm +
        2 % (44 mm on the RV-3SB, 264 mm on the 12 m DEMO-class arm). Link
        lengths are machined to a small fraction of a percent; 2 % of the reach
        is the lever of a 1 deg error, and 20 mm covers a tool or sensor mount
        measured by hand.
      noise_ratio: residual RMS over the noise above which the fit is warned
        of (3: with >= 5 dof the chance of a clean fit exceeding it is below
        1e-4).
      refuse_ratio: residual RMS over the noise above which the fit is refused
        (30: see rule 4 of the module docstring for the cases that set it).
      max_noise: m, largest believable reading scatter about a plate (1 mm:
        range finders read to microns, plates are flat to tens of microns, and
        a 1.6 mm-off nominal model scatters points by about that much).
      noise_floor: m, the smallest noise used to standardize residuals (10 nm,
        below any range finder: noise-free simulations stay finite).
      min_dof: fewest degrees of freedom left to check the fit.
      min_per_plate: fewest readings on a plate (3 fix it, 3 check it).
      outlier_p, min_z: outlier threshold (see the module docstring).
      plate_ratio: a plate whose robust scatter is this many times the median
        plate's does not fit one plane.
      rtol: smallest singular value of the scaled Jacobian at the solution,
        relative to the largest, for full rank.
    """

    angle: float = float(np.deg2rad(5.0))
    length: float = 0.02
    length_fraction: float = 0.02
    noise_ratio: float = 3.0
    refuse_ratio: float = 30.0
    max_noise: float = 1e-3
    noise_floor: float = 1e-8
    min_dof: int = 5
    min_per_plate: int = 6
    outlier_p: float = 1e-3
    min_z: float = 5.0
    plate_ratio: float = 5.0
    rtol: float = 1e-8


@dataclasses.dataclass(frozen=True)
class SanityReport:
    """The outcome of the checks.

    Attributes:
      reasons: one line per failed check (empty: plausible).
      noise: m, the noise the residual was compared with.
      noise_source: ``declared`` or how it was estimated.
      residual_rms: m, sqrt(RSS / dof) of the fit.
      dof: readings - unknowns.
      z: (N,) standardized residuals at the reference model.
      outliers: 0-based indices of the outlying readings.
      reference: ``calibrated`` or ``nominal``: the model of the outlier check.
      warnings: what the data say the model may miss, without refusing it.
    """

    reasons: tuple[str, ...]
    noise: float
    noise_source: str
    residual_rms: float
    dof: int
    z: np.ndarray = dataclasses.field(repr=False)
    outliers: np.ndarray
    reference: str
    warnings: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True when every check passed."""
        return not self.reasons

    def summary(self) -> str:
        """One line: the verdict, residual, noise and dof."""
        head = "plausible" if self.ok else f"IMPLAUSIBLE ({len(self.reasons)})"
        if self.ok and self.warnings:
            head += f", with {len(self.warnings)} warning(s)"
        return (
            f"sanity: {head}; residual {self.residual_rms * 1e6:.3g} um vs noise "
            f"{self.noise * 1e6:.3g} um ({self.noise_source}), {self.dof} dof, "
            f"max |z| {float(np.max(np.abs(self.z), initial=0.0)):.3g}"
        )


def _format_delta(name: str, value: float) -> str:
    if name[:2] in ("dd", "dr"):
        return f"{name} = {value * 1e3:.4g} mm"
    return f"{name} = {np.rad2deg(value):.4g} deg"


def degenerate_reason(
    sv: np.ndarray, vt: np.ndarray, names: list[str], rtol: float
) -> str | None:
    """The reason if the scaled Jacobian (singular values ``sv``, right
    singular vectors ``vt``) at the solution lost rank."""
    null = vt[sv <= rtol * sv[0]] if sv.size and sv[0] > 0 else vt
    if null.shape[0] == 0:
        return None
    weight = np.abs(null[:, : len(names)]).max(axis=0)
    loose = [n for n, w in zip(names, weight, strict=True) if w > 1e-3]
    return (
        f"degenerate solution: the Jacobian at the calibrated model has rank "
        f"{vt.shape[1] - null.shape[0]} of {vt.shape[1]}"
        + (f" ({', '.join(loose)} undetermined)" if loose else "")
        + ": the model collapsed so that planes fit whatever the readings"
    )


def studentized_residuals(
    residuals: np.ndarray, U: np.ndarray, full: np.ndarray, dof: int, floor: float
) -> tuple[np.ndarray, np.ndarray]:
    """Leverage-corrected residuals e (N,) and externally studentized z (N,)
    of a least-squares fit whose Jacobian has left singular vectors ``U``
    (columns ``full`` spanning its range)."""
    r = np.asarray(residuals, dtype=np.float64)
    h = np.clip(np.sum(U[:, full] ** 2, axis=1), 0.0, 1.0 - 1e-9)
    e = r / np.sqrt(1.0 - h)
    if dof < 2:
        return e, np.zeros_like(e)
    rss = float(r @ r)
    s_i = np.sqrt(np.maximum(rss - e**2, 0.0) / (dof - 1))
    return e, e / np.maximum(s_i, floor)


def out_of_bounds_reason(
    names: list[str], deltas: np.ndarray, length: float, angle: float
) -> str | None:
    """The reason if corrections exceed the bounds (the largest first)."""
    deltas = np.asarray(deltas, dtype=np.float64)
    lim = np.array([length if n[:2] in ("dd", "dr") else angle for n in names])
    lim[np.array([is_compliance_name(n) for n in names], bool)] = np.inf  # c<j>
    excess = np.abs(deltas) / lim
    bad = np.flatnonzero(~(excess <= 1.0))
    if bad.size == 0:
        return None
    bad = bad[np.argsort(-np.nan_to_num(excess[bad], nan=np.inf), kind="stable")]
    listed = ", ".join(_format_delta(names[i], float(deltas[i])) for i in bad[:6])
    more = f" and {bad.size - 6} more" if bad.size > 6 else ""
    return (
        f"{bad.size} correction(s) beyond physical bounds (+-{np.rad2deg(angle):.3g} "
        f"deg on angles, +-{length * 1e3:.3g} mm on lengths): {listed}{more}"
    )


def residual_over_noise(
    s: float,
    ref: float,
    source: str,
    dof: int,
    bounds: CalibrationBounds,
    what: str,
) -> tuple[bool, str] | None:
    """The residual-over-noise check of the module docstring's rule 4: None
    when the residual RMS ``s`` (m) is within ``noise_ratio`` times the noise
    ``ref`` (m, ``source``: declared or how estimated), else (refused, line):
    refused beyond ``refuse_ratio`` times, a warning between. ``what`` says
    what the RMS is over."""
    floor = max(ref, bounds.noise_floor)
    if dof <= 0 or s <= bounds.noise_ratio * floor:
        return None
    refused = s > bounds.refuse_ratio * floor
    line = (
        f"residual {s * 1e6:.4g} um ({what}) is {s / ref:.3g} times the noise "
        f"({ref * 1e6:.4g} um, {source})"
    )
    if refused:
        return (
            True,
            f"{line}, over {bounds.refuse_ratio:g}x: readings the model cannot explain",
        )
    return False, f"{line}: the model misses something the readings see"


def check_joint_values(
    q: np.ndarray,
    lower: np.ndarray | None,
    upper: np.ndarray | None,
    sigma: np.ndarray | None = None,
    *,
    source: str = "measurements",
    row: str = "row",
) -> list[str]:
    """Checks measured joint values (N, n) against the robot: rad for a
    revolute joint, m for a prismatic one (``sigma`` 1; None = all revolute).

    Raises ValueError (one line starting with ``source``) for values evidently
    in another unit: a revolute |q| beyond both 2 pi and the joint's limits by
    more than 0.5 rad (degrees), a prismatic |q| beyond its limits by more
    than 0.5 m (mm). Returns one message per joint with values outside
    [lower, upper] (the caller warns)."""
    q = np.asarray(q, dtype=np.float64)
    n = q.shape[1]
    slide = np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1
    if lower is not None and upper is not None:
        span = np.maximum(np.abs(np.asarray(lower)), np.abs(np.asarray(upper)))
        bound = np.where(slide, span, np.maximum(span, 2 * np.pi)) + 0.5
    else:  # no limits: two turns or the longest length a robot has
        bound = np.where(slide, MAX_LENGTH, 2 * np.pi + 0.5)
    over = np.abs(q) > bound
    if over.any():
        k, j = (int(v[0]) for v in np.nonzero(over))
        unit, looks = ("m", "mm") if slide[j] else ("rad", "degrees")
        raise ValueError(
            f"{source}: joint q{j + 1} = {q[k, j]:g} at {row} {k + 1} looks like "
            f"{looks}; joint values must be in {unit}"
        )
    messages = []
    if lower is not None and upper is not None:
        out = (q < np.asarray(lower) - 1e-9) | (q > np.asarray(upper) + 1e-9)
        for j in np.flatnonzero(out.any(axis=0)):
            rows = np.flatnonzero(out[:, j])
            unit = "m" if slide[j] else "rad"
            messages.append(
                f"{source}: joint q{j + 1} outside its limits "
                f"[{lower[j]:.4g}, {upper[j]:.4g}] {unit} at {rows.size} {row}(s), "
                f"first at {row} {rows[0] + 1} ({q[rows[0], j]:.4g} {unit})"
            )
    return messages
