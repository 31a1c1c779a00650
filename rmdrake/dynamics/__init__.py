"""Dynamics: standard parameters, the joint-torque regressor, base parameters.

See :mod:`rmdrake.dynamics.parameters` (the 13 standard parameters per link and
their checks), :mod:`rmdrake.dynamics.chain` (revolute serial chains from a
RobotModel, a Drake plant or a URDF) and :mod:`rmdrake.dynamics.regressor`
(tau = Y(q, qd, qdd) @ chi, vectorised over samples) and
:mod:`rmdrake.dynamics.base` (base parameters and their regrouping).
"""

from rmdrake.dynamics.base import BaseParameters, base_parameters
from rmdrake.dynamics.chain import SerialChain, plant_standard_parameters, urdf_plant
from rmdrake.dynamics.parameters import (
    N_PER_LINK,
    PhysicalCheck,
    StandardParameters,
    check_physical,
    parameter_names,
    pseudo_inertia,
    random_standard_parameters,
    require_physical,
    spatial_inertia_from_standard,
    standard_from_spatial_inertia,
    standard_parameters,
    transform_inertial,
)
from rmdrake.dynamics.regressor import regressor, regressor_columns, torques

__all__ = [
    "BaseParameters",
    "N_PER_LINK",
    "PhysicalCheck",
    "SerialChain",
    "StandardParameters",
    "base_parameters",
    "check_physical",
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
