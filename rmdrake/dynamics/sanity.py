"""Is a dynamic identification believable? Checks run after the fit.

Least squares returns base parameters for any log. Two things say the log
contradicts them (:func:`check_identification`, one line per failed check):

1. **Residual far above the torque noise.** A right model leaves only the
   noise. The noise per joint is the declared one (N m or N) or estimated from the
   raw torque log: the robust (MAD) scale of its second differences over
   sqrt(6), which is the white-noise standard deviation whenever the torque
   varies slowly between samples (the motion's harmonics are far below the
   sampling rate; Coulomb steps at velocity reversals are few, the median
   ignores them). A joint fails when its RMS residual exceeds ``noise_ratio``
   (3) times the noise; with an *estimated* noise it must also exceed
   ``min_share`` (10 %) of the joint's torque RMS, because a drive that
   filters its torque before logging hides its noise from the second
   differences, and a model that explains 90 % of the torque is not wrong. A
   joint order, a sign, a wrong robot or a shift between torque and motion
   leaves 2-10 times the noise and 20-100 % of the torque (the tests); so
   does identifying with sign(qd) Coulomb friction a slow arm simulated with
   a smooth one (give the simulator's width).
2. **A base parameter the data do not determine.** Relative std
   (100 std / |x|, the least-squares covariance sigma^2 (A^T A)^-1 of the
   estimator, or Gautier's WLS one at x for ``physical``) over ``max_relative_std``
   (100 %) *and* a share of some joint's torque, RMS(A_ij x_i) / RMS(b_j),
   over ``min_share`` (10 %). Small parameters (products of inertia of
   nearly symmetric links) routinely have relative stds of several hundred
   per cent on clean data; they carry under 1 % of any torque and are
   harmless. A parameter that carries a tenth of a torque and is not
   distinguishable from zero means a trajectory that does not excite the
   robot (too short, too slow) and a model that will predict wrong torques.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from rmdrake.dynamics.identification import Identification

__all__ = [
    "IdentificationBounds",
    "IdentificationSanity",
    "check_identification",
    "torque_noise",
]


@dataclasses.dataclass(frozen=True)
class IdentificationBounds:
    """Thresholds of :func:`check_identification` (see the module docstring).

    Attributes:
      noise_ratio: largest RMS residual over the torque noise, per joint.
      min_share: fraction of a joint's torque RMS a residual (with estimated
        noise) or an undetermined parameter must reach to fail.
      max_relative_std: %, largest relative std of a parameter carrying
        ``min_share`` of a torque.
    """

    noise_ratio: float = 3.0
    min_share: float = 0.10
    max_relative_std: float = 100.0


@dataclasses.dataclass(frozen=True)
class IdentificationSanity:
    """The outcome of :func:`check_identification`.

    Attributes:
      reasons: one line per failed check (empty: plausible).
      noise: (n,) torque noise per joint, N m.
      noise_source: ``declared`` or how it was estimated.
      residual_rms: (n,) RMS residual per joint, N m.
      relative_std: (p,) relative std per base parameter, %.
      share: (p,) largest share of a joint's torque RMS per base parameter.
    """

    reasons: tuple[str, ...]
    noise: np.ndarray
    noise_source: str
    residual_rms: np.ndarray
    relative_std: np.ndarray = dataclasses.field(repr=False)
    share: np.ndarray = dataclasses.field(repr=False)

    @property
    def ok(self) -> bool:
        """True when every check passed."""
        return not self.reasons

    def summary(self) -> str:
        """One line: the verdict and the residual over the noise per joint."""
        head = "plausible" if self.ok else f"IMPLAUSIBLE ({len(self.reasons)})"
        ratio = self.residual_rms / np.maximum(self.noise, 1e-300)
        return (
            f"sanity: {head}; residual / torque noise ({self.noise_source}) per "
            f"joint: {', '.join(f'{r:.3g}' for r in ratio)}"
        )


def torque_noise(tau: np.ndarray) -> np.ndarray:
    """(n,) white-noise standard deviation of each column of a raw torque log
    (N, n), N m: 1.4826 MAD of the second differences / sqrt(6)."""
    tau = np.asarray(tau, dtype=np.float64)
    if tau.ndim != 2 or tau.shape[0] < 4:
        raise ValueError("torque_noise: expected (N >= 4, n) torques")
    d2 = np.diff(tau, 2, axis=0)
    mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(6.0)


def _relative_std(result: Identification) -> np.ndarray:
    """(p,) 100 std / |x| of the result's parameters x, with the estimator's std
    or, when it has none (``physical``), the covariance of Gautier's weighted
    least squares at x: sigma^2 (A_w^T A_w)^-1, rows of joint j weighted by
    1 / (its RMS residual), sigma^2 the weighted RSS over rows - p."""
    x = np.asarray(result.params, dtype=np.float64)
    std = result.std
    if std is None:
        obs = result.observations
        r = obs.b - obs.A @ x
        joint = np.sqrt(np.mean(r.reshape(-1, obs.n_joints) ** 2, axis=0))
        joint = np.maximum(joint, 1e-12 * max(float(joint.max()), 1e-300))
        w = np.tile(1.0 / joint, obs.A.shape[0] // obs.n_joints)
        Aw = obs.A * w[:, None]
        sigma2 = float(np.sum((w * r) ** 2)) / max(Aw.shape[0] - Aw.shape[1], 1)
        std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(Aw.T @ Aw)), 0) * sigma2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 100.0 * np.asarray(std) / np.abs(x)


def check_identification(
    result: Identification,
    *,
    noise: float | Sequence[float] | np.ndarray | None = None,
    raw_torque: np.ndarray | None = None,
    bounds: IdentificationBounds | None = None,
) -> IdentificationSanity:
    """Runs the checks of the module docstring on an identification.

    Args:
      result: what :func:`~rmdrake.dynamics.identification.identify` returned.
      noise: declared torque noise (standard deviation), N m (N on a
        prismatic joint), one value or one per joint; None: estimated
        (:func:`torque_noise`) from ``raw_torque``,
        else from the prepared samples' torque (filtered: an underestimate).
      raw_torque: (N, n) efforts of the log as recorded, N m or N.
      bounds: thresholds (default :class:`IdentificationBounds`()).
    """
    b = bounds or IdentificationBounds()
    obs = result.observations
    n = obs.n_joints
    B = obs.b.reshape(-1, n)
    torque_rms = np.sqrt(np.mean(B**2, axis=0))
    residual = np.asarray(result.residual_rms, dtype=np.float64)
    if noise is not None:
        sigma = np.broadcast_to(np.asarray(noise, dtype=np.float64), (n,)).copy()
        source = "declared"
    elif raw_torque is not None:
        sigma, source = torque_noise(raw_torque), "estimated from the raw log"
    else:
        sigma = torque_noise(B)
        source = "estimated from the prepared torques"
    sigma = np.maximum(sigma, 1e-9 * max(float(np.max(np.abs(B))), 1e-300))
    reasons: list[str] = []
    ratio = residual / sigma
    high = ratio > b.noise_ratio
    if noise is None:
        high &= residual > b.min_share * torque_rms
    if high.any():
        joints = ", ".join(
            f"joint {j + 1} {residual[j]:.3g} N m = {ratio[j]:.3g}x noise, "
            f"{100 * residual[j] / max(torque_rms[j], 1e-300):.3g} % of its torque"
            for j in np.flatnonzero(high)
        )
        reasons.append(
            f"torque residual far above the noise ({source}): {joints}: the model "
            "does not explain the torque (wrong robot, joint order or sign, torque "
            "shifted in time against the motion, or another friction law: see the "
            "Coulomb width)"
        )
    rel = _relative_std(result)
    A = obs.A
    share = np.zeros(A.shape[1])
    joint_of = np.zeros(A.shape[1], dtype=int)
    for i in range(A.shape[1]):
        part = (A[:, i] * result.params[i]).reshape(-1, n)
        per_joint = np.sqrt(np.mean(part**2, axis=0)) / np.maximum(torque_rms, 1e-300)
        joint_of[i] = int(np.argmax(per_joint))
        share[i] = float(per_joint[joint_of[i]])
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
        noise=sigma,
        noise_source=source,
        residual_rms=residual,
        relative_std=rel,
        share=share,
    )
