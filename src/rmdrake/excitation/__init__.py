"""Excitation for dynamic identification (paper eq. 11-17): Fourier
trajectories and their file (:mod:`~rmdrake.excitation.trajectory`), random
ones (:mod:`~rmdrake.excitation.random`) and the optimal design by DE
(:mod:`~rmdrake.excitation.design`).
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.excitation.design": (
            "ExcitationCost",
            "ExcitationResult",
            "FourierParametrization",
            "design_excitation",
            "fit_to_limits",
            "limit_scales",
        ),
        "rmdrake.excitation.random": ("random_fourier_trajectory",),
        "rmdrake.excitation.trajectory": (
            "MAX_HARMONICS",
            "MAX_PERIOD_S",
            "FourierTrajectory",
            "check_sampling",
            "fourier_series",
            "load_fourier",
        ),
    },
)
