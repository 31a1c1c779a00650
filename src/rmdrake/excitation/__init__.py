"""Excitation for dynamic identification (paper eq. 11-17): Fourier
trajectories and their file (:mod:`~rmdrake.excitation.trajectory`), random
ones (:mod:`~rmdrake.excitation.random`) and the optimal design by DE
(:mod:`~rmdrake.excitation.design`).
"""

from __future__ import annotations

from rmdrake.excitation.design import (
    ExcitationCost,
    ExcitationResult,
    FourierParametrization,
    design_excitation,
    fit_to_limits,
    limit_scales,
)
from rmdrake.excitation.random import (  # noqa: F401
    random_fourier_trajectory,
)
from rmdrake.excitation.trajectory import (  # noqa: F401
    MAX_HARMONICS,
    MAX_PERIOD_S,
    FourierTrajectory,
    check_sampling,
    fourier_series,
    load_fourier,
)

__all__ = [
    "ExcitationCost",
    "ExcitationResult",
    "FourierParametrization",
    "FourierTrajectory",
    "MAX_HARMONICS",
    "MAX_PERIOD_S",
    "check_sampling",
    "design_excitation",
    "fit_to_limits",
    "fourier_series",
    "limit_scales",
    "load_fourier",
    "random_fourier_trajectory",
]
