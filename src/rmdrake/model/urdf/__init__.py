"""URDF in and out: the serial chain between two links of a URDF as a robot
model (:mod:`~rmdrake.model.urdf.importer`, reading through Drake's parser in
:mod:`~rmdrake.model.urdf.parse`), and a robot model as a URDF
(:mod:`~rmdrake.model.urdf.export`).
"""

from __future__ import annotations

from rmdrake.model.urdf.export import (  # noqa: F401
    robot_to_urdf,
)
from rmdrake.model.urdf.importer import (  # noqa: F401
    BASE_TOLERANCE,
    CONTINUOUS_LIMIT,
    PARALLEL_ANGLE,
)

__all__ = [
    "BASE_TOLERANCE",
    "CONTINUOUS_LIMIT",
    "PARALLEL_ANGLE",
    "robot_to_urdf",
]
