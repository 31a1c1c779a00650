"""Is a dynamic identification believable? Checks before and after the fit.

A real arm's torques are never the rigid-body model's plus white noise
(elasticity, sensor dynamics, cables, a friction law the model lacks), so the
residual is judged against the *torque scale of the arm*, not against the
log's own noise floor (on the real Panda log the estimated floor puts a good
fit at 1.5-3.9x noise; on a filtered or quantised log it is 10^3-10^4x).

Scale. Joint j's torque scale is s_j = max(RMS tau_j, ``floor_share`` (0.1)
x max_k RMS tau_k), N m (N on a prismatic joint): a vertical first axis or
a wrist that carries little torque is judged against a tenth of the arm's
largest joint, not against its own small torque. Every share below is
RMS / s_j.

After the fit (:func:`check_identification`, and :func:`check_prediction`
for ``validate``), one line per failed check, the numbers named:

1. **Held-out share over ``max_heldout_share`` (1/3) refuses.** The log is
   split in time; the least-squares fit of the base parameters on the first
   ``fit_fraction`` (70 %) predicts the rest. A wrong model does not
   generalise. Measured on simulated RV-3SB logs (50 Hz; largest joint share,
   in-sample / held-out): at a torque noise of 1 % of the effort limits, clean
   11 / 11 %, an unmodelled Stribeck friction 13 / 17 %, a 20 ms first-order
   torque-sensor low-pass 9 / 10 %, a cable spring on joint 1 22 / 22 %; at
   0.1 % noise (the settings of tests/dynamics/test_identification_sanity.py)
   the largest shares are 11.9 % (Stribeck), 13.3 % (a 50 ms low-pass) and
   20.8 % (the spring); but joints 2 and 3 swapped 45 / 46 %, joint 2's sign
   flipped 43 / 72 %, the log identified with the DEMO arm's kinematics
   47 / 58 %, torque 0.3 s late 52 / 84 % (0.1 s late: 37 %, refused; 40 ms
   late: 23 %, warned only: a lag that small is what a torque filter does).
   Real Panda (Gaz 2019, 1 kHz, 10 Hz cut-off), ols, wls, physical: 9.1 /
   9.3 % (joint 1), the rest under 5 %. ``validate`` predicts with a model
   fitted elsewhere: the whole log is held out, the same threshold applies to
   its prediction error.
2. **A sign the data reverse refuses.** For each joint, the torque column
   negated is fitted again (``validate``: compared with the prediction); a
   residual on that joint under ``max_flip_ratio`` (0.75) of the logged one
   means the log's sign convention differs from the robot's. Measured
   ratios: joint 2 flipped 0.50; clean 1.07 or more; the Panda 1.01 (joint 7)
   to 37.
3. **An unexplained share over ``warn_share`` (10 %) warns** (in-sample or
   held-out), naming each joint's share: effects the model lacks, not a
   wrong model.
4. **A base parameter the data do not determine.** Relative std
   (100 std / |x|, the least-squares covariance sigma^2 (A^T A)^-1 of the
   estimator, or Gautier's WLS one at x for ``physical``) over ``max_relative_std``
   (100 %) *and* a share of some joint's torque, RMS(A_ij x_i) / RMS(b_j),
   over ``min_share`` (10 %). Small parameters (products of inertia of
   nearly symmetric links) routinely have relative stds of several hundred
   per cent on clean data; they carry under 1 % of any torque and are
   harmless. A parameter that carries a tenth of a torque and is not
   distinguishable from zero means a trajectory that does not excite the
   robot (too short, too slow) and a model that will predict wrong torques.
5. **Link masses far from the prior's** (:func:`check_masses`): a link whose
   identified mass is over ``max_mass_factor`` (10) times the prior's or
   under a tenth of it, by more than ``min_mass_share`` (5 %) of the prior's
   total mass (light links move freely: the real Panda's unbounded physical
   fit puts 39 kg on link 3). The fit is already held inside ``mass_bounds``.

Before the fit (:func:`check_torque_log`, reasons as above): a joint's torque
constant (its standard deviation at most ``constant_share`` (1e-6) of its
effort limit: the column was not logged) or its 99th-percentile |torque| over
``max_effort_ratio`` (3) times its effort limit (a log in N mm is ~1000x;
the real Panda's log is at most 0.43x, the RV-3SB logs of the tests 0.35x). And
:func:`check_prior` raises ValueError for a prior that is not physical
(:func:`~rmdrake.model.dynamic_parameters.check_physical`), has other
kinematics than the robot (:func:`rmdrake.model.same_robot.check_same_robot`:
an MDH length off by over ``max_length_error``
(0.02 m) + 10 %, an angle by over ``max_angle_error`` (0.05 rad): calibration
errors are mm and mrad) or a total mass over ``max_mass_factor`` (10) times
the robot's own (or outside its ``mass_bounds.total`` by that factor).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.dynamics.identification import HELDOUT_FRACTION, Identification
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
    "check_masses",
    "check_prediction",
    "check_prior",
    "check_torque_log",
    "torque_scale",
]


@dataclasses.dataclass(frozen=True)
class IdentificationBounds:
    """Thresholds of the checks (see the module docstring for the figures).

    Attributes:
      floor_share: fraction of the largest joint torque RMS under which no
        joint's torque scale falls.
      warn_share: share of the torque scale a residual (in-sample or held
        out) must exceed to warn.
      max_heldout_share: share of the torque scale over which the held-out
        (or ``validate``'s) residual refuses.
      fit_fraction: the first part of the log fitted for the held-out check.
      max_flip_ratio: residual with a joint's torque negated over the logged
        one, under which the sign is refused.
      min_share: fraction of a joint's torque RMS an undetermined parameter
        must carry to fail.
      max_relative_std: %, largest relative std of a parameter carrying
        ``min_share`` of a torque.
      max_mass_factor: largest ratio of an identified (or a prior's total)
        mass to the reference, either way.
      min_mass_share: fraction of the prior's total mass a link's mass must
        differ by for the factor to count.
      max_effort_ratio: largest 99th-percentile |torque| over the effort limit.
      constant_share: torque std over the effort limit at or under which a
        joint's torque is constant.
      max_length_error: m, MDH length difference allowed between the robot
        and a prior (plus 10 % of the length).
      max_angle_error: rad, MDH angle difference allowed.
    """

    floor_share: float = 0.10
    warn_share: float = 0.10
    max_heldout_share: float = 1.0 / 3.0
    fit_fraction: float = HELDOUT_FRACTION
    max_flip_ratio: float = 0.75
    min_share: float = 0.10
    max_relative_std: float = 100.0
    max_mass_factor: float = 10.0
    min_mass_share: float = 0.05
    max_effort_ratio: float = 3.0
    constant_share: float = 1e-6
    max_length_error: float = MAX_LENGTH_ERROR
    max_angle_error: float = MAX_ANGLE_ERROR


@dataclasses.dataclass(frozen=True)
class IdentificationSanity:
    """The outcome of :func:`check_identification` or :func:`check_prediction`.

    Attributes:
      reasons: one line per failed check (empty: plausible).
      warnings: one line per warning (unexplained shares).
      scale: (n,) torque scale per joint, N m or N.
      residual_rms: (n,) RMS residual per joint (in-sample), N m or N.
      heldout_rms: (n,) RMS residual of the held-out prediction, N m or N.
      flip_ratio: (n,) residual with the joint's torque negated over the
        logged one.
      relative_std: (p,) relative std per base parameter, % (empty for
        :func:`check_prediction`).
      share: (p,) largest share of a joint's torque RMS per base parameter.
    """

    reasons: tuple[str, ...]
    warnings: tuple[str, ...]
    scale: np.ndarray
    residual_rms: np.ndarray
    heldout_rms: np.ndarray
    flip_ratio: np.ndarray
    relative_std: np.ndarray = dataclasses.field(repr=False)
    share: np.ndarray = dataclasses.field(repr=False)

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
            f"{100 * r:.3g}/{100 * h:.3g}"
            for r, h in zip(
                self.residual_rms / self.scale,
                self.heldout_rms / self.scale,
                strict=True,
            )
        )
        return (
            f"sanity: {head}; unexplained % of the torque scale per joint "
            f"(fit/held-out): {pairs}"
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


def _joints(values: np.ndarray, index: np.ndarray) -> str:
    """``joint 2 45.6 %, joint 3 43.2 %`` of shares ``values`` at ``index``."""
    return ", ".join(f"joint {j + 1} {100 * values[j]:.3g} %" for j in index)


def _judge(
    residual: np.ndarray,
    heldout: np.ndarray,
    flip: np.ndarray,
    scale: np.ndarray,
    b: IdentificationBounds,
    held_what: str,
) -> tuple[list[str], list[str]]:
    """Reasons and warnings of checks 1-3 of the module docstring (the one
    rule of ``identify`` and ``validate``)."""
    reasons, warnings = [], []
    held = heldout / scale
    bad = np.flatnonzero(held > b.max_heldout_share)
    if bad.size:
        reasons.append(
            f"the model does not predict the torque: {held_what} leaves "
            f"{_joints(held, bad)} of the torque scale unexplained (over "
            f"{100 * b.max_heldout_share:.3g} %): wrong robot, joint order or "
            "sign, or torque shifted in time against the motion; check the log's "
            "columns and --robot"
        )
    flipped = np.flatnonzero(flip < b.max_flip_ratio)
    if flipped.size:
        listed = ", ".join(f"joint {j + 1} {flip[j]:.2g}x" for j in flipped)
        reasons.append(
            f"torque sign: negated, the torque of {listed} fits better than as "
            f"logged (residual under {b.max_flip_ratio:g}x): the log's sign "
            "convention differs from the robot's; negate the column or check "
            "--robot"
        )
    share = np.maximum(residual, heldout) / scale
    loose = np.flatnonzero(share > b.warn_share)
    if loose.size and not reasons:
        warnings.append(
            f"the model leaves part of the torque unexplained (over "
            f"{100 * b.warn_share:.3g} % of the torque scale, fit or held out): "
            f"{_joints(share, loose)}: effects it lacks (friction law, "
            "elasticity, sensor dynamics, cables); try --terms, or accept"
        )
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
    result: Identification, *, bounds: IdentificationBounds | None = None
) -> IdentificationSanity:
    """Runs checks 1-4 of the module docstring on an identification.

    Args:
      result: what :func:`~rmdrake.dynamics.identification.identify` returned.
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
    what = (
        f"the last {100 * (1 - b.fit_fraction):.3g} % of the log, predicted by a "
        f"least-squares fit of the first {100 * b.fit_fraction:.3g} %,"
    )
    reasons, warnings = _judge(residual, heldout, flip, scale, b, what)
    rel = _relative_std(result)
    # RMS over the samples of A_ji x_i, per joint j (rows) and parameter i
    part = np.abs(result.params) * np.sqrt(columns[:, :p] / N)
    per_joint = part / np.maximum(torque_rms, 1e-300)[:, None]
    joint_of = np.argmax(per_joint, axis=0)
    share = per_joint[joint_of, np.arange(p)]
    loose = np.flatnonzero(~(rel <= b.max_relative_std) & (share > b.min_share))
    if loose.size:
        loose = loose[np.argsort(-share[loose], kind="stable")]
        names = result.base.names
        listed = ", ".join(
            f"{names[i]} ({rel[i]:.3g} %, {100 * share[i]:.3g} % of joint "
            f"{joint_of[i] + 1}'s torque)"
            for i in loose[:6]
        )
        more = f" and {loose.size - 6} more" if loose.size > 6 else ""
        reasons.append(
            f"{loose.size} base parameter(s) not determined by the data (relative "
            f"std over {b.max_relative_std:g} %) though each carries over "
            f"{100 * b.min_share:g} % of a joint's torque: {listed}{more}: the "
            "trajectory does not excite them (too short or too slow)"
        )
    return IdentificationSanity(
        reasons=tuple(reasons),
        warnings=tuple(warnings),
        scale=scale,
        residual_rms=residual,
        heldout_rms=heldout,
        flip_ratio=flip,
        relative_std=rel,
        share=share,
    )


def check_prediction(
    predicted: np.ndarray,
    measured: np.ndarray,
    *,
    bounds: IdentificationBounds | None = None,
) -> IdentificationSanity:
    """Checks 1-3 of the module docstring on a model's predicted efforts
    against a log it was not fitted to (``validate``): the whole log is held
    out, and a joint's sign is refused when RMS(predicted + measured) is under
    ``max_flip_ratio`` times RMS(predicted - measured).

    Args:
      predicted, measured: (N, n) efforts, N m or N.
    """
    b = bounds or IdentificationBounds()
    predicted = np.asarray(predicted, dtype=np.float64)
    measured = np.asarray(measured, dtype=np.float64)
    scale = torque_scale(measured, b.floor_share)
    error = np.sqrt(np.mean((predicted - measured) ** 2, axis=0))
    negated = np.sqrt(np.mean((predicted + measured) ** 2, axis=0))
    flip = negated / np.maximum(error, 1e-300)
    reasons, warnings = _judge(error, error, flip, scale, b, "the prediction")
    return IdentificationSanity(
        reasons=tuple(reasons),
        warnings=tuple(warnings),
        scale=scale,
        residual_rms=error,
        heldout_rms=error,
        flip_ratio=flip,
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
            f"torque log: joint(s) {joints} constant (std at most "
            f"{b.constant_share:g} of the effort limit): the torque was not "
            "logged; check the log's tau columns (currents: give --gains)"
        )
    ratio = np.where(usable, np.percentile(np.abs(tau), 99, axis=0) / limit, 0.0)
    over = np.flatnonzero(ratio > b.max_effort_ratio)
    if over.size:
        listed = ", ".join(f"joint {j + 1} {ratio[j]:.3g}x" for j in over)
        reasons.append(
            f"torque log: 99th-percentile |torque| over {b.max_effort_ratio:g}x "
            f"the robot's effort limit on {listed}: the unit is not N m or N "
            "(N mm?) or the log belongs to another robot; convert the log or "
            "check --robot"
        )
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
    """Reasons (check 5 of the module docstring) why identified link masses
    (n,), kg, are absurd against the prior's (n,) kg (None: no check)."""
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
    listed = ", ".join(
        f"link {j + 1} {m[j]:.4g} kg vs {m0[j]:.4g} kg" for j in np.flatnonzero(far)
    )
    return [
        f"identified link masses over {b.max_mass_factor:g}x off the prior's: "
        f"{listed}: the log is of another robot or in another torque unit; check "
        "the log and --robot/--prior, or bound the masses with --mass-bounds"
    ]
