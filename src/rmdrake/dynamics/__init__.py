"""Dynamics: standard parameters, the joint-torque regressor, base parameters,
their identification.

See :mod:`rmdrake.model.dynamic_parameters` (the 13 standard parameters per link and
their checks), :mod:`rmdrake.dynamics.friction` (the joint friction law),
:mod:`rmdrake.dynamics.chain` (serial chains of revolute and prismatic joints
from a RobotModel, a Drake plant or a URDF), :mod:`rmdrake.dynamics.regressor`
(tau = Y(q, qd, qdd) @ chi, vectorised over samples),
:mod:`rmdrake.dynamics.base` (base parameters and their regrouping),
:mod:`rmdrake.dynamics.estimators` (least-squares estimators of A x = b) and
:mod:`rmdrake.dynamics.identification` (samples to an identified robot model).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.dynamics.base": (
            "BaseParameters",
            "base_parameters",
        ),
        "rmdrake.dynamics.chain": (
            "SerialChain",
            "plant_standard_parameters",
        ),
        "rmdrake.dynamics.estimators": (
            "DifferentialEvolutionLeastSquares",
            "Estimator",
            "OrdinaryLeastSquares",
            "IDENTIFICATION_METHODS",
            "WeightedLeastSquares",
        ),
        "rmdrake.dynamics.friction": (
            "DEFAULT_V_EPS",
            "coulomb_sign",
            "friction_torque",
        ),
        "rmdrake.dynamics.identification": (
            "Identification",
            "identified_model",
            "identify",
        ),
        "rmdrake.dynamics.observations": ("Observations",),
        "rmdrake.dynamics.physical_fit": ("PhysicalLeastSquares",),
        "rmdrake.dynamics.regressor": (
            "regressor_columns",
            "torques",
        ),
        "rmdrake.model.dynamic_parameters": (
            "N_PER_LINK",
            "PhysicalCheck",
            "StandardParameters",
            "check_physical",
            "parameter_names",
            "pseudo_inertia",
            "random_standard_parameters",
            "require_physical",
            "standard_from_spatial_inertia",
            "standard_parameters",
            "transform_inertial",
        ),
        "rmdrake.model.plant": ("spatial_inertia_from_standard",),
        "rmdrake.model.urdf.parse": ("urdf_plant",),
    },
)

# The function regressor has its module's name: bound here, not lazily, since
# importing the module rmdrake.dynamics.regressor binds the module to this name.
from rmdrake.dynamics.regressor import regressor as regressor  # noqa: E402

__all__ = sorted([*__all__, "regressor"])
