"""Validation of a calibrated model against the true one on held-out poses.

The figure of merit is the tool-point error |p_BE,calibrated(q) - p_BE,true(q)|
(m) on random joint vectors within the limits that the calibration never saw.
Where the calibration could not see base-frame parameters (the plates absorb
any rigid motion of the robot), the calibrated and true models may differ by a
rigid transform of the base that no plate measurement can reveal; the error is
then reported after the best-fit rigid alignment of the two point sets
(Kabsch, :meth:`scipy.spatial.transform.Rotation.align_vectors`), and the
result says so.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.dynamics.compliance import link_angles
from rmdrake.kinematics.compare import rigid_alignment
from rmdrake.kinematics.forward import tool_points
from rmdrake.model.robot import RobotModel

__all__ = ["ValidationResult", "tool_point_errors"]


@dataclasses.dataclass(frozen=True)
class ValidationResult:
    """Tool-point errors on held-out poses.

    Attributes:
      errors: (N,) per-pose error, m.
      aligned: True when a best-fit rigid alignment was removed first.
      X_TC: (4, 4) the alignment (pose of the calibrated model's base in the
        true model's base), identity when not aligned.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import ValidationResult, random_poses
    >>> from rmdrake.calibration import tool_point_errors
    >>> robot = load_robot("rv3sb")
    >>> q = random_poses(robot, 5, seed=1)
    >>> result = tool_point_errors(robot, robot, q, align=True)
    >>> isinstance(result, ValidationResult), result.aligned, result.X_TC.shape
    (True, True, (4, 4))
    """

    errors: np.ndarray
    aligned: bool
    X_TC: np.ndarray

    @property
    def mean(self) -> float:
        """Mean error, m."""
        return float(np.mean(self.errors))

    @property
    def max(self) -> float:
        """Largest error, m."""
        return float(np.max(self.errors))

    def describe(self) -> str:
        """One line in mm, naming the alignment if one was used."""
        how = " after best-fit rigid alignment" if self.aligned else ""
        return (
            f"tool-point error{how}: mean {self.mean * 1e3:.4f} mm, max "
            f"{self.max * 1e3:.4f} mm over {self.errors.size} held-out poses"
        )


def tool_point_errors(
    calibrated: RobotModel,
    true: RobotModel,
    q: np.ndarray,
    *,
    align: bool = False,
    p_E_calibrated: np.ndarray | None = None,
    p_E_true: np.ndarray | None = None,
    at_rest: bool = False,
) -> ValidationResult:
    """Tool-point errors |p_B,calibrated(q) - p_B,true(q)| (m, in the base frame
    B) of ``calibrated`` against ``true`` at joint angles q.

    Args:
      calibrated: the model under test (e.g. an estimator's ``model_``).
      true: the reference (the simulated true robot).
      q: (N, n) held-out joint angles (encoder angles with ``at_rest``), rad
        or m.
      align: remove the best-fit rigid transform first (use when base-frame
        parameters are unidentifiable and the truth has errors there).
      p_E_calibrated, p_E_true: (3,) the tool point in each model's tool frame
        E, m (default E's origin; a tracker's markers' centroid, say).
      at_rest: each model's elastic joints at rest under gravity, no payload
        (link angles of :func:`~rmdrake.dynamics.compliance.link_angles`);
        rigid joints are unchanged.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import random_poses, tool_point_errors
    >>> robot = load_robot("rv3sb")
    >>> q = random_poses(robot, 20, seed=0)
    >>> result = tool_point_errors(robot, robot, q)
    >>> result.errors.shape, float(result.errors.max()) < 1e-12
    ((20,), True)
    """
    p = []
    for model, p_E in ((calibrated, p_E_calibrated), (true, p_E_true)):
        q_l = link_angles(model, q, 0.0) if at_rest else q
        p.append(tool_points(model.table, q_l, sigma=model.sigma, p_EM=p_E))
    p_cal, p_true = p
    X = np.eye(4)
    if align:
        X = rigid_alignment(p_cal, p_true)
        p_cal = p_cal @ X[:3, :3].T + X[:3, 3]
    return ValidationResult(np.linalg.norm(p_cal - p_true, axis=1), align, X)
