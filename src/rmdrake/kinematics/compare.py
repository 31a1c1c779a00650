"""How far apart two models of one robot put the tool: the distance between
their tool points (m) over random poses, e.g. a true robot against its nominal
or its calibrated model (``rmdrake compare``), optionally after the best rigid
alignment of one point set onto the other (:func:`rigid_alignment`): what a
calibration from plates cannot see, the base's pose, taken out."""

from __future__ import annotations

import numpy as np

from rmdrake.kinematics.forward import tool_points
from rmdrake.model.perturb import MAX_ANGLE_STD, MAX_LENGTH_STD
from rmdrake.model.robot import RobotModel
from rmdrake.model.same_robot import check_same_robot

__all__ = [
    "COMPARE_MAX_ANGLE",
    "COMPARE_MAX_LENGTH",
    "MIN_ALIGNED_POSES",
    "aligned_poses_error",
    "rigid_alignment",
    "tool_error_stats",
]

#: m: an MDH length's largest difference (beyond 10 % of its value) between two
#: robots compared: 10 x the largest std :func:`~rmdrake.model.perturb.
#: perturb_robot` draws, so any true robot it draws is its nominal's robot.
COMPARE_MAX_LENGTH = 10 * MAX_LENGTH_STD
#: rad: an MDH angle's largest difference between two robots compared (idem).
COMPARE_MAX_ANGLE = 10 * MAX_ANGLE_STD

#: The fewest poses of an aligned comparison: a rigid alignment needs three
#: non-collinear tool points (two leave the rotation about their line free).
MIN_ALIGNED_POSES = 3


