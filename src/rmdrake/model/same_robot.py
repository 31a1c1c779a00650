"""Are two robot models the same robot, up to calibration-sized errors?

The one comparison every command that pairs two models uses: ``identify
--prior`` (:func:`rmdrake.dynamics.sanity.check_prior`), ``correct --nominal``
and ``simulate --nominal``. Calibration errors are millimetres and
milliradians; a model of another robot differs by tenths of a metre or whole
angles. Rule: the same joint count and joint types, every MDH length (d, r)
within ``max_length_error`` (0.02 m) + 10 % of its value, every MDH angle
(alpha, theta, beta) within ``max_angle_error`` (0.05 rad, 2.9 deg).
"""

from __future__ import annotations

import numpy as np

from rmdrake.model.robot import MDH_KEYS, RobotModel

__all__ = ["MAX_ANGLE_ERROR", "MAX_LENGTH_ERROR", "check_same_robot"]

#: m, an MDH length's largest difference beyond 10 % of its value.
MAX_LENGTH_ERROR = 0.02
#: rad, an MDH angle's largest difference (2.9 deg).
MAX_ANGLE_ERROR = 0.05


def check_same_robot(
    model: RobotModel,
    other: RobotModel,
    *,
    what: str,
    remedy: str,
    max_length_error: float = MAX_LENGTH_ERROR,
    max_angle_error: float = MAX_ANGLE_ERROR,
) -> None:
    """Refuses ``other`` unless it is ``model``'s robot (module docstring).

    Args:
      model: the reference robot.
      other: the robot compared, named ``what`` in the message (``prior``,
        ``nominal``).
      remedy: what to do, ending the message.
      max_length_error: m; max_angle_error: rad (the rule's figures).

    Raises:
      ValueError: ``WHAT: robot 'B' has other kinematics than robot 'A'
        (joint j d 0.5 vs 0.25, beyond calibration-sized errors); REMEDY``.
    """
    if other.n_joints != model.n_joints:
        raise ValueError(
            f"{what}: robot '{other.name}' has {other.n_joints} joints, robot "
            f"'{model.name}' {model.n_joints}: not the same robot; {remedy}"
        )
    lengths, angles = [1, 3], [0, 2, 4]
    d = np.abs(other.mdh - model.mdh)
    allowed = max_length_error + 0.1 * np.abs(model.mdh[:, lengths])
    off_len = np.argwhere(d[:, lengths] > allowed)
    off_ang = np.argwhere(d[:, angles] > max_angle_error)
    if off_len.size or off_ang.size or not np.array_equal(other.sigma, model.sigma):
        j, c = (
            (off_len[0][0], lengths[off_len[0][1]])
            if off_len.size
            else (off_ang[0][0], angles[off_ang[0][1]])
            if off_ang.size
            else (0, 1)
        )
        raise ValueError(
            f"{what}: robot '{other.name}' has other kinematics than robot "
            f"'{model.name}' (joint {j + 1} {MDH_KEYS[c]} {other.mdh[j, c]:.4g} vs "
            f"{model.mdh[j, c]:.4g}, beyond calibration-sized errors); {remedy}"
        )
