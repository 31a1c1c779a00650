"""Which arm of a fleet has drifted: each arm's identified base parameters
against the fleet's robust centre (or a known-good reference), in words.

Numbers in, flags out (numpy and scipy.stats: no plant, no file): ``values`` and ``std``
are (m, p) arrays, m arms by p base parameters (SI units of each parameter,
:mod:`rmdrake.dynamics.base`), the std being each identification's own
(the least-squares covariance of :mod:`rmdrake.dynamics.estimators`).

Fleet mode (:func:`compare_fleet` without a reference). Per parameter the
centre is the median over the arms and the spread a robust standard deviation
over them: both ignore up to half the fleet being off, so a worn arm does not
move the yardstick it is measured with. An arm departs from the fleet in a
parameter by the ratio r = (x - centre) / s with the combined standard
deviation s = sqrt(std^2 + spread^2): its own identification's uncertainty and
the arm-to-arm (manufacturing) spread.

The spread is Rousseeuw and Croux's Qn (``spread="qn"``, the default: the
first quartile of the pairwise distances |x_i - x_k|, scaled to a normal
sigma with their small-sample factors; 82 % efficient at the normal) or
1.4826 MAD (``spread="mad"``: the MAD of a normal sample is 0.6745 sigma; 37 %
efficient). Both break down only when half the fleet is off. And the
departure is reported in *sigma*: the standard normal deviate with the same
two-sided tail probability as r under Student's t with the spread's
degrees of freedom, nu = e (m - 1) for m arms and efficiency e
(:data:`SPREADS`). A large r is worth fewer sigma where the spread of a small
fleet is uncertain: with 3 arms (nu = 1.6) a ratio of 1000 is 4.4 sigma.
(Not Welch-Satterthwaite's larger degrees of freedom where the arm's own std
dominates: the fleet's spread already holds the estimation noise, and on small
fleets that rule raises flags on healthy ones.)

The threshold: family-wise. A fleet of m arms x p parameters is m p tests;
one is flagged beyond the sigma z* whose two-sided normal tail is
``false_alarm`` / (m p) (:func:`family_threshold`, Bonferroni), so that a
healthy fleet raises any flag with probability at most ``false_alarm``
(:data:`DEFAULT_FALSE_ALARM`, 1 %). Example: 12 arms x 52 base parameters of
the RV-3SB: 624 tests, z* = 4.31; 4 arms 4.06, 21 arms 4.44. A fixed
threshold is too loose for a small fleet and too strict for a large one.
``bench/fleet.py`` prints the false alarms of healthy simulated fleets and the
detection of a worn arm at several fleet sizes; the README's results table
holds a 12-arm case. Every parameter gets the same
threshold: joint terms (friction, rotor inertia), which wear changes, are not
tested at a looser one than the inertial parameters, only listed first.

Build spread. A fleet of 4 cannot tell its spread: a worn arm is rarely found
among 4 without it. ``build_spread`` (p,) is a known arm-to-arm standard deviation of
each base parameter (the manufacturer's tolerance, e.g. 3 % on every standard
dynamic parameter, regrouped by :func:`build_spread_of`), taken as a
measurement of the spread with ``build_dof`` degrees of freedom
(:data:`DEFAULT_BUILD_DOF`, 20) and pooled with the fleet's (a scaled
inverse-chi-squared prior): spread^2 = (nu0 b^2 + nu Qn^2) / (nu0 + nu) with
nu0 + nu degrees of freedom, where b^2 = build^2 + the median of the arms'
std^2 is the scatter of the estimates the build spread predicts (Qn measures
the same). A build spread given too small raises false alarms: the prior is
trusted as much as 20 arms' worth of data (``bench/fleet.py`` measures both).

The combined s counts an arm's estimation noise twice (once in its std, once
in the spread of the estimates), as defined: conservative where the stds are
right (on simulated logs with white torque noise they are), and a margin
where they are not (a least-squares std assumes white residuals; a
real arm's are not).

Below the fit's round-off. s is at least :data:`RESOLUTION` (1e-9) times the
largest |centre|: on noise-free simulated logs a parameter that is zero on
every arm (a product of inertia of a symmetric link) is found at 1e-15 with
stds of 1e-16, and its scatter is not a difference between arms.

Reference mode (``reference`` given: a known-good model's base parameters, with
their stds when the reference is itself an identification that recorded them).
The centre is the reference; s = sqrt(std^2 + reference std^2 + spread^2), the
spread being the fleet's, as above, when at least :data:`MIN_SPREAD_ARMS` arms
are compared (else 0, and sigma = r). The spread stays in on purpose: against
a reference without stds (the nominal CAD model, an arm identified years ago)
the arms' own stds alone would flag every arm for its ordinary manufacturing
difference; with it, an arm is flagged when it is further from the reference
than arms differ from each other, which a whole fleet that wore alike still
is (the spread measures differences between arms, not their common drift).

Words. A base parameter is named by :func:`parameter_words`: ``fv3`` is
``joint 3 viscous friction``, ``Ia4`` ``joint 4 rotor inertia``, ``M3``
``link 3 mass (M3)``, the regrouped ``ZZ1R`` (``ZZ1 + Ia1 + YY2 + ...``, see
:meth:`~rmdrake.dynamics.base.BaseParameters.expressions`) ``link 1 inertia ZZ
(ZZ1R, regrouped)``. A flag reads ``joint 3 viscous friction +48 % (6.2
sigma)``: the change from the centre relative to it, or, where the centre is
not itself clear of zero by ``threshold`` combined sigmas (a percentage of
nothing), the change in the parameter's SI unit. Flags of the physically
meaningful joint terms (friction, rotor inertia, offsets) come first, then the
inertial base parameters, each in base-parameter order.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence

import numpy as np

from rmdrake.model.robot import DYNAMIC_KEYS, EXTRA_DYNAMIC_KEYS, MOTOR_KEYS

__all__ = [
    "DEFAULT_BUILD_DOF",
    "DEFAULT_FALSE_ALARM",
    "MAD_TO_SIGMA",
    "MAX_THRESHOLD",
    "MIN_SPREAD_ARMS",
    "QN_TO_SIGMA",
    "RESOLUTION",
    "SPREADS",
    "FleetComparison",
    "Flag",
    "build_spread_of",
    "check_threshold",
    "compare_fleet",
    "family_threshold",
    "is_joint_term",
    "parameter_unit",
    "parameter_words",
    "robust_centre",
    "sigma_equivalent",
    "spread_dof",
]

MAD_TO_SIGMA = 1.4826
"""sigma / MAD of a normal distribution (1 / 0.6745)."""
QN_TO_SIGMA = 2.2219
"""sigma / (first quartile of the pairwise distances) of a normal distribution
(Rousseeuw and Croux 1993), before the small-sample factor."""
SPREADS = {"qn": 0.82, "mad": 0.37}
"""The robust spreads :func:`robust_centre` knows and their efficiency at the
normal (the share of the samples a standard deviation would need for the same
precision), which sets their degrees of freedom (:func:`spread_dof`)."""
FLEET_METHODS: tuple[str, ...] = ("wls", "ols")
"""The estimators ``rmdrake fleet`` offers: those that record each base
parameter's standard deviation."""
DEFAULT_FALSE_ALARM = 0.01
"""The chance that a healthy fleet (or arm history) gets any flag at all, which
sets the threshold (:func:`family_threshold`)."""
DEFAULT_BUILD_DOF = 20.0
"""Degrees of freedom of a known build spread (module docstring): the
manufacturer's figure counts as much as a spread measured on 21 arms (Qn:
0.82 x 20 = 16.4 degrees of freedom) and a little more."""
MAX_THRESHOLD = 20.0
"""sigma: the largest threshold given. The family-wise one is 4-5 sigma for
any fleet; beyond 20 a worn arm (+50 % friction is 6-50 sigma on a real log)
is no longer flagged, and the comparison only hides it."""
MIN_SPREAD_ARMS = 3
"""Reference mode: the fewest arms whose spread counts (the spread of one or two
arms is none)."""
RESOLUTION = 1e-9
"""The smallest combined standard deviation, relative to the largest |centre|
(module docstring)."""
# Qn's small-sample factors d_n, n = 2..9 (Croux and Rousseeuw 1992).
_QN_SMALL = (0.399, 0.994, 0.512, 0.844, 0.611, 0.857, 0.669, 0.872)

