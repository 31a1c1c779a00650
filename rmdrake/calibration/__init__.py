"""Plane-constraint kinematic calibration (Wang et al. 2016, §2 and §4).

A range finder on the tool reads the distance to a flat plate put at several
unknown places; the points measured on one plate are coplanar exactly when the
kinematic model is right. This package simulates such readings, analyses which
error parameters they identify, and estimates them with the paper's method
(Differential Evolution on tetrahedron volumes), with Levenberg-Marquardt on
point-to-plane distances, or with both (``de+lm``).
"""

from rmdrake.calibration.calibrator import PlaneCalibrator
from rmdrake.calibration.cost import (
    PlaneProblem,
    VolumeCost,
    fit_plane,
    fit_planes,
    plate_quadruples,
    tetrahedron_volumes,
)
from rmdrake.calibration.estimators import (
    CALIBRATION_LOSSES,
    CALIBRATION_METHODS,
    PlaneLM,
    VolumeDE,
    VolumeDEPlaneLM,
    make_calibrator,
)
from rmdrake.calibration.identifiability import (
    IdentifiabilityReport,
    analyse_identifiability,
)
from rmdrake.calibration.measurements import (
    Plate,
    SimulatedPlates,
    random_poses,
    range_readings,
    simulate_plates,
    solve_tool_ik,
)
from rmdrake.calibration.parameters import parameter_bounds, resolve_parameters
from rmdrake.calibration.pose_selection import select_d_optimal
from rmdrake.calibration.range_finder import (
    BeamReadings,
    RangeFinderSpec,
    beam_readings,
    ray_plane_distance,
)
from rmdrake.calibration.validation import (
    ValidationResult,
    rigid_alignment,
    tool_point_errors,
)
from rmdrake.io import PlaneMeasurements

__all__ = [
    "CALIBRATION_LOSSES",
    "CALIBRATION_METHODS",
    "BeamReadings",
    "IdentifiabilityReport",
    "PlaneCalibrator",
    "PlaneLM",
    "PlaneMeasurements",
    "PlaneProblem",
    "Plate",
    "RangeFinderSpec",
    "SimulatedPlates",
    "ValidationResult",
    "VolumeCost",
    "VolumeDE",
    "VolumeDEPlaneLM",
    "analyse_identifiability",
    "beam_readings",
    "fit_plane",
    "fit_planes",
    "make_calibrator",
    "parameter_bounds",
    "plate_quadruples",
    "random_poses",
    "range_readings",
    "ray_plane_distance",
    "resolve_parameters",
    "rigid_alignment",
    "select_d_optimal",
    "simulate_plates",
    "solve_tool_ik",
    "tetrahedron_volumes",
    "tool_point_errors",
]
