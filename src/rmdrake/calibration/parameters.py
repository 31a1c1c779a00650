"""Which MDH error parameters a calibration estimates, and their search bounds.

Error parameters are named ``dalpha<j>``, ``dd<j>``, ``dtheta<j>``, ``dr<j>``,
``dbeta<j>`` (rad for the angles, m for the lengths d and r) and add to row j of
the robot's MDH table (:func:`rmdrake.model.error_parameters.apply_deltas`); ``c<j>``
are joint
compliances (rad/(N m), m/N on a slide) of an elastostatic calibration
(:mod:`rmdrake.calibration.elastostatic`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rmdrake.model.error_parameters import error_parameter_names, split_error_parameters
from rmdrake.model.robot import RobotModel

__all__ = [
    "POINT_PRESETS",
    "joint_offset_names",
    "parameter_bounds",
    "resolve_parameters",
]

POINT_PRESETS: tuple[str, ...] = ("auto", "base", "offsets", "full")
"""Parameter presets of a point calibration: ``auto`` (chosen from the data by
cross-validation, :mod:`rmdrake.calibration.points.selection`), ``base`` (no
error parameter: the nominal kinematics with the instrument pose and the
markers fitted), ``offsets`` (the joint offsets, :func:`joint_offset_names`)
and ``full`` (all), the last two reduced to their identifiable subset."""


def joint_offset_names(model: RobotModel) -> list[str]:
    """The joint offsets: ``dtheta<j>`` of a revolute joint, ``dr<j>`` of a
    prismatic one (what adds to the joint variable), j = 1..n.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import joint_offset_names
    >>> joint_offset_names(load_robot("rv3sb"))
    ['dtheta1', 'dtheta2', 'dtheta3', 'dtheta4', 'dtheta5', 'dtheta6']
    """
    return [
        f"{'dr' if s == 1 else 'dtheta'}{j}" for j, s in enumerate(model.sigma, start=1)
    ]


def resolve_parameters(model: RobotModel, params: str | Sequence[str]) -> list[str]:
    """Error parameter names of a preset (``paper``, ``full``), of a
    comma-separated string or of a list of names (MDH names and compliances
    ``c<j>``).

    Raises:
      ValueError: unknown preset or parameter name (naming it).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import resolve_parameters
    >>> names = resolve_parameters(load_robot("rv3sb"), "paper")
    >>> len(names), names[:3]
    (17, ['dalpha2', 'dalpha3', 'dalpha4'])
    """
    if isinstance(params, str):
        if params in ("paper", "full"):
            return error_parameter_names(model, params)
        if "," not in params and not params.startswith(("d", "c")):
            raise ValueError(
                f"unknown parameter preset '{params}': expected 'paper', 'full' or "
                f"a comma-separated list of names such as dalpha2,dd3,c2"
            )
        params = [p.strip() for p in params.split(",") if p.strip()]
    names = list(params)
    if not names:
        raise ValueError("error parameters: none given")
    split_error_parameters(model, names)  # raises naming an unknown name
    return names


def parameter_bounds(
    names: Sequence[str], length: float = 3e-3, angle: float = 3e-3
) -> np.ndarray:
    """(k, 2) symmetric bounds: +-``length`` m for ``dd``/``dr`` parameters,
    +-``angle`` rad for ``dalpha``/``dtheta``/``dbeta``.

    Example:

    >>> from rmdrake.calibration import parameter_bounds
    >>> parameter_bounds(["dtheta2", "da2"], length=1e-3, angle=2e-3)
    array([[-0.002,  0.002],
           [-0.002,  0.002]])
    """
    half = np.array([length if n[:2] in ("dd", "dr") else angle for n in names])
    return np.stack([-half, half], axis=1)