_ALL_KEYS = DYNAMIC_KEYS + EXTRA_DYNAMIC_KEYS + MOTOR_KEYS
_KEY = re.compile("^(" + "|".join(sorted(_ALL_KEYS, key=len)[::-1]) + r")(\d+)(R?)$")
_JOINT_WORDS = {
    "Ia": "rotor inertia",
    "fv": "viscous friction",
    "fc": "Coulomb friction",
    "fcn": "Coulomb friction at negative velocity",
    "tau0": "torque offset",
}
_MOTOR_WORDS = {  # a coupled motor's (rmdrake.model.transmission)
    "Iam": "rotor inertia",
    "fvm": "viscous friction",
    "fcm": "Coulomb friction",
}
_UNITS = {  # (revolute, prismatic)
    "inertia": ("kg m^2", "kg m^2"),
    "first moment": ("kg m", "kg m"),
    "M": ("kg", "kg"),
    "Ia": ("kg m^2", "kg"),
    "fv": ("N m s/rad", "N s/m"),
    "fc": ("N m", "N"),
    "fcn": ("N m", "N"),
    "tau0": ("N m", "N"),
    "Iam": ("kg m^2", "kg m^2"),
    "fvm": ("N m s/rad", "N m s/rad"),
    "fcm": ("N m", "N m"),
}