def rigid_alignment(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(4, 4) rigid transform X minimising sum |X source_i - target_i|^2
    (scipy's ``Rotation.align_vectors`` on the centred points).

    Args:
      source, target: (N, 3) corresponding points, m.

    >>> import numpy as np
    >>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [0, 0, 3.0]])
    >>> X = rigid_alignment(p, p + [0.1, 0.2, 0.3])  # a pure translation
    >>> np.round(X[:3, 3], 6).tolist(), bool(np.allclose(X[:3, :3], np.eye(3)))
    ([0.1, 0.2, 0.3], True)
    """
    from scipy.spatial.transform import Rotation

    cs, ct = source.mean(axis=0), target.mean(axis=0)
    rot, _ = Rotation.align_vectors(target - ct, source - cs)
    X = np.eye(4)
    X[:3, :3] = rot.as_matrix()
    X[:3, 3] = ct - X[:3, :3] @ cs
    return X


def tool_error_stats(
    a: RobotModel,
    b: RobotModel,
    *,
    n_poses: int = 1000,
    seed: int = 0,
    aligned: bool = False,
) -> dict[str, float]:
    """The distance between the tool points of ``a`` and ``b`` (m) at the same
    joint positions.

    The poses are uniform within both robots' joint limits (the intersection;
    rad or m), drawn from ``numpy.random.default_rng(seed)`` as the plate
    simulator's ``random_poses`` draws them (that sampler lives in the
    calibration stage, which kinematics does not import). The tool points are
    :func:`~rmdrake.kinematics.forward.tool_points` of each robot's MDH table
    and joint types, in its base frame B.

    Args:
      a, b: the two robots (same joint count and types).
      n_poses: number of random poses, >= 1.
      seed: seeds the poses (integer >= 0).
      aligned: first move ``a``'s tool points by the rigid transform that
        best fits them onto ``b``'s (:func:`rigid_alignment`): needs at least
        :data:`MIN_ALIGNED_POSES` poses whose tool points are not collinear.

    Returns:
      ``{"mean": m, "p95": m, "max": m, "n_poses": N}``: the mean, 95th
      percentile and largest distance in m.

    Raises:
      ValueError: (one line) different joint counts or types, kinematics that
        differ by more than :data:`COMPARE_MAX_LENGTH` (+ 10 %) or
        :data:`COMPARE_MAX_ANGLE` (another robot, not a model of the same
        one), joint limits that do not overlap, ``n_poses`` < 1, or, with
        ``aligned``, fewer than :data:`MIN_ALIGNED_POSES` poses or collinear
        tool points (the alignment's rotation undefined).
    """
    if a.n_joints != b.n_joints:
        raise ValueError(
            f"robot '{a.name}' has {a.n_joints} joints, robot '{b.name}' "
            f"{b.n_joints}: compare needs two models of one robot"
        )
    if not np.array_equal(a.sigma, b.sigma):
        j = int(np.flatnonzero(a.sigma != b.sigma)[0])
        kinds = ("revolute", "prismatic")
        raise ValueError(
            f"joint {j + 1} is {kinds[a.sigma[j]]} on robot '{a.name}' and "
            f"{kinds[b.sigma[j]]} on robot '{b.name}': compare needs two models "
            "of one robot"
        )
    check_same_robot(
        a,
        b,
        what="compare",
        remedy="compare needs two models of one robot",
        max_length_error=COMPARE_MAX_LENGTH,
        max_angle_error=COMPARE_MAX_ANGLE,
    )
    if isinstance(n_poses, bool) or not isinstance(n_poses, int | np.integer):
        raise ValueError(f"n_poses: expected an integer >= 1, found {n_poses!r}")
    if n_poses < 1:
        raise ValueError(f"n_poses: expected an integer >= 1, found {n_poses}")
    if aligned and n_poses < MIN_ALIGNED_POSES:
        raise ValueError(aligned_poses_error("n_poses", int(n_poses)))
    lower = np.maximum(a.limits.lower, b.limits.lower)
    upper = np.minimum(a.limits.upper, b.limits.upper)
    if np.any(lower > upper):
        j = int(np.flatnonzero(lower > upper)[0])
        raise ValueError(
            f"joint {j + 1}: the limits of robots '{a.name}' and '{b.name}' do not "
            "overlap; no pose is within both"
        )
    rng = np.random.default_rng(seed)
    q = rng.uniform(lower, upper, (int(n_poses), a.n_joints))
    p_a = tool_points(a.table, q, sigma=a.sigma)
    p_b = tool_points(b.table, q, sigma=b.sigma)
    if aligned:
        _check_not_collinear(p_b, int(n_poses))
        X = rigid_alignment(p_a, p_b)
        p_a = p_a @ X[:3, :3].T + X[:3, 3]
    e = np.linalg.norm(p_a - p_b, axis=1)
    return {
        "mean": float(e.mean()),
        "p95": float(np.percentile(e, 95)),
        "max": float(e.max()),
        "n_poses": int(n_poses),
    }


def aligned_poses_error(option: str, n_poses: int) -> str:
    """The one line refusing an aligned comparison over ``n_poses`` poses,
    naming ``option`` (``n_poses``, ``--poses``) and the minimum.

    >>> aligned_poses_error("--poses", 2)
    '--poses 2: an aligned comparison needs at least 3 poses (a rigid ...)'
    """
    return (
        f"{option} {n_poses}: an aligned comparison needs at least "
        f"{MIN_ALIGNED_POSES} poses (a rigid alignment of {n_poses} tool "
        f"point{'s' if n_poses != 1 else ''} leaves the rotation about their "
        "line undefined)"
    )


def _check_not_collinear(p: np.ndarray, n_poses: int) -> None:
    """Refuses tool points p (N, 3) (m) that lie on one line: their rigid
    alignment has no defined rotation (the second singular value of the
    centred points below 1e-9 of the first, or all points equal)."""
    sv = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    if sv[0] == 0 or sv[1] <= 1e-9 * sv[0]:
        raise ValueError(
            f"the tool points of the {n_poses} poses lie on one line: their "
            "rigid alignment has no defined rotation; give more poses"
        )
