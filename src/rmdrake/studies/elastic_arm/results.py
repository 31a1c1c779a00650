"""The compliance study's results: one small dataclass per step
(:mod:`rmdrake.studies.elastic_arm.steps`) and the study's outcome,
:class:`ComplianceStudyResult`. SI units throughout (m, rad, kg, s); frames:
B the robot's base (= W, the world), E the tool frame, M the tool tracker's
marker at the tool origin.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.compensation.paths import JointPathProgram
from rmdrake.model.robot import RobotModel
from rmdrake.studies.calibration import CalibrationDraw

__all__ = [
    "ComplianceStudyResult",
    "ElasticCalibration",
    "ElasticReadings",
    "ElasticTruth",
    "InsertionRuns",
    "PathResult",
    "PickupResult",
    "PickupRun",
    "StaticAccuracy",
    "StationAccuracy",
]


@dataclasses.dataclass(frozen=True)
class ElasticTruth:
    """Step 1: the robots and the controllers' bandwidth.

    Attributes:
      nominal: the robot without compliance (the paper's rigid model), what
        every controller and calibration starts from.
      true: the elastic true robot (geometric errors, stiffness spread).
      draw: the geometric errors, plates, planned readings and held-out
        poses, drawn by :func:`~rmdrake.studies.calibration.draw_true_robot`.
      heaviest: the largest of ``test_payloads``, kg.
      mode: lowest structural mode of the robot with ``heaviest`` at its home
        position (joints at 0, clipped to the limits), rad/s.
      bandwidth: every controller's feedback bandwidth, rad/s.
    """

    nominal: RobotModel
    true: RobotModel
    draw: CalibrationDraw
    heaviest: float
    mode: float
    bandwidth: float


@dataclasses.dataclass(frozen=True)
class ElasticReadings:
    """Step 2: the plate readings of every calibration payload.

    Attributes:
      data: the readings (range-finder distances, m; motor-side joint
        angles, rad), with their ``payload`` column, kg.
      wall_time: wall time of taking them, s.
    """

    data: PlaneMeasurements
    wall_time: float


@dataclasses.dataclass(frozen=True)
class ElasticCalibration:
    """Step 3: the rigid and the elastostatic calibration.

    Attributes:
      rigid: the rigid calibration (``params`` from the lightest payload's
        readings).
      elastic: the elastostatic one (``params`` and the joint compliances
        from all readings).
      verdicts: fit name -> its check against the declared reading noise
        ("plausible" or "flagged: " and the reasons).
      stiffness: (n,) the true joint stiffness, N m/rad.
      stiffness_identified: (n,) the elastostatic calibration's, NaN where
        not identified, N m/rad.
      geometric: "rigid" and "elastostatic" -> mean tool-point error of the
        calibrated kinematics at the held-out poses, no load, m.
    """

    rigid: RobotModel
    elastic: RobotModel
    verdicts: dict[str, str]
    stiffness: np.ndarray
    stiffness_identified: np.ndarray
    geometric: dict[str, float]


@dataclasses.dataclass(frozen=True)
class StaticAccuracy:
    """Step 4: static tool accuracy at the held-out targets (SI units).

    Attributes:
      q_nominal: (K, n) the targets' nominal configurations, rad.
      X_BE: (K, 4, 4) the target tool poses in the base frame B (the nominal
        kinematics at ``q_nominal``), m.
      q_link: variant -> (K, n) its link-side joint targets, rad.
      errors: (variant, payload kg) -> (K,) tool position errors of the true
        arm at rest with the variant's motor commands, m.
      deflection: (K,) tool deflection of the nominal commands with the
        largest payload (rest against rigid), m.
      q_compensated: (n,) the elastostatic variant's motor command for the
        first target with the largest payload, rad.
    """

    q_nominal: np.ndarray
    X_BE: np.ndarray
    q_link: dict[str, np.ndarray]
    errors: dict[tuple[str, float], np.ndarray]
    deflection: np.ndarray
    q_compensated: np.ndarray


@dataclasses.dataclass(frozen=True)
class StationAccuracy:
    """Step 4 in the station: the first targets driven with the largest
    payload.

    Attributes:
      errors: variant -> (k,) tool errors read by the tool tracker, m (empty
        when no target is driven).
      gap: largest |station - static prediction| over those, m.
    """

    errors: dict[str, np.ndarray]
    gap: float


@dataclasses.dataclass(frozen=True)
class PathResult:
    """Step 5, the insertion-like move under one variant (SI units).

    Attributes:
      max_error: largest tool distance from the path point at the same time
        during the move, m.
      final_error: tool distance from the path's end at the end of the hold, m.
      oscillation: largest tool distance from its final rest position after
        the programme ends, m.
      settling_time: time after the programme's end until the tool stays
        within the settle band of its final position, s.
    """

    max_error: float
    final_error: float
    oscillation: float
    settling_time: float


@dataclasses.dataclass(frozen=True)
class InsertionRuns:
    """Step 5: the insertion-like move with the largest payload.

    Attributes:
      program: the joint programme, planned on the nominal model.
      results: variant -> :class:`PathResult`.
    """

    program: JointPathProgram
    results: dict[str, PathResult]


@dataclasses.dataclass(frozen=True)
class PickupRun:
    """One pick-up run (:func:`~rmdrake.studies.elastic_arm.pickup.pickup_run`).

    Attributes:
      t: (K,) log times, s.
      p_WM: (K, 3) tool positions, m.
      estimated_mass: the estimator's payload mass at the end, kg (None
        without an estimator).
    """

    t: np.ndarray
    p_WM: np.ndarray
    estimated_mass: float | None


@dataclasses.dataclass(frozen=True)
class PickupResult:
    """Step 6, a module picked up mid-task (SI units): the arm holds a target
    with no payload, then the payload's mass appears on the tool (the true
    plant's payload body, a Context parameter) and, for ``told``, on the
    controller's ``payload_mass`` source at the same instant.

    Attributes:
      before: tool error at the end of the unloaded hold, m.
      told, untold: tool error at the end of the loaded hold, with the
        controller's payload mass updated and left at 0, m.
      peak: largest tool error after the pick-up (told), m.
      settling_time: time after the pick-up until the told arm stays within the
        settle band of its final position, s.
      estimating, estimating_peak, estimating_settling_time: the same three
        figures (final error m, peak m, settling s) with the controller's
        payload mass from the online estimator
        (:data:`~rmdrake.studies.elastic_arm.pickup.ESTIMATING`).
      estimated_mass: the estimator's payload mass at the end, kg.
    """

    before: float
    told: float
    untold: float
    peak: float
    settling_time: float
    estimating: float = float("nan")
    estimating_peak: float = float("nan")
    estimating_settling_time: float = float("nan")
    estimated_mass: float = float("nan")


@dataclasses.dataclass
class ComplianceStudyResult:
    """Outcome of
    :func:`~rmdrake.studies.elastic_arm.study.run_compliance_study` (SI units).

    Attributes:
      true, rigid, elastic: the true robot and the two calibrated models.
      readings: plate readings used (all payloads).
      stiffness: (n,) true stiffness; stiffness_identified: (n,) the
        elastostatic calibration's (NaN where not identified), N m/rad.
      static: (variant, payload kg) -> (K,) tool errors at the targets, m.
      deflection: (K,) tool deflection of the nominal commands with the
        largest payload (rest against rigid), m.
      diagram: variant -> (k,) tool errors of the station runs, m.
      diagram_gap: largest |station - static prediction| over those, m.
      mode: lowest structural mode of the nominal robot, rad/s; bandwidth:
        the controllers', rad/s.
      path: variant -> :class:`PathResult`.
      pickup: the module picked up mid-task (:class:`PickupResult`), or None.
      files: written files.

    Example:

    >>> import dataclasses
    >>> from rmdrake.studies import ComplianceStudyResult
    >>> [f.name for f in dataclasses.fields(ComplianceStudyResult)][:3]
    ['true', 'rigid', 'elastic']
    """

    true: RobotModel
    rigid: RobotModel
    elastic: RobotModel
    readings: int
    stiffness: np.ndarray
    stiffness_identified: np.ndarray
    static: dict[tuple[str, float], np.ndarray]
    deflection: np.ndarray
    diagram: dict[str, np.ndarray]
    diagram_gap: float
    mode: float
    bandwidth: float
    path: dict[str, PathResult]
    pickup: PickupResult | None = None
    files: list[Path] = dataclasses.field(default_factory=list)

    def mean(self, variant: str, payload: float) -> float:
        """Mean static tool error of ``variant`` at ``payload`` kg, m."""
        return float(np.mean(self.static[(variant, payload)]))