def _split(name: str) -> tuple[str, int, bool]:
    """(key, 1-based link or joint, regrouped) of a base parameter name such
    as ``ZZ1R``, ``fv3``, ``tau02``."""
    m = _KEY.match(name)
    if m is None:
        raise ValueError(
            f"base parameter {name!r}: expected a dynamic key "
            f"({', '.join(_ALL_KEYS)}), a link number and "
            "an optional R"
        )
    return m.group(1), int(m.group(2)), m.group(3) == "R"


def is_joint_term(name: str) -> bool:
    """True for a joint's friction, rotor inertia or offset (``Ia``, ``fv``,
    ``fc``, ``fcn``, ``tau0``) or a coupled motor's (``Iam``, ``fvm``,
    ``fcm``): what wear changes, flagged first."""
    key = _split(name)[0]
    return key in _JOINT_WORDS or key in _MOTOR_WORDS


def parameter_words(name: str) -> str:
    """A base parameter in words: ``fv3`` -> ``joint 3 viscous friction``,
    ``fcm6`` -> ``coupled motor 6 Coulomb friction``,
    ``fc3R`` -> ``joint 3 Coulomb friction (fc3R, regrouped)``, ``M2`` ->
    ``link 2 mass (M2)``, ``MX2R`` -> ``link 2 first moment MX (MX2R,
    regrouped)``, ``ZZ1R`` -> ``link 1 inertia ZZ (ZZ1R, regrouped)``.

    Raises:
      ValueError: a name that is not a dynamic key, a number and an optional R.
    """
    key, j, regrouped = _split(name)
    if key in _JOINT_WORDS or key in _MOTOR_WORDS:
        words = (
            f"joint {j} {_JOINT_WORDS[key]}"
            if key in _JOINT_WORDS
            else f"coupled motor {j} {_MOTOR_WORDS[key]}"
        )
        return f"{words} ({name}, regrouped)" if regrouped else words
    if key == "M":
        words = f"link {j} mass"
    elif key.startswith("M"):
        words = f"link {j} first moment {key}"
    else:
        words = f"link {j} inertia {key}"
    return f"{words} ({name}{', regrouped' if regrouped else ''})"


