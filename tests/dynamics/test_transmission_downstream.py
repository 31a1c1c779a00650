"""The stages after identification on an arm with a coupled wrist (issue 41):
payload identification, excitation design and fleet comparison, each with
one assertion that fails if the coupled motor is lost on the way.

Data are the model's own efforts (regressor with the coupled motor, known
truth); the Drake oracles are in tests/model/test_transmission_plant.py and
tests/systems/test_coupled_station.py.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.dynamics import torques
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.joint_log import JointLog, write_joint_log
from rmdrake.dynamics.payload import identify_payload
from rmdrake.excitation.design import design_excitation
from rmdrake.excitation.random import random_fourier_trajectory
from rmdrake.execution import Execution
from rmdrake.model.dynamic_parameters import extended_parameters
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import Payload
from rmdrake.pipelines.fleet import run_fleet

RATE = 150.0


def _motion(model, seed: int, periods: float = 1.0):
    traj = random_fourier_trajectory(model, seed=seed, fill=0.8)
    t = np.arange(int(periods * RATE / traj.base_frequency)) / RATE
    return t, traj.q(t), traj.qd(t), traj.qdd(t)


def test_payload_on_the_coupled_wrist_arm():
    """A 2 kg payload carried by the geared arm, its efforts the model's: the
    arm's prediction (coupled motor included) leaves exactly the payload,
    whose mass comes back to 1e-9 kg with residuals of round-off; the arm
    without its coupled motor leaves that motor's torque in joint 5's
    residual (over 0.1 N m; its weighting keeps the mass)."""
    arm = load_robot("rv3sb_geared")
    load = Payload(2.0, [0.03, -0.02, 0.05], [4e-3, 4e-3, 3e-3, 0, 0, 0])
    t, q, qd, qdd = _motion(arm, 3)
    tau = torques(
        arm, q, qd, qdd, extended_parameters(dataclasses.replace(arm, payload=load))
    )
    samples = JointSamples(t, q, qd, qdd, tau, RATE)
    found = identify_payload(arm, samples)
    assert abs(found.payload.mass - 2.0) < 1e-9
    assert found.residual_rms.max() < 1e-9
    serial = dataclasses.replace(arm, transmission=None, motor_terms=None)
    assert identify_payload(serial, samples).residual_rms[4] > 0.1


def test_excitation_design_includes_the_coupled_motor():
    """The design's base set is the one identify fits: 55 columns on the
    geared arm (52 + Iam6, fvm6, fcm6), and its cond(A) is finite."""
    arm = load_robot("rv3sb_geared")
    result = design_excitation(
        arm, maxiter=2, popsize=2, n_random=2, progress=False, max_time=60.0
    )
    assert np.isfinite(result.cond)
    from rmdrake.excitation.design import _design_cost  # the cost's base set

    cost = _design_cost(
        arm, np.zeros(6), harmonics=5, base_frequency=0.1,
        t_design=np.linspace(0, 10, 50), margin=0.95, criterion="cond", per_link=13,
    )  # fmt: skip
    assert cost.base.count == 55 and "fvm6" in cost.base.names


def test_fleet_flags_a_worn_coupled_motor(tmp_path):
    """Five geared arms logged on the motor side (the model's efforts plus
    0.01 N m noise), arm 2's coupled motor with twice the viscous friction:
    the fleet flags arm 2's fvm6 (in words, a coupled motor's) and no other
    arm."""
    nominal = load_robot("rv3sb_geared")
    t, q, qd, qdd = _motion(nominal, 4)
    logs = []
    for arm in range(5):
        terms = np.array(nominal.motor_terms)
        if arm == 2:
            terms[0, 1] *= 2.0
        true = dataclasses.replace(nominal, motor_terms=terms)
        tau = torques(true, q, qd, qdd, extended_parameters(true))
        tau += np.random.default_rng(arm).normal(0.0, 0.01, tau.shape)
        log = JointLog(t, q, tau, qd, qdd)
        logs.append(
            write_joint_log(tmp_path / f"arm_{arm}.csv", log, nominal.transmission)
        )
    run = run_fleet(
        nominal, logs, tmp_path / "out", execution=Execution(workers=0),
        echo=lambda _: None,
    )  # fmt: skip
    assert not run.failed, [a.reason for a in run.failed]
    flagged = run.flagged
    assert set(flagged) == {"arm_2"}, flagged
    assert "fvm6" in {f.name.rstrip("R") for f in flagged["arm_2"]}
