"""Is a dynamic identification believable? Refuse on evidence, warn on the rest.

A real arm's torques are never the rigid-body model's plus white noise
(elasticity, sensor offsets and dynamics, cables, a friction law the model
lacks), and a flexible model fits a little of anything. So a wrong robot,
joint order, sign, unit or time base is refused on the evidence it leaves on
the joints that *carry the torque*, and an unexplained share on a joint that
carries little is a warning that names the joint, its share and the likely
causes. Every threshold below was set on every real log in ``../shared/data``
(the Panda of Gaz et al. 2019; the KUKA LWR4+ runs 1-3 of FloBaRoID, joint
torque sensors) and on wrong variants made from each (two loaded joints'
torques swapped, the largest negated, torques in N mm, the torque 0.3 s
late, the other arm's model): ``bench/identification_sanity.py`` prints the
figures quoted here, and tests/dynamics/test_real_log_sanity.py holds them.

Scale and load. Joint j's torque scale is s_j = max(RMS tau_j, ``floor_share``
(0.1) x max_k RMS tau_k), N m (N on a prismatic joint); every share below is
RMS / s_j. Joint j is *loaded* when RMS tau_j >= ``loaded_share`` (0.1) x
max_k RMS tau_k (:func:`~rmdrake.dynamics.log_evidence.loaded_joints`): the
LWR4's joints 2, 4 (and 3 on runs 1-2, 0.12; 0.08 on run 3), the Panda's 1-4.
The LWR4's joints 1, 5, 6, 7 carry 0.01-0.05 of joint 2's torque, mostly
sensor offset (which changes between runs), friction and noise.

Refusals, before the fit (:func:`check_torque_log`, :func:`check_positions`,
:func:`check_torque_unit`):

* **unit**: a joint's 99th-percentile |torque| over ``max_effort_ratio`` (3)
  x its effort limit (N mm: 193-426x on the real logs; right: at most 0.43x),
  or the torque RMS of the loaded joints over ``max_unit_factor`` (10) times,
  or under a tenth of, the prior's prediction on the same motion (geometric
  mean; right LWR4 logs 0.94-0.96 of its URDF's); a constant column;
* **another robot**: over ``max_outside_share`` (1 %) of the samples with a
  joint beyond the robot's limits by more than ``limit_margin`` (2 %) of its
  range (the LWR4's logs with the Panda's model: 99 %, the Panda's with the
  LWR4's: 47 %; right logs: 0 %); positions in degrees do the same.

Refusals, after the fit (:func:`check_identification`; ``validate``'s
:func:`check_prediction` the same on a prediction, the whole log held out),
on the loaded joints only, and only the first of sign, order, time that
applies (a negated torque also fits a shift in time):

1. **sign**: the joint's torque negated and fitted again leaves under
   ``max_flip_ratio`` (0.75) of the residual (negated variants 0.03-0.13;
   right loaded joints 1.4 or more; unloaded joints 0.5-0.9 on noise, so not
   judged);
2. **joint order**: two loaded joints with their torques exchanged leave
   under ``max_swap_ratio`` (0.75) of the pair's residual (swapped variants
   0.02-0.33; right logs 3.0 or more);
3. **time base**: the torque shifted by the lag of least residual
   (:data:`~rmdrake.dynamics.log_evidence.LAG_RANGE` either way) is over
   ``min_lag`` (0.1 s) away and leaves at most ``max_lag_ratio`` (0.97) of
   the residual energy (0.3 s late: +0.30-0.32 s at 0.01-0.92x; right logs:
   at most 0.04 s, 0.99-1.00x; a lag under 0.1 s is what a torque filter
   does);
4. **held out**: the least-squares fit of the first ``fit_fraction`` (70 %) of
   the log predicts the rest with over ``max_heldout_share`` (1/3) of the
   scale unexplained (right loaded joints: at most 11.8 % (LWR4 joint 3);
   the Panda's joint 1 9.6 %; simulated RV-3SB logs with an unmodelled
   Stribeck friction, a 50 ms torque low-pass or a cable spring at most
   21 %; joints swapped in the motion columns 45 %, another arm's
   kinematics 47-58 %);
5. **undetermined**: a base parameter with a relative std (100 std / |x|,
   the least-squares covariance, or Gautier's WLS one at x for ``physical``)
   over ``max_relative_std`` (100 %) that carries over ``min_share`` (10 %)
   of a joint's torque RMS: the trajectory does not excite it.

Warnings (the model is written):

* a loaded joint over ``warn_share`` (10 %) of its scale, fit or held out:
  effects the model lacks (friction law, elasticity, sensor dynamics);
* a joint that carries little torque over ``warn_share``: on the real LWR4
  joint 1 38 %, joint 5 14 %, joint 7 13 % of the scale (1.4, 1.0, 0.26 N m
  RMS): a sensor offset (``--terms offset``), a friction law, noise;
* link masses over ``max_mass_factor`` (10) x off the prior's by over
  ``min_mass_share`` (5 %) of its total (:func:`check_masses`): a link mass
  the torques do not determine (the LWR4's physical fit puts 28.6 kg on
  link 2, whose mass no joint torque sees); a log in another unit is refused
  by its scale above.

And :func:`check_prior` raises ValueError for a prior that is not physical
(:func:`~rmdrake.model.dynamic_parameters.check_physical`), has other
kinematics than the robot (:func:`rmdrake.model.same_robot.check_same_robot`:
an MDH length off by over ``max_length_error`` (0.02 m) + 10 %, an angle by
over ``max_angle_error`` (0.05 rad)) or a total mass over ``max_mass_factor``
(10) times the robot's own.

Messages: a refusal is one headline (what was decided) and one short line
per reason; a warning the same, e.g.::

    the model leaves joints that carry little torque unexplained (written):
      joint 1: 37.7 % of its torque scale (1.41 N m RMS)
      likely a sensor offset (try --terms offset), friction, or noise
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.dynamics.identification import HELDOUT_FRACTION, Identification
from rmdrake.dynamics.log_evidence import (
    LogEvidence,
    fit_evidence,
    loaded_joints,
    positions_outside,
    prediction_evidence,
)
from rmdrake.dynamics.observations import ReducedObservations, heldout_split
from rmdrake.model.dynamic_parameters import check_physical, standard_parameters
from rmdrake.model.robot import RobotModel
from rmdrake.model.same_robot import (
    MAX_ANGLE_ERROR,
    MAX_LENGTH_ERROR,
    check_same_robot,
)

__all__ = [
    "IdentificationBounds",
    "IdentificationSanity",
    "check_identification",
    "check_log",
    "check_masses",
    "check_positions",
    "check_prediction",
    "check_prior",
    "check_torque_log",
    "check_torque_unit",
    "torque_scale",
    "torque_unit_factor",
]


@dataclasses.dataclass(frozen=True)
class IdentificationBounds:
    """Thresholds of the checks (the module docstring gives the cases that
    set them).

    Attributes:
      floor_share: fraction of the largest joint torque RMS under which no
        joint's torque scale falls.
      loaded_share: fraction of the largest joint torque RMS a joint carries
        to be judged (loaded).
      warn_share: share of the torque scale a residual (in-sample or held
        out) must exceed to warn.
      max_heldout_share: share of the torque scale over which the held-out
        (or ``validate``'s) residual of a loaded joint refuses.
      fit_fraction: the first part of the log fitted for the held-out check.
      max_flip_ratio: residual with a loaded joint's torque negated over the
        logged one, under which the sign is refused.
      max_swap_ratio: residual of two loaded joints with their torques
        exchanged over the logged one, under which the order is refused.
      min_lag: s, smallest lag of least residual that refuses the time base.
      max_lag_ratio: residual energy at that lag over the unshifted one, at or
        under which the time base is refused.
      min_share: fraction of a joint's torque RMS an undetermined parameter
        must carry to fail.
      max_relative_std: %, largest relative std of a parameter carrying
        ``min_share`` of a torque.
      max_mass_factor: largest ratio of an identified (or a prior's total)
        mass to the reference, either way.
      min_mass_share: fraction of the prior's total mass a link's mass must
        differ by for the factor to count.
      max_effort_ratio: largest 99th-percentile |torque| over the effort limit.
      max_unit_factor: largest ratio, either way, of the loaded joints'
        torque RMS to the prior's prediction.
      constant_share: torque std over the effort limit at or under which a
        joint's torque is constant.
      limit_margin: fraction of a joint's range a position may pass a limit
        by before the sample counts as outside.
      max_outside_share: largest share of samples outside the limits.
      max_length_error: m, MDH length difference allowed between the robot
        and a prior (plus 10 % of the length).
      max_angle_error: rad, MDH angle difference allowed.
    """

    floor_share: float = 0.10
    loaded_share: float = 0.10
    warn_share: float = 0.10
    max_heldout_share: float = 1.0 / 3.0
    fit_fraction: float = HELDOUT_FRACTION
    max_flip_ratio: float = 0.75
    max_swap_ratio: float = 0.75
    min_lag: float = 0.1
    max_lag_ratio: float = 0.97
    min_share: float = 0.10
    max_relative_std: float = 100.0
    max_mass_factor: float = 10.0
    min_mass_share: float = 0.05
    max_effort_ratio: float = 3.0
    max_unit_factor: float = 10.0
    constant_share: float = 1e-6
    limit_margin: float = 0.02
    max_outside_share: float = 0.01
    max_length_error: float = MAX_LENGTH_ERROR
    max_angle_error: float = MAX_ANGLE_ERROR


@dataclasses.dataclass(frozen=True)
class IdentificationSanity:
    """The outcome of :func:`check_identification` or :func:`check_prediction`.

    Attributes:
      reasons: one line per failed check (empty: plausible).
      warnings: one warning each: a headline, then indented lines.
      scale: (n,) torque scale per joint, N m or N.
      loaded: (n,) bool, the joints judged (module docstring).
      residual_rms: (n,) RMS residual per joint (in-sample), N m or N.
      heldout_rms: (n,) RMS residual of the held-out prediction, N m or N.
      flip_ratio: (n,) residual with the joint's torque negated over the
        logged one.
      evidence: the shift and swap evidence (None when not measured: no
        samples given).
      relative_std: (p,) relative std per base parameter, % (empty for
        :func:`check_prediction`).
      share: (p,) largest share of a joint's torque RMS per base parameter.
    """

    reasons: tuple[str, ...]
    warnings: tuple[str, ...]
    scale: np.ndarray
    loaded: np.ndarray
    residual_rms: np.ndarray
    heldout_rms: np.ndarray
    flip_ratio: np.ndarray
    evidence: LogEvidence | None = None
    relative_std: np.ndarray = dataclasses.field(default=None, repr=False)
    share: np.ndarray = dataclasses.field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """True when every check passed (warnings allowed)."""
        return not self.reasons

    def summary(self) -> str:
        """One line: the verdict and the unexplained shares per joint."""
        head = "plausible" if self.ok else f"IMPLAUSIBLE ({len(self.reasons)})"
        if self.warnings:
            head += f", {len(self.warnings)} warning(s)"
        pairs = ", ".join(
            f"{100 * r:.3g}/{100 * h:.3g}{'' if load else '*'}"
            for r, h, load in zip(
                self.residual_rms / self.scale,
                self.heldout_rms / self.scale,
                self.loaded,
                strict=True,
            )
        )
        return (
            f"sanity: {head}; unexplained % of the torque scale per joint "
            f"(fit/held-out; *: carries little torque): {pairs}"
        )


def torque_scale(tau: np.ndarray, floor_share: float = 0.10) -> np.ndarray:
    """(n,) torque scale per joint of efforts (N, n), N m or N:
    max(RMS tau_j, ``floor_share`` max_k RMS tau_k) (module docstring)."""
    rms = np.sqrt(np.mean(np.asarray(tau, dtype=np.float64) ** 2, axis=0))
    return _floored_scale(rms, floor_share)


def _floored_scale(rms: np.ndarray, floor_share: float) -> np.ndarray:
    """(n,) max(rms_j, ``floor_share`` max_k rms_k): the torque scale of
    per-joint RMS efforts ``rms``, N m or N."""
    return np.maximum(rms, max(floor_share * float(rms.max()), 1e-300))


def _joint_list(index: np.ndarray) -> str:
    """``joints 2, 3 and 4`` (or ``joint 2``) of 0-based ``index``."""
    names = [str(j + 1) for j in index]
    if len(names) == 1:
        return f"joint {names[0]}"
    return f"joints {', '.join(names[:-1])} and {names[-1]}"


def _warning(headline: str, lines: list[str]) -> str:
    """A warning: the headline, then one indented line each."""
    return "\n".join([headline, *(f"  {line}" for line in lines)])


def _judge(
    residual: np.ndarray,
    heldout: np.ndarray,
    flip: np.ndarray,
    scale: np.ndarray,
    torque_rms: np.ndarray,
    loaded: np.ndarray,
    evidence: LogEvidence | None,
    b: IdentificationBounds,
    held_what: str,
) -> tuple[list[str], list[str]]:
    """Reasons and warnings of refusals 1-4 and the unexplained-share warnings
    of the module docstring on the ``loaded`` joints (the one rule of
    ``identify`` and ``validate``)."""
    reasons, warnings = [], []
    flipped = np.flatnonzero(loaded & (flip < b.max_flip_ratio))
    for j in flipped:
        reasons.append(
            f"sign: joint {j + 1}'s torque negated leaves {flip[j]:.2g}x the "
            f"residual (under {b.max_flip_ratio:g}x): negate it or check --robot"
        )
    if evidence is not None and not reasons:
        for a, c, ratio in evidence.swaps:
            if ratio < b.max_swap_ratio:
                reasons.append(
                    f"joint order: joints {a + 1} and {c + 1} exchanged leave "
                    f"{ratio:.2g}x the residual (under {b.max_swap_ratio:g}x): "
                    "reorder the log's columns"
                )
    if evidence is not None and not reasons:
        lag, ratio = evidence.lag, evidence.lag_ratio
        if abs(lag) >= b.min_lag and ratio <= b.max_lag_ratio:
            late = "late" if lag > 0 else "early"
            reasons.append(
                f"time base: the torque {abs(lag):.2g} s {late} leaves "
                f"{ratio:.2g}x the residual (over {b.min_lag:g} s, at most "
                f"{b.max_lag_ratio:g}x): align the log's time stamps"
            )
    held = heldout / scale
    bad = np.flatnonzero(loaded & (held > b.max_heldout_share))
    if bad.size:
        listed = ", ".join(f"joint {j + 1} {100 * held[j]:.3g} %" for j in bad)
        reasons.append(
            f"{held_what}: {listed} unexplained (over "
            f"{100 * b.max_heldout_share:.3g} % on a loaded joint): wrong robot, "
            "order, sign or time"
        )
    if reasons:
        return reasons, warnings
    share = np.maximum(residual, heldout) / scale
    for judged, headline, cause in (
        (
            True,
            "the model leaves part of the torque unexplained (written):",
            "effects it lacks (friction law, elasticity, sensor dynamics, "
            "cables): try --terms, or accept",
        ),
        (
            False,
            "the model leaves joints that carry little torque unexplained (written):",
            "likely a sensor offset (try --terms offset), friction, or noise",
        ),
    ):
        loose = np.flatnonzero((loaded == judged) & (share > b.warn_share))
        if loose.size:
            lines = [
                f"joint {j + 1}: {100 * share[j]:.3g} % of its torque scale "
                f"(RMS {torque_rms[j]:.3g})"
                for j in loose
            ]
            warnings.append(_warning(headline, [*lines, cause]))
    return reasons, warnings


def _heldout_and_flip(
    obs: ReducedObservations, fraction: float
) -> tuple[np.ndarray, np.ndarray]:
    """(n,) RMS residual of the least-squares fit of the first ``fraction``
    of the samples predicting the rest, and (n,) per joint the RMS residual of
    the whole-log fit with that joint's torque negated over the logged one.

    Raises:
      ValueError: the observations have no segment boundary at ``fraction``
        (identify with ``heldout_fraction`` = ``fraction``)."""
    N = obs.n_samples
    k = heldout_split(N, fraction)
    try:
        cut = obs.segments_before(k)
    except ValueError as e:
        raise ValueError(
            f"fit_fraction {fraction:g}: {e}; identify with heldout_fraction="
            f"{fraction:g}"
        ) from None
    x = obs.minimum_norm_solution(slice(0, cut))
    heldout = np.sqrt(obs.residual_sum_squares(x, slice(cut, None)) / (N - k))
    logged = obs.residual_sum_squares(obs.minimum_norm_solution())
    flip = np.empty(obs.n_joints)
    for j in range(obs.n_joints):
        negated = obs.negated(j)
        rss = negated.residual_sum_squares(negated.minimum_norm_solution())
        flip[j] = np.sqrt(rss[j]) / max(float(np.sqrt(logged[j])), 1e-300)
    return heldout, flip


def _relative_std(result: Identification) -> np.ndarray:
    """(p,) 100 std / |x| of the result's parameters x, with the estimator's std
    or, when it has none (``physical``), the covariance of Gautier's weighted
    least squares at x: sigma^2 (A_w^T A_w)^-1, rows of joint j weighted by
    1 / (its RMS residual), sigma^2 the weighted RSS over rows - p."""
    x = np.asarray(result.params, dtype=np.float64)
    std = result.std
    if std is None:
        obs = result.observations
        rss = obs.residual_sum_squares(x)
        joint = np.sqrt(rss / obs.n_samples)
        joint = np.maximum(joint, 1e-12 * max(float(joint.max()), 1e-300))
        w = 1.0 / joint
        p = obs.n_parameters
        Rw = obs.factor(w)[:p, :p]
        sigma2 = float(np.sum(w**2 * rss)) / max(obs.n_rows - p, 1)
        std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(Rw.T @ Rw)), 0) * sigma2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 100.0 * np.asarray(std) / np.abs(x)


def check_identification(
    result: Identification,
    *,
    model: RobotModel | None = None,
    samples: object = None,
    bounds: IdentificationBounds | None = None,
) -> IdentificationSanity:
    """Runs the after-fit refusals and warnings of the module docstring.

    Args:
      result: what :func:`~rmdrake.dynamics.identification.identify` returned.
      model, samples: the robot and the
        :class:`~rmdrake.dynamics.data.JointSamples` it was identified from:
        given both, the joint-order and time-base evidence is measured too
        (else only sign, held-out share and undetermined parameters).
      bounds: thresholds (default :class:`IdentificationBounds`()).
    """
    b = bounds or IdentificationBounds()
    obs = result.observations
    N, p = obs.n_samples, obs.n_parameters
    columns = obs.column_sum_squares()  # (n, p + 1): ||A_j[:, i]||^2, ||b_j||^2
    torque_rms = np.sqrt(columns[:, p] / N)
    scale = _floored_scale(torque_rms, b.floor_share)
    residual = np.asarray(result.residual_rms, dtype=np.float64)
    heldout, flip = _heldout_and_flip(obs, b.fit_fraction)
    loaded = loaded_joints(torque_rms, b.loaded_share)
    evidence = None
    if model is not None and samples is not None:
        s = samples

        def regressor(rows: np.ndarray) -> np.ndarray:
            return result.base.regressor(
                model,
                s.q[rows],
                s.qd[rows],
                s.qdd[rows],
                coulomb_width=result.coulomb_width,
            )

        evidence = fit_evidence(regressor, s.tau, s.t, s.rate, loaded)
    reasons, warnings = _judge(
        residual, heldout, flip, scale, torque_rms, loaded, evidence, b, "held out"
    )
    rel = _relative_std(result)
    # RMS over the samples of A_ji x_i, per joint j (rows) and parameter i
    part = np.abs(result.params) * np.sqrt(columns[:, :p] / N)
    per_joint = part / np.maximum(torque_rms, 1e-300)[:, None]
    joint_of = np.argmax(per_joint, axis=0)
    share = per_joint[joint_of, np.arange(p)]
    undetermined = ~(rel <= b.max_relative_std)
    on_loaded = np.max(np.where(loaded[:, None], per_joint, 0.0), axis=0)
    for refuse in (True, False):
        # refused: carrying a loaded joint's torque; else warned
        if refuse:
            loose = np.flatnonzero(undetermined & (on_loaded > b.min_share))
        else:
            loose = np.flatnonzero(
                undetermined & (on_loaded <= b.min_share) & (share > b.min_share)
            )
        if not loose.size:
            continue
        loose = loose[np.argsort(-share[loose], kind="stable")]
        names = result.base.names
        lines = [
            f"{names[i]} (std {rel[i]:.3g} %, {100 * share[i]:.3g} % of joint "
            f"{joint_of[i] + 1})"
            for i in loose[:2]
        ]
        more = f" and {loose.size - 2} more" if loose.size > 2 else ""
        if refuse:
            reasons.append(
                f"undetermined: {', '.join(lines)}{more}: over "
                f"{b.max_relative_std:g} % std and {100 * b.min_share:g} % of a "
                "loaded joint's torque; excite longer or faster"
            )
        else:
            warnings.append(
                _warning(
                    f"{loose.size} base parameter(s) the data do not determine, "
                    "on joints that carry little torque (written):",
                    [*lines, "excite them longer or faster to pin them down"],
                )
            )
    return IdentificationSanity(
        reasons=tuple(reasons),
        warnings=tuple(warnings),
        scale=scale,
        loaded=loaded,
        residual_rms=residual,
        heldout_rms=heldout,
        flip_ratio=flip,
        evidence=evidence,
        relative_std=rel,
        share=share,
    )


def check_prediction(
    predicted: np.ndarray,
    measured: np.ndarray,
    *,
    t: np.ndarray | None = None,
    rate: float | None = None,
    bounds: IdentificationBounds | None = None,
) -> IdentificationSanity:
    """The after-fit refusals and warnings of the module docstring on a
    model's predicted efforts against a log it was not fitted to
    (``validate``): the whole log is held out; a loaded joint's sign is
    refused when RMS(predicted + measured) is under ``max_flip_ratio`` times
    RMS(predicted - measured); order and time base are judged on the
    prediction shifted and swapped when ``t`` and ``rate`` are given.

    Args:
      predicted, measured: (N, n) efforts, N m or N.
      t: (N,) s, the samples' times; rate: Hz.
    """
    b = bounds or IdentificationBounds()
    predicted = np.asarray(predicted, dtype=np.float64)
    measured = np.asarray(measured, dtype=np.float64)
    torque_rms = np.sqrt(np.mean(measured**2, axis=0))
    scale = _floored_scale(torque_rms, b.floor_share)
    error = np.sqrt(np.mean((predicted - measured) ** 2, axis=0))
    negated = np.sqrt(np.mean((predicted + measured) ** 2, axis=0))
    flip = negated / np.maximum(error, 1e-300)
    loaded = loaded_joints(torque_rms, b.loaded_share)
    evidence = None
    if t is not None and rate is not None:
        evidence = prediction_evidence(predicted, measured, t, rate, loaded)
    reasons, warnings = _judge(
        error, error, flip, scale, torque_rms, loaded, evidence, b, "prediction"
    )
    return IdentificationSanity(
        reasons=tuple(reasons),
        warnings=tuple(warnings),
        scale=scale,
        loaded=loaded,
        residual_rms=error,
        heldout_rms=error,
        flip_ratio=flip,
        evidence=evidence,
        relative_std=np.empty(0),
        share=np.empty(0),
    )


def check_torque_log(
    tau: np.ndarray,
    effort: np.ndarray,
    bounds: IdentificationBounds | None = None,
) -> list[str]:
    """Reasons (one line each, empty: fine) why a torque log (N, n), N m or N,
    cannot be a log of a robot with effort limits ``effort`` (n,): a constant
    joint torque, or one far over its limit (module docstring)."""
    b = bounds or IdentificationBounds()
    tau = np.asarray(tau, dtype=np.float64)
    effort = np.broadcast_to(np.asarray(effort, dtype=np.float64), tau.shape[1:])
    usable = np.isfinite(effort) & (effort > 0)
    limit = np.where(usable, effort, 1.0)
    reasons = []
    std = tau.std(axis=0)
    constant = np.flatnonzero(usable & (std <= b.constant_share * limit))
    if constant.size or not np.any(std > 0):
        joints = ", ".join(str(j + 1) for j in constant) or "all"
        reasons.append(
            f"torque log: joint(s) {joints} constant: the torque was not logged; "
            "check the tau columns (currents: give --gains)"
        )
    ratio = np.where(usable, np.percentile(np.abs(tau), 99, axis=0) / limit, 0.0)
    over = np.flatnonzero(ratio > b.max_effort_ratio)
    if over.size:
        j = over[np.argmax(ratio[over])]
        reasons.append(
            f"unit: the 99th-percentile |torque| of {_joint_list(over)} is up to "
            f"{ratio[j]:.3g}x the effort limit (joint {j + 1}; over "
            f"{b.max_effort_ratio:g}x): N mm? convert the log or check --robot"
        )
    return reasons


def torque_unit_factor(
    tau: np.ndarray, prior_tau: np.ndarray, loaded_share: float = 0.10
) -> tuple[float, np.ndarray]:
    """(factor, loaded): the geometric mean over the loaded joints of the
    logged torque RMS over the prior's prediction on the same motion, both
    (N, n) in N m or N, and the (n,) loaded joints with a non-zero prediction
    (the factor is nan when there is none).

    >>> import numpy as np
    >>> tau = np.array([[1.0, 20.0], [-1.0, -20.0]])
    >>> factor, loaded = torque_unit_factor(1e3 * tau, tau)  # a log in N mm
    >>> round(factor), loaded.tolist()
    (1000, [False, True])
    """
    rms = np.sqrt(np.mean(np.asarray(tau, dtype=np.float64) ** 2, axis=0))
    prior = np.sqrt(np.mean(np.asarray(prior_tau, dtype=np.float64) ** 2, axis=0))
    loaded = loaded_joints(rms, loaded_share) & (prior > 0)
    if not loaded.any():
        return float("nan"), loaded
    return float(np.exp(np.mean(np.log(rms[loaded] / prior[loaded])))), loaded


def check_torque_unit(
    tau: np.ndarray,
    prior_tau: np.ndarray,
    bounds: IdentificationBounds | None = None,
) -> list[str]:
    """Reasons (one line, or empty) why a torque log (N, n) is in another unit
    than the prior's prediction (N, n) on the same motion, N m or N: the
    loaded joints' RMS ratio (geometric mean) over ``max_unit_factor`` either
    way (module docstring)."""
    b = bounds or IdentificationBounds()
    factor, loaded = torque_unit_factor(tau, prior_tau, b.loaded_share)
    if not loaded.any() or 1.0 / b.max_unit_factor <= factor <= b.max_unit_factor:
        return []
    return [
        f"unit: the torque of {_joint_list(np.flatnonzero(loaded))} is {factor:.3g}x "
        f"the prior's prediction on the same motion (limit {b.max_unit_factor:g}x "
        "either way): convert the log (N m, N) or check --robot/--prior"
    ]


def check_positions(
    q: np.ndarray,
    model: RobotModel,
    bounds: IdentificationBounds | None = None,
) -> list[str]:
    """Reasons (one line, or empty) why joint positions (N, n), rad or m,
    cannot be ``model``'s: over ``max_outside_share`` of the samples beyond its
    limits by over ``limit_margin`` of the range (module docstring)."""
    b = bounds or IdentificationBounds()
    limits = model.limits
    share, past = positions_outside(q, limits.lower, limits.upper, b.limit_margin)
    if share <= b.max_outside_share:
        return []
    j = int(np.argmax(past / np.maximum(limits.upper - limits.lower, 1e-300)))
    unit = "m" if model.sigma[j] else "rad"
    return [
        f"positions: {100 * share:.3g} % of the samples leave the joint limits "
        f"of robot '{model.name}' (joint {j + 1} by up to {past[j]:.3g} {unit}): "
        "another robot, or positions in degrees; check --robot"
    ]


def check_log(
    samples: object,
    model: RobotModel,
    effort: np.ndarray,
    prior: RobotModel | None = None,
    bounds: IdentificationBounds | None = None,
) -> list[str]:
    """The before-fit refusals of the module docstring on prepared
    :class:`~rmdrake.dynamics.data.JointSamples`: the torque log against the
    effort limits (n,) (:func:`check_torque_log`), the positions against
    ``model``'s limits (:func:`check_positions`) and, when ``prior`` (a model
    of this robot, the same joint count) has dynamics, the torque's unit
    against its prediction on at most
    :data:`~rmdrake.dynamics.log_evidence.EVIDENCE_SAMPLES` samples
    (:func:`check_torque_unit`)."""
    from rmdrake.dynamics.log_evidence import EVIDENCE_SAMPLES
    from rmdrake.dynamics.regressor import torques

    s = samples
    reasons = check_torque_log(s.tau, effort, bounds)
    reasons += check_positions(s.q, model, bounds)
    if prior is not None and prior.dynamics is not None and not reasons:
        if prior.n_joints == model.n_joints:
            rows = np.unique(
                np.linspace(0, s.n_samples - 1, EVIDENCE_SAMPLES).astype(int)
            )
            predicted = torques(
                prior, s.q[rows], s.qd[rows], s.qdd[rows], standard_parameters(prior)
            )
            reasons += check_torque_unit(s.tau[rows], predicted, bounds)
    return reasons


def _total_mass(model: RobotModel) -> float | None:
    """Sum of the link masses of ``model``'s dynamics, kg (None without)."""
    return None if model.dynamics is None else float(np.sum(model.dynamics[:, 9]))


def check_prior(
    model: RobotModel,
    prior: RobotModel,
    bounds: IdentificationBounds | None = None,
) -> None:
    """Refuses, before the fit, a prior that is not physical or not this
    robot (module docstring); the prior may be ``model`` itself.

    Raises:
      ValueError: one line naming the prior, the link or MDH entry and the
        figure.
    """
    b = bounds or IdentificationBounds()
    if prior.dynamics is None or prior.n_joints != model.n_joints:
        return  # a joint count that differs: identify's refusal
    report = check_physical(standard_parameters(prior))
    if not report.ok:
        j, check, detail = report.failures[0]
        raise ValueError(
            f"prior: robot '{prior.name}' is not physical: link {j}: {check} fails "
            f"({detail}); give a physical prior with --prior"
        )
    if prior is model:
        return
    check_same_robot(
        model,
        prior,
        what="prior",
        remedy="give this robot's own dynamics with --prior",
        max_length_error=b.max_length_error,
        max_angle_error=b.max_angle_error,
    )
    own = _total_mass(model)
    if own is None and model.mass_bounds is not None:
        if model.mass_bounds.total is not None:
            lo, hi = model.mass_bounds.total
            own = float(np.sqrt(lo * hi)) if np.isfinite(hi) and lo > 0 else None
    mass = _total_mass(prior)
    if own is not None and own > 0 and mass is not None:
        factor = max(mass / own, own / max(mass, 1e-300))
        if factor > b.max_mass_factor:
            raise ValueError(
                f"prior: robot '{prior.name}' weighs {mass:.4g} kg, {factor:.3g}x "
                f"off robot '{model.name}''s {own:.4g} kg (limit "
                f"{b.max_mass_factor:g}x); give this robot's own dynamics with "
                "--prior"
            )


def check_masses(
    masses: np.ndarray,
    prior_masses: np.ndarray | None,
    bounds: IdentificationBounds | None = None,
) -> list[str]:
    """Warnings (module docstring; one headline and a line per link, or
    empty) for identified link masses (n,), kg, far from the prior's (n,) kg
    (None: no check)."""
    b = bounds or IdentificationBounds()
    if prior_masses is None:
        return []
    m = np.asarray(masses, dtype=np.float64)
    m0 = np.asarray(prior_masses, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.maximum(m / m0, m0 / m)
    factor = np.where(np.isfinite(factor), factor, np.inf)
    far = (factor > b.max_mass_factor) & (
        np.abs(m - m0) > b.min_mass_share * float(np.sum(np.abs(m0)))
    )
    if not far.any():
        return []
    lines = [
        f"link {j + 1}: {m[j]:.4g} kg (prior {m0[j]:.4g} kg)"
        for j in np.flatnonzero(far)
    ]
    return [
        _warning(
            f"identified link masses over {b.max_mass_factor:g}x off the prior's "
            "(written):",
            [
                *lines,
                "masses the torques do not determine: bound them with "
                "--mass-bounds or give --prior",
            ],
        )
    ]