def parameter_unit(name: str, prismatic: bool = False) -> str:
    """The SI unit of a base parameter (that of its kept column: a regrouped
    one adds terms of the same unit): kg m^2, kg m, kg; Ia kg m^2, fv N m s/rad,
    fc, fcn, tau0 N m (``prismatic`` joint: kg, N s/m, N)."""
    key = _split(name)[0]
    kind = key if key in _UNITS else "first moment" if key[0] == "M" else "inertia"
    return _UNITS[kind][bool(prismatic)]


def _qn(x: np.ndarray) -> np.ndarray:
    """(p,) Qn of the m rows of (m, p) ``x``, per column (0 for m < 2)."""
    m, p = x.shape
    if m < 2:
        return np.zeros(p)
    i, k = np.triu_indices(m, 1)
    h = m // 2 + 1
    rank = h * (h - 1) // 2 - 1  # the C(h, 2)-th smallest distance
    if m <= 9:
        d_n = _QN_SMALL[m - 2]
    else:
        d_n = m / (m + 1.4) if m % 2 else m / (m + 3.8)
    d = np.abs(x[i] - x[k])  # (m (m - 1) / 2, p) pairwise distances
    return QN_TO_SIGMA * d_n * np.partition(d, rank, axis=0)[rank]


def check_threshold(threshold: float, what: str = "threshold") -> float:
    """``threshold`` (sigma) when finite, > 0 and at most
    :data:`MAX_THRESHOLD`.

    Raises:
      ValueError: one line naming ``what`` and the bound."""
    if not (np.isfinite(threshold) and threshold > 0):
        raise ValueError(f"{what}: expected a number > 0, found {threshold}")
    if threshold > MAX_THRESHOLD:
        raise ValueError(
            f"{what} {threshold:g} sigma: over the bound of {MAX_THRESHOLD:g} sigma "
            "(it would hide a worn arm; leave it out for the family-wise "
            "threshold of --false-alarm, 4-5 sigma)"
        )
    return float(threshold)


def family_threshold(tests: int, false_alarm: float = DEFAULT_FALSE_ALARM) -> float:
    """The sigma beyond which one of ``tests`` departures is flagged, so that
    ``tests`` healthy ones raise any flag with probability at most
    ``false_alarm`` (Bonferroni: two-sided tail false_alarm / tests each).

    Example: 12 arms x 52 base parameters at 1 % is 624 tests, each allowed a
    two-sided tail of 1.6e-5: 4.31 sigma; 21 arms 4.43, 4 arms 4.06.

    Raises:
      ValueError: tests < 1, false_alarm not in (0, 1).
    """
    from scipy import special

    if int(tests) < 1:
        raise ValueError(f"tests: expected at least 1, found {tests}")
    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm: expected a probability in (0, 1), found "
                         f"{false_alarm}")  # fmt: skip
    return float(-special.ndtri(0.5 * false_alarm / int(tests)))


