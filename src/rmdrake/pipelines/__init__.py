"""What each command does, file to file, callable from Python as the command
line calls it: read and check the inputs, run, check the result (an
implausible one raises :class:`~rmdrake.errors.ImplausibleResultError` and
writes nothing unless forced), write atomically, echo a summary.
"""

from rmdrake.exports import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "rmdrake.model.loading": ("controller_model_for",),
        "rmdrake.pipelines.calibrate": ("calibrate_file",),
        "rmdrake.pipelines.correct": ("correct_file",),
        "rmdrake.pipelines.identify": ("identify_file",),
        "rmdrake.pipelines.show": (
            "robot_summary",
            "save_robot_html",
        ),
        "rmdrake.pipelines.simulate": (
            "log_summary",
            "saturation_warnings",
            "simulate_file",
            "simulate_trajectory",
            "station_config",
        ),
        "rmdrake.pipelines.validate": (
            "robot_labels",
            "validate_file",
        ),
    },
)
