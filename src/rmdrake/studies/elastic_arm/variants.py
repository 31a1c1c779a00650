"""The compliance study's compared controllers, one :class:`Variant` record
each (:data:`VARIANTS`), and their static model: the link-side targets each
plans, its motor-side commands and where the true arm rests with them.

========================  ============  ====================  ================
variant                   plans on      pre-deflects          in the move
========================  ============  ====================  ================
``nominal``               nominal IK    no                    nominal
``rigid``                 rigid cal.    no (rigid model)      compensation
``elastostatic``          elastic cal.  its compliances       compensation
``oracle``                true model    true compliances      compensation
========================  ============  ====================  ================

At the static targets in the station, ``nominal`` and ``rigid`` run computed
torque on the nominal (rigid) model, their targets corrected already;
``elastostatic`` and ``oracle`` run the compensation controller, which
pre-deflects its command online by its calibrated model's compliances at the
payload. In the move, every variant but ``nominal`` runs the compensation
controller, which also corrects the nominal program online.

Example::

    models = ElasticModels(nominal, rigid, elastic, true)
    q_m = ELASTOSTATIC.motor_commands(models, q_link, mass=4500.0)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.compensation.correction import correct_targets
from rmdrake.dynamics.compliance import link_angles, motor_angles, with_payload_mass
from rmdrake.kinematics.forward import tool_poses
from rmdrake.model.robot import RobotModel
from rmdrake.systems.station_config import (
    CompensationControllerConfig,
    ControllerConfig,
    InverseDynamicsControllerConfig,
)

__all__ = [
    "ELASTOSTATIC",
    "NOMINAL",
    "ORACLE",
    "RIGID",
    "VARIANTS",
    "ElasticModels",
    "Variant",
    "attained_positions",
    "link_targets",
]


@dataclasses.dataclass(frozen=True)
class ElasticModels:
    """The robots the variants plan with and the station runs take.

    Attributes:
      nominal: the robot without compliance (the paper's rigid model).
      rigid: the rigid calibration.
      elastic: the elastostatic calibration (geometry and joint compliances).
      true: the elastic true robot.
    """

    nominal: RobotModel
    rigid: RobotModel
    elastic: RobotModel
    true: RobotModel


@dataclasses.dataclass(frozen=True)
class Variant:
    """One compared controller.

    Attributes:
      name: its key in the printed tables, ``results.yaml`` and the result's
        dictionaries.
      label: its name in the figures.
      model: the field of :class:`ElasticModels` it plans its targets on and
        pre-deflects with (where that model has compliances).
      corrects: it knows a calibrated model: in the move, the compensation
        controller corrects the nominal program online by it.
      compensates: it pre-deflects for the payload: at the static targets in
        the station, the compensation controller with its deflection layer
        (else computed torque on the nominal model, the targets corrected
        already).
    """

    name: str
    label: str
    model: str
    corrects: bool
    compensates: bool

    def __post_init__(self) -> None:
        fields = [f.name for f in dataclasses.fields(ElasticModels)]
        if self.model not in fields:
            raise ValueError(
                f"variant '{self.name}': model expected one of {fields}, "
                f"found '{self.model}'"
            )

    def planning_model(self, models: ElasticModels) -> RobotModel:
        """The model of ``models`` this variant plans and pre-deflects with."""
        return getattr(models, self.model)

    def motor_commands(
        self, models: ElasticModels, q_link: np.ndarray, mass: float
    ) -> np.ndarray:
        """Motor-side commands (..., n), rad, for the link-side targets
        ``q_link`` (..., n), rad: pre-deflected at ``mass`` kg (at the tool)
        by the planning model's compliances where it has them, else
        ``q_link`` itself."""
        model = self.planning_model(models)
        if model.compliance is None:
            return q_link
        return motor_angles(with_payload_mass(model, mass), q_link, mass)

    def target_controller(
        self, models: ElasticModels, bandwidth: float, mass: float
    ) -> tuple[ControllerConfig, RobotModel | None]:
        """The station controller for static targets at ``bandwidth`` rad/s
        with ``mass`` kg held, and the calibrated model it is given (without
        the payload; None for computed torque on the nominal model)."""
        if not self.compensates:
            return InverseDynamicsControllerConfig(bandwidth=bandwidth), None
        controller = CompensationControllerConfig(
            bandwidth=bandwidth,
            kinematic_correction=False,
            deflection_compensation=True,
            payload_mass=mass,
        )
        return controller, self.planning_model(models)

    def move_controller(
        self, models: ElasticModels, bandwidth: float, mass: float
    ) -> tuple[ControllerConfig, RobotModel | None]:
        """The station controller for the insertion-like move at ``bandwidth``
        rad/s with ``mass`` kg held, and the calibrated model it corrects the
        program by (without the payload; None for the nominal controller)."""
        if not self.corrects:
            return InverseDynamicsControllerConfig(bandwidth=bandwidth), None
        if self.compensates:
            controller = CompensationControllerConfig(
                bandwidth=bandwidth, deflection_compensation=True, payload_mass=mass
            )
        else:
            controller = CompensationControllerConfig(
                bandwidth=bandwidth, deflection_compensation=False
            )
        return controller, self.planning_model(models)


NOMINAL = Variant("nominal", "nominal controller", "nominal", False, False)
"""The nominal IK (the targets' own configurations) and the nominal
controller."""
RIGID = Variant("rigid", "rigid calibration (paper)", "rigid", True, False)
"""The targets solved on the rigid calibration (the paper's model)."""
ELASTOSTATIC = Variant(
    "elastostatic", "elastostatic calibration + compensation", "elastic", True, True
)
"""Solved on the elastostatic calibration, pre-deflected by its compliances."""
ORACLE = Variant(
    "oracle", "oracle (true kinematics and compliance)", "true", True, True
)
"""Solved on the true kinematics, pre-deflected by the true compliances."""
VARIANTS = (NOMINAL, RIGID, ELASTOSTATIC, ORACLE)
"""The compared controllers, in the order of the tables and figures."""


def link_targets(
    models: ElasticModels, q_nom: np.ndarray, X_BE: np.ndarray
) -> dict[str, np.ndarray]:
    """Link-side joint targets (K, n) of each variant by name, rad: the
    nominal IK (the targets' own configurations ``q_nom``, (K, n) rad), or the
    full tool poses ``X_BE`` (K, 4, 4; m, in the base frame B) solved on the
    variant's planning model, seeded at ``q_nom``."""
    p, R = X_BE[:, :3, 3], X_BE[:, :3, :3]
    out = {NOMINAL.name: q_nom}
    for variant in VARIANTS:
        if variant is NOMINAL:
            continue
        model = variant.planning_model(models)
        out[variant.name] = correct_targets(model, p, q_seed=q_nom, orientation=R).q
    return out


def attained_positions(true: RobotModel, q_m: np.ndarray, mass: float) -> np.ndarray:
    """(K, 3) tool positions p_BE, m, of the ``true`` arm at rest with its
    motors at ``q_m`` (K, n), rad, holding ``mass`` kg at the tool."""
    q_l = link_angles(with_payload_mass(true, mass), q_m, mass)
    return tool_poses(true.table, q_l, sigma=true.sigma)[:, :3, 3]