def build_spread_of(chi: object, regroup: object, relative: object) -> np.ndarray:
    """The arm-to-arm (manufacturing) standard deviation of each base parameter
    when each standard dynamic parameter j varies independently by
    ``relative[j]`` x |chi[j]| (one sigma): sqrt(sum_j K_kj^2 (relative_j
    chi_j)^2), SI units of each base parameter.

    Example: with 3 % on every standard parameter, fv3 (not regrouped) varies
    by 3 % of itself; ZZ1R = ZZ1 + Ia1 + YY2 + ... by 3 % of the root sum of
    squares of its terms, less than 3 % of the sum.

    Args:
      chi: (w,) the nominal robot's standard (or extended) parameters, SI.
      regroup: (p, w) the regrouping matrix, chi_base = K @ chi
        (:attr:`~rmdrake.dynamics.base.BaseParameters.K_full`).
      relative: a relative spread (0.03), one for all, or (w,) one each.

    Raises:
      ValueError: shapes that disagree, a relative spread negative or not
        finite.
    """
    chi = np.asarray(chi, dtype=np.float64)
    K = np.asarray(regroup, dtype=np.float64)
    if chi.ndim != 1 or K.ndim != 2 or K.shape[1] != chi.size:
        raise ValueError(
            f"regroup {K.shape} and chi {chi.shape}: expected (p, w) and (w,)"
        )
    rel = np.broadcast_to(np.asarray(relative, dtype=np.float64), chi.shape)
    if not np.all(np.isfinite(rel)) or np.any(rel < 0):
        raise ValueError("relative: expected spreads >= 0 (0.03 is 3 %)")
    return np.sqrt((K**2) @ (rel * chi) ** 2)


