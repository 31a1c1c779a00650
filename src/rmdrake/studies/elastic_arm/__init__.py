"""The heavy arm bends: elastostatic calibration and deflection compensation
(scenario ``demo_rh_compliance``).

The paper's motivation (its §1) is a blanket-handling arm whose errors come
"from geometric dimensions, dynamic motion, as well as joint and link
deformations". This study puts a number on the last: on an elastic arm
(``RobotModel.compliance``) with geometric errors, what a rigid calibration
(the paper's model) leaves under load, and what an elastostatic one (the joint
compliances identified with the geometry) and the compensation controller's
pre-deflection buy.

Steps (:func:`run_compliance_study`):

1. The truth: the robot's kinematics with the calibration study's errors on
   ``params`` and its joint stiffness scaled per joint by 1 + spread N(0, 1).
   The nominal model (what every controller and calibration starts from) is
   the robot without compliance: the paper's rigid model.
2. Plate readings with each payload of ``calibration_payloads``, taken in the
   Drake station (the true elastic arm settles at each configuration under a
   controller whose bandwidth is a quarter of its lowest structural mode; the
   encoders read the motor side, the range finder sees the link side).
3. LM calibration of the rigid model (``params``) and of the elastostatic one
   (``params`` and ``c<j>``), both on all the readings.
4. Static tool accuracy on held-out targets (full tool poses) at each of
   ``test_payloads``, the payload held at the tool. The variants command the
   motor side:

   - ``nominal``: the nominal IK (the targets' own configurations);
   - ``rigid``: the targets solved on the rigid calibration;
   - ``elastostatic``: solved on the elastostatic calibration, then
     pre-deflected by its compliances at the payload
     (:func:`rmdrake.dynamics.compliance.motor_angles`);
   - ``oracle``: solved on the true kinematics and pre-deflected by the true
     compliances.

   The attained tool position is where the true arm rests with its motors
   there (:func:`rmdrake.dynamics.compliance.link_angles`); the first
   ``diagram_targets`` targets are also driven in the station at the largest
   payload, with the compensation controller pre-deflecting online, and the
   tool tracker's reading is compared with that static prediction.
5. An insertion-like move along the tool's approach axis with the largest
   payload in the station, each variant's controller tracking it online
   (kinematic correction and pre-deflection inside the controller): the tool
   path error, the residual oscillation after the stop (largest distance from
   the final rest position after the programme ends) and its settling time
   (last time outside ``settle_band`` of the final position).
6. A module picked up mid-task: the compensation controller holds the first
   target with no payload; then the largest payload appears on the true arm's
   tool (its payload body's inertia, a Context parameter) and on the
   controller's ``payload_mass`` source at the same instant (``told``; for
   comparison, not on the controller's: ``not told``); and a third run,
   ``estimating``, whose controller's ``payload_mass`` comes from a
   :class:`~rmdrake.systems.payload_estimator.PayloadEstimator` on the
   measured joint signals (recursive least squares on the payload's mass and
   first moments, the elastostatic calibration's arm subtracted): the tool
   error before, after, its peak and its settling time.

In the station, ``nominal`` and ``rigid`` run computed torque on the nominal
(rigid) model, the rigid calibration's targets corrected already for the
static targets and online inside the compensation controller for the move;
``elastostatic`` and ``oracle`` run the compensation controller, which
pre-deflects its command by its calibrated model's compliances at the payload
(:class:`~rmdrake.systems.deflection.DeflectionCompensation`).

The package follows the steps: :mod:`~rmdrake.studies.elastic_arm.steps`
has one function per step, each returning a small frozen dataclass of
:mod:`~rmdrake.studies.elastic_arm.results`;
:mod:`~rmdrake.studies.elastic_arm.variants` the compared controllers
(:data:`~rmdrake.studies.elastic_arm.variants.VARIANTS`) and their static
model; :mod:`~rmdrake.studies.elastic_arm.station_runs` a variant's runs in
the station (targets and the move) and
:mod:`~rmdrake.studies.elastic_arm.pickup` the pick-up's;
:mod:`~rmdrake.studies.elastic_arm.report` prints the tables and writes the
files; :func:`run_compliance_study`
(:mod:`~rmdrake.studies.elastic_arm.study`) runs them in order. The plate
readings of each payload and every station run of steps 4-6 are tasks
(:mod:`rmdrake.execution`); the figures do not depend on where they ran.

Example::

    from rmdrake.model.loading import load_robot
    from rmdrake.studies.elastic_arm import run_compliance_study
    from rmdrake.studies.scenarios import load_scenario

    scenario = load_scenario(name="demo_rh_compliance_smoke")
    result = run_compliance_study(
        load_robot(scenario.robot), scenario.compliance, "out/compliance"
    )

Files: ``payload_errors.png`` (tool error per target, per model and payload),
``deflection_field.png`` (tool deflection of the nominal controller with the
largest payload over the workspace), ``compliance.html`` (Meshcat: the
nominal, sagging and compensated arm in grey, red and green, deflection
magnified),
``results.yaml``.
"""

from rmdrake.studies.elastic_arm.results import ComplianceStudyResult
from rmdrake.studies.elastic_arm.study import run_compliance_study

__all__ = ["ComplianceStudyResult", "run_compliance_study"]
