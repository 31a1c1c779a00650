"""URDF in and out: the serial chain between two links of a URDF as a robot
model (:mod:`~rmdrake.model.urdf.importer`, reading through Drake's parser in
:mod:`~rmdrake.model.urdf.parse`), and a robot model as a URDF
(:mod:`~rmdrake.model.urdf.export`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.model.urdf.export": ("robot_to_urdf",),
        "rmdrake.model.urdf.importer": (
            "BASE_TOLERANCE",
            "CONTINUOUS_LIMIT",
            "PARALLEL_ANGLE",
        ),
    },
)
