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

from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.chain import SerialChain, plant_standard_parameters
from rmdrake.dynamics.estimators import (
    DifferentialEvolutionLeastSquares,
    Estimator,
    OrdinaryLeastSquares,
    WeightedLeastSquares,
)
from rmdrake.dynamics.friction import DEFAULT_V_EPS, coulomb_sign, friction_torque
from rmdrake.dynamics.identification import (
    IDENTIFICATION_METHODS,
    Identification,
    identified_model,
    identify,
)
from rmdrake.dynamics.observations import Observations
from rmdrake.dynamics.physical_fit import PhysicalLeastSquares
from rmdrake.dynamics.regressor import regressor, regressor_columns, torques
from rmdrake.model.dynamic_parameters import (
    N_PER_LINK,
    PhysicalCheck,
    StandardParameters,
    check_physical,
    parameter_names,
    pseudo_inertia,
    random_standard_parameters,
    require_physical,
    standard_from_spatial_inertia,
    standard_parameters,
    transform_inertial,
)
from rmdrake.model.plant import spatial_inertia_from_standard
from rmdrake.model.urdf.parse import urdf_plant

__all__ = [
    "BaseParameters",
    "DEFAULT_V_EPS",
    "DifferentialEvolutionLeastSquares",
    "Estimator",
    "IDENTIFICATION_METHODS",
    "Identification",
    "N_PER_LINK",
    "Observations",
    "OrdinaryLeastSquares",
    "PhysicalCheck",
    "PhysicalLeastSquares",
    "SerialChain",
    "StandardParameters",
    "WeightedLeastSquares",
    "base_parameters",
    "check_physical",
    "coulomb_sign",
    "friction_torque",
    "identified_model",
    "identify",
    "parameter_names",
    "plant_standard_parameters",
    "pseudo_inertia",
    "random_standard_parameters",
    "regressor",
    "regressor_columns",
    "require_physical",
    "spatial_inertia_from_standard",
    "standard_from_spatial_inertia",
    "standard_parameters",
    "torques",
    "transform_inertial",
    "urdf_plant",
]
