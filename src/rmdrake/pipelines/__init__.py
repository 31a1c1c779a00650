"""What each command does, file to file, callable from Python as the command
line calls it: read and check the inputs, run, check the result (an
implausible one raises :class:`~rmdrake.errors.ImplausibleResultError` and
writes nothing unless forced), write atomically, echo a summary.
"""

from __future__ import annotations

from rmdrake.pipelines.calibrate import (  # noqa: F401
    calibrate_file,
)
from rmdrake.pipelines.correct import (  # noqa: F401
    correct_file,
)
from rmdrake.pipelines.identify import (  # noqa: F401
    identify_file,
)
from rmdrake.pipelines.show import (  # noqa: F401
    robot_summary,
    save_robot_html,
)
from rmdrake.pipelines.simulate import (  # noqa: F401
    controller_model_for,
    log_summary,
    saturation_warnings,
    simulate_file,
    simulate_trajectory,
    station_config,
)
from rmdrake.pipelines.validate import (  # noqa: F401
    robot_labels,
    validate_file,
)

__all__ = [
    "calibrate_file",
    "controller_model_for",
    "correct_file",
    "identify_file",
    "log_summary",
    "robot_labels",
    "robot_summary",
    "saturation_warnings",
    "save_robot_html",
    "simulate_file",
    "simulate_trajectory",
    "station_config",
    "validate_file",
]