def robust_centre(values: object, spread: str = "qn") -> tuple[np.ndarray, np.ndarray]:
    """(centre, spread) of (m, p) values over the m arms, per parameter: the
    median, and Qn or 1.4826 MAD (``spread``, module docstring), in the
    values' units.

    Raises:
      ValueError: values that are not (m >= 1, p) and finite, an unknown spread.
    """
    x = np.asarray(values, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] == 0:
        raise ValueError(f"values: expected (arms, parameters), found {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("values: expected finite numbers")
    if spread not in SPREADS:
        known = ", ".join(SPREADS)
        raise ValueError(f"spread: expected one of {known}, found {spread!r}")
    centre = np.median(x, axis=0)
    if spread == "mad":
        return centre, MAD_TO_SIGMA * np.median(np.abs(x - centre), axis=0)
    return centre, _qn(x)


def spread_dof(arms: int, spread: str = "qn") -> float:
    """Degrees of freedom of a robust spread of ``arms`` values: those of a
    standard deviation, arms - 1, times the spread's efficiency
    (:data:`SPREADS`); 0 for one arm."""
    return max(SPREADS[spread] * (arms - 1), 0.0)


def sigma_equivalent(ratio: object, dof: object) -> np.ndarray:
    """The standard normal deviate, signed, with the two-sided tail probability
    of ``ratio`` under Student's t with ``dof`` degrees of freedom (inf: the
    ratio itself; 0: 0, nothing can be told). Computed in log space, so far
    departures stay apart (a ratio of 1e20 at 16 degrees of freedom is 38.5
    sigma)."""
    from scipy import special, stats

    r, nu = np.broadcast_arrays(
        np.asarray(ratio, dtype=np.float64), np.asarray(dof, dtype=np.float64)
    )
    out = np.array(r, dtype=np.float64)
    t = np.isfinite(nu) & (nu > 0) & np.isfinite(r) & (r != 0)
    if np.any(t):
        a, v = np.abs(r[t]), nu[t]
        log_tail = stats.t.logsf(a, v)
        # where the tail underflows (far beyond 30 sigma): its power law,
        # log sf = log c + (v - 1) / 2 log v - v log a, c the density's constant
        lc = special.gammaln((v + 1) / 2) - special.gammaln(v / 2)
        lc -= 0.5 * np.log(np.pi * v)
        far = lc + 0.5 * (v - 1) * np.log(v) - v * np.log(a)
        log_tail = np.where(np.isfinite(log_tail), log_tail, far)
        out[t] = np.sign(r[t]) * _log_tail_to_sigma(log_tail)
    out[(nu <= 0) | (r == 0)] = 0.0
    return out


def _log_tail_to_sigma(log_tail: np.ndarray) -> np.ndarray:
    """The normal deviates z >= 0 with log P(N > z) = ``log_tail`` (<= 0)."""
    from scipy import special, stats

    lt = np.minimum(np.asarray(log_tail, dtype=np.float64), 0.0)
    z = np.maximum(stats.norm.isf(np.exp(lt)), 0.0)
    for i in np.flatnonzero(lt < -700.0):  # exp underflows: bisect log_ndtr
        lo, hi = 0.0, float(np.sqrt(-2.0 * lt[i])) + 1.0  # log_ndtr(-z) < -z^2/2
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if special.log_ndtr(-mid) > lt[i] else (lo, mid)
        z[i] = lo
    return z


@dataclasses.dataclass(frozen=True)
class Flag:
    """One parameter where one arm departs from the centre.

    Attributes:
      arm: the arm's name.
      name: the base parameter's name (``fv3``).
      value, centre: the arm's value and the centre's, SI.
      sigma: the combined standard deviation s, SI.
      ratio: (value - centre) / s, signed.
      z: the departure in sigma (module docstring), signed.
      relative: (value - centre) / |centre|, or None where the centre is not
        clear of zero (module docstring).
      unit: the parameter's SI unit.
    """

    arm: str
    name: str
    value: float
    centre: float
    sigma: float
    ratio: float
    z: float
    relative: float | None
    unit: str

    @property
    def words(self) -> str:
        """The parameter in words (:func:`parameter_words`)."""
        return parameter_words(self.name)

    def text(self) -> str:
        """``joint 3 viscous friction +48 % (6.2 sigma)``, or the change in
        SI units where no percentage means anything."""
        if self.relative is not None:
            pct = 100.0 * self.relative
            change = f"{pct:+.0f} %" if abs(pct) >= 10 else f"{pct:+.1f} %"
        else:
            change = f"{self.value - self.centre:+.3g} {self.unit}"
        return f"{self.words} {change} ({abs(self.z):.1f} sigma)"


@dataclasses.dataclass(frozen=True)
class FleetComparison:
    """What :func:`compare_fleet` found.

    Attributes:
      arms: (m,) names of the arms compared.
      names: (p,) base parameter names.
      values, std: (m, p) the arms' parameters and their stds, SI.
      centre: (p,) the fleet median, or the reference's values.
      spread: (p,) the fleet's robust spread (0 in reference mode with fewer
        than :data:`MIN_SPREAD_ARMS` arms).
      reference_std: (p,) the reference's stds (zeros: none, or fleet mode).
      combined: (m, p) combined standard deviations s, SI.
      ratio: (m, p) (value - centre) / s, signed.
      dof: (m, p) effective degrees of freedom of s (inf: the stds alone).
      z: (m, p) signed departures in sigma (module docstring).
      threshold: sigma over which a parameter is flagged.
      false_alarm: the family-wise false-alarm rate that set the threshold
        (:func:`family_threshold` of m x p tests), or None (given).
      build_spread: (p,) the known build spread pooled into the spread, SI,
        or None.
      build_dof: its degrees of freedom (inf: taken as exact).
      reference: the reference's name, or None (fleet mode).
      spread_kind: ``qn`` or ``mad``.
      prismatic: (n,) joints that are prismatic (units), or None.
    """

    arms: tuple[str, ...]
    names: tuple[str, ...]
    values: np.ndarray
    std: np.ndarray
    centre: np.ndarray
    spread: np.ndarray
    reference_std: np.ndarray
    combined: np.ndarray
    ratio: np.ndarray
    dof: np.ndarray
    z: np.ndarray
    threshold: float
    false_alarm: float | None = None
    build_spread: np.ndarray | None = None
    build_dof: float = DEFAULT_BUILD_DOF
    reference: str | None = None
    spread_kind: str = "qn"
    prismatic: tuple[bool, ...] | None = None

    @property
    def order(self) -> np.ndarray:
        """(p,) parameter indices in flag order: joint terms (friction, rotor
        inertia, offsets) first, then the inertial ones, each in base order."""
        joint = np.array([is_joint_term(n) for n in self.names], dtype=bool)
        return np.r_[np.flatnonzero(joint), np.flatnonzero(~joint)]

    def _index(self, arm: int | str) -> int:
        return self.arms.index(arm) if isinstance(arm, str) else int(arm)

    def flags(self, arm: int | str) -> list[Flag]:
        """The flagged parameters of one arm (index or name), in :attr:`order`."""
        i = self._index(arm)
        out = []
        for k in self.order:
            z = float(self.z[i, k])
            if not abs(z) > self.threshold:
                continue
            centre, sigma = float(self.centre[k]), float(self.combined[i, k])
            value = float(self.values[i, k])
            key, j, _ = _split(self.names[k])
            slide = self.prismatic is not None and key in _JOINT_WORDS
            slide = slide and bool(self.prismatic[j - 1])
            clear = abs(centre) > self.threshold * sigma
            out.append(
                Flag(
                    arm=self.arms[i],
                    name=self.names[k],
                    value=value,
                    centre=centre,
                    sigma=sigma,
                    ratio=float(self.ratio[i, k]),
                    z=z,
                    relative=(value - centre) / abs(centre) if clear else None,
                    unit=parameter_unit(self.names[k], slide),
                )
            )
        return out

    @property
    def flagged(self) -> dict[str, list[Flag]]:
        """{arm: its flags} of the arms with at least one flag, in arm order."""
        every = {arm: self.flags(i) for i, arm in enumerate(self.arms)}
        return {arm: f for arm, f in every.items() if f}

    def largest(self, arm: int | str) -> tuple[str, float]:
        """(name, |sigma|) of the arm's parameter furthest from the centre."""
        a = np.abs(self.z[self._index(arm)])
        k = int(np.argmax(a))
        return self.names[k], float(a[k])

    def describe(self) -> str:
        """One line: what the arms were compared with and how."""
        if self.reference is None:
            against = f"the median of {len(self.arms)} arm(s)"
        else:
            against = f"reference '{self.reference}'"
        how = "Qn" if self.spread_kind == "qn" else "1.4826 MAD"
        how += " over the arms"
        if self.build_spread is not None:
            how += f" pooled with the build spread ({self.build_dof:g} dof)"
        beyond = f"flagged beyond {self.threshold:.3g} sigma"
        if self.false_alarm is not None:
            beyond += (
                f" (false alarms {100 * self.false_alarm:g} % over "
                f"{len(self.arms)} x {len(self.names)} tests)"
            )
        return (
            f"compared {len(self.names)} base parameters with {against} "
            f"(spread: {how}); {beyond}"
        )


def _as_matrix(x: object, what: str, shape: tuple[int, int]) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.shape != shape:
        raise ValueError(f"{what}: expected shape {shape}, found {a.shape}")
    return a


def compare_fleet(
    arms: Sequence[str],
    names: Sequence[str],
    values: object,
    std: object,
    *,
    threshold: float | None = None,
    false_alarm: float = DEFAULT_FALSE_ALARM,
    build_spread: object = None,
    build_dof: float = DEFAULT_BUILD_DOF,
    reference: object = None,
    reference_std: object = None,
    reference_name: str = "reference",
    spread: str = "qn",
    prismatic: Sequence[bool] | None = None,
) -> FleetComparison:
    """Compares each arm's base parameters with the fleet's robust centre, or
    with a reference (module docstring).

    Args:
      arms: (m,) arm names (distinct).
      names: (p,) base parameter names (:mod:`rmdrake.dynamics.base`).
      values: (m, p) identified base parameters, SI.
      std: (m, p) their standard deviations, SI (NaN: unknown, 0).
      threshold: sigma over which a parameter is flagged (> 0); None: the
        family-wise one, :func:`family_threshold` of m x p tests.
      false_alarm: the family-wise false-alarm rate of that threshold.
      build_spread: (p,) a known arm-to-arm standard deviation of each base
        parameter, SI (:func:`build_spread_of`), pooled with the fleet's
        (module docstring); None: the fleet's alone.
      build_dof: its degrees of freedom (> 0; inf: exact, the fleet's
        spread is then not used).
      reference: (p,) a known-good model's base parameters (None: fleet mode).
      reference_std: (p,) their stds (None: none known, 0).
      reference_name: names the reference in :meth:`FleetComparison.describe`.
      spread: ``qn`` or ``mad`` (module docstring).
      prismatic: (n,) per joint, for the units of a change printed in SI.

    Raises:
      ValueError: shapes that disagree, repeated arm names, a threshold not
        > 0, no arms, values that are not finite, an unknown name or spread.
    """
    arms, names = tuple(str(a) for a in arms), tuple(str(n) for n in names)
    m, p = len(arms), len(names)
    if m == 0:
        raise ValueError("compare_fleet: no arms to compare")
    if len(set(arms)) != m:
        raise ValueError("arms: names repeat; each arm needs its own")
    if threshold is None:
        threshold = family_threshold(m * p, false_alarm) if p else np.inf
        alarm: float | None = float(false_alarm)
    else:
        threshold, alarm = check_threshold(threshold), None
    for n in names:
        _split(n)
    x = _as_matrix(values, "values", (m, p))
    s = np.nan_to_num(np.abs(_as_matrix(std, "std", (m, p))), nan=0.0)
    centre, fleet_spread = robust_centre(x, spread)
    nu = spread_dof(m, spread)
    ref_std = np.zeros(p)
    if reference is not None:
        centre = np.asarray(reference, dtype=np.float64)
        if centre.shape != (p,) or not np.all(np.isfinite(centre)):
            raise ValueError(f"reference: expected {p} finite values")
        if reference_std is not None:
            ref_std = np.asarray(reference_std, dtype=np.float64)
            if ref_std.shape != (p,):
                raise ValueError(f"reference_std: expected {p} values")
            ref_std = np.nan_to_num(np.abs(ref_std), nan=0.0)
        if m < MIN_SPREAD_ARMS:
            fleet_spread, nu = np.zeros(p), 0.0
    build = None
    if build_spread is not None:
        build = np.abs(np.asarray(build_spread, dtype=np.float64))
        if build.shape != (p,) or not np.all(np.isfinite(build)):
            raise ValueError(f"build_spread: expected {p} finite values")
        if not build_dof > 0:
            raise ValueError(f"build_dof: expected a number > 0, found {build_dof}")
        # the spread of the estimates the build spread predicts: build and
        # the arms' typical estimation noise, as the fleet's spread measures
        prior = np.sqrt(build**2 + np.median(s**2, axis=0))
        if np.isinf(build_dof):
            fleet_spread, nu = prior, np.inf
        else:
            pooled = (build_dof * prior**2 + nu * fleet_spread**2) / (build_dof + nu)
            fleet_spread, nu = np.sqrt(pooled), build_dof + nu
    floor = RESOLUTION * max(float(np.max(np.abs(centre), initial=0.0)), 1e-300)
    combined = np.maximum(np.sqrt(s**2 + ref_std**2 + fleet_spread**2), floor)
    ratio = (x - centre) / combined
    # the spread's own degrees of freedom, not Welch-Satterthwaite's more
    # where the std dominates: that let 12 % of healthy fleets of 4 arms
    # raise a flag (module docstring)
    dof = np.where(fleet_spread > 0, nu, np.inf) * np.ones((m, 1))
    return FleetComparison(
        arms=arms,
        names=names,
        values=x,
        std=s,
        centre=centre,
        spread=fleet_spread,
        reference_std=ref_std,
        combined=combined,
        ratio=ratio,
        dof=dof,
        z=sigma_equivalent(ratio, dof),
        threshold=float(threshold),
        false_alarm=alarm,
        build_spread=build,
        build_dof=float(build_dof),
        reference=None if reference is None else str(reference_name),
        spread_kind=spread,
        prismatic=None if prismatic is None else tuple(bool(v) for v in prismatic),
    )
