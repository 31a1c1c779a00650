"""The configuration of the elastostatic study, read from a scenario's
``compliance:`` section (:mod:`rmdrake.studies.scenarios`).

This module does not use ``from __future__ import annotations``: Drake's loader
reads the field types at run time.
"""

import dataclasses

from rmdrake.systems.measurement_runs import measurement_config
from rmdrake.systems.station_config import StationConfig

__all__ = ["ComplianceStudyConfig"]


@dataclasses.dataclass
class ComplianceStudyConfig:
    """The elastostatic study of a heavy arm with elastic joints (the robot's
    ``compliance``; its stiffness is the truth's nominal value).

    A true robot gets the calibration study's kinematic errors on ``params``
    (sized to ``mean_error``) and joint stiffness off the robot's by a factor
    1 + ``stiffness_spread`` N(0, 1) (seeded). Plate readings are taken in the
    Drake station (``readings_in_diagram``) or from the static model, once per
    payload in ``calibration_payloads`` (all plates each time). Two models are
    calibrated by LM on them: the paper's rigid one (``params``) and the
    elastostatic one (``params`` and the joint compliances). Then static tool
    accuracy at ``test_payloads`` on ``n_targets`` held-out poses (as the
    compensation study's) for the nominal controller, the rigid calibration,
    the elastostatic calibration with deflection compensation and the oracle;
    the first ``diagram_targets`` targets are also driven in the station at
    the largest payload. Last, an insertion-like straight move of
    ``path_length`` along the tool's approach axis at ``path_speed`` of the
    joint limits, then a hold of ``path_hold``, with the largest payload.

    Attributes:
      seed: seeds the true robot, plates, noise and targets.
      params: kinematic error parameters perturbed and calibrated.
      mean_error: mean tool-point error of the nominal kinematics, m.
      stiffness_spread: relative std of the true stiffness about the robot's.
      plates, per_plate: plate locations and readings per plate (per payload).
      noise: range-finder noise, m.
      calibration_payloads: payload masses of the readings, kg.
      test_payloads: payload masses of the accuracy test, kg.
      n_validation: held-out poses of the calibrated models' kinematic error.
      n_targets: held-out targets of the static accuracy test.
      target_margin, min_singular: as the compensation study's.
      readings_in_diagram: take the plate readings in the Drake station (else
        from the static deflection model, which the station reproduces).
      diagram_targets: targets driven in the station per variant (0 = none).
      settle_time: hold before each reading or target, s.
      speed: fraction of the joint limits of the moves.
      bandwidth: feedback bandwidth of every controller, rad/s; 0 = a quarter
        of the nominal robot's lowest structural mode with the largest payload
        at its home position.
      path_length: m; path_speed: fraction of the joint limits; path_hold: s.
      settle_band: tool band of the path's settling time, m.
      station: the Drake station (its controller bandwidth is replaced).
    """

    seed: int = 0
    params: str = "paper"
    mean_error: float = 1.0e-2
    stiffness_spread: float = 0.2
    plates: int = 6
    per_plate: int = 12
    noise: float = 1.0e-5
    calibration_payloads: list[float] = dataclasses.field(
        default_factory=lambda: [0.0, 4500.0]
    )
    test_payloads: list[float] = dataclasses.field(
        default_factory=lambda: [0.0, 2250.0, 4500.0]
    )
    n_validation: int = 500
    n_targets: int = 50
    target_margin: float = 0.15
    min_singular: float = 0.05
    readings_in_diagram: bool = True
    diagram_targets: int = 5
    settle_time: float = 6.0
    speed: float = 0.5
    bandwidth: float = 0.0
    path_length: float = 0.5
    path_speed: float = 0.3
    path_hold: float = 10.0
    settle_band: float = 1.0e-5
    station: StationConfig = dataclasses.field(default_factory=measurement_config)
