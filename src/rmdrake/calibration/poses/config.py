"""The options of the pose calibration and the estimator they make: the
method's :class:`PoseLMConfig` (beside the common
:class:`~rmdrake.calibration.config.CalibrationConfig`) and
:func:`make_pose_calibrator`.

Of :class:`~rmdrake.calibration.config.CalibrationConfig`, ``noise`` is the
position noise (m), ``f_scale`` (m) is divided by it for a robust loss
(residuals are in noise units; 3 noises when the noise is not declared).

Example::

    config = CalibrationConfig(noise=2e-5, calibrator=PoseLMConfig(angle_noise=5e-5))
    est = make_pose_calibrator(config, load_robot("rv3sb"))  # an unfitted PoseLM
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from rmdrake.calibration.config import CalibrationConfig
from rmdrake.model.robot import RobotModel

__all__ = ["PoseLMConfig", "make_pose_calibrator", "method_config"]


@dataclasses.dataclass(kw_only=True)
class PoseLMConfig:
    """Method ``lm`` on pose measurements: Levenberg-Marquardt on the position
    and angle errors of the marker pose, X_IB and X_FM unknowns too, with the
    common options of :class:`~rmdrake.calibration.config.CalibrationConfig`
    (its ``noise``: the position noise, m).

    Attributes:
      angle_noise: std of each orientation component, rad; None = estimated
        from the residuals.
      seed: seeds every reading split (the selection's and the reported one).
      selection_folds: K of the automatic choice's K-fold cross-validation.
      repeats: seeded K-fold splits of the automatic choice, pooled.
      folds: report the held-out errors over K folds of the readings; None =
        not.
      holdout: report them over one held-out fraction (0 < fraction < 1);
        None = not.
      max_nfev: most residual evaluations of each least-squares solve; None =
        scipy's default.

    >>> PoseLMConfig(angle_noise=5e-5).method, PoseLMConfig().angle_noise
    ('lm', None)
    """

    method: ClassVar[str] = "lm"

    angle_noise: float | None = None
    seed: int = 0
    selection_folds: int = 5
    repeats: int = 1
    folds: int | None = None
    holdout: float | None = None
    max_nfev: int | None = None


def method_config(config: CalibrationConfig) -> PoseLMConfig:
    """The config's :class:`PoseLMConfig` (the default one when it has none).

    Raises:
      ValueError: another method's config (one line).
    """
    method = config.calibrator
    if method is None:
        return PoseLMConfig()
    if not isinstance(method, PoseLMConfig):
        raise ValueError(
            f"{type(method).__name__} (method '{method.method}') does not calibrate "
            "pose measurements; they are calibrated by PoseLMConfig"
        )
    return method


def make_pose_calibrator(config: CalibrationConfig, model: RobotModel) -> Any:
    """The :class:`~rmdrake.calibration.poses.lm.PoseLM` of a config (see the
    module docstring for ``noise`` and ``f_scale``).

    Raises:
      ValueError: another method's config, compliance asked (one line).

    >>> from rmdrake.model.loading import load_robot
    >>> method = PoseLMConfig(angle_noise=5e-5)
    >>> config = CalibrationConfig(noise=2e-5, calibrator=method)
    >>> est = make_pose_calibrator(config, load_robot("rv3sb"))
    >>> type(est).__name__, est.noise_p, est.noise_r
    ('PoseLM', 2e-05, 5e-05)
    """
    from rmdrake.calibration.poses.lm import PoseLM

    method = method_config(config)
    if config.compliance:
        raise ValueError(
            "compliance: the pose calibration fits rigid joints only (no payload "
            "column); calibrate compliances from point or plane measurements"
        )
    f_scale = 3.0 if config.noise is None else config.f_scale / config.noise
    return PoseLM(
        model,
        params="auto" if config.params is None else config.params,
        noise_p=config.noise,
        noise_r=method.angle_noise,
        loss=config.loss,
        f_scale=f_scale,
        folds=method.selection_folds,
        seed=method.seed,
        repeats=method.repeats,
        rtol=config.rtol,
        max_nfev=method.max_nfev,
    )
