"""Base-parameter counts of chains with prismatic joints, by two oracles.

1. Closed-form counts derived by hand for three chains (gravity g along -z0 of
   the base, so "vertical" = along z0). The rules used are those of Gautier and
   Khalil (IEEE Trans. Robotics and Automation 6(3), 1990) and Khalil and Bennis
   (IJRR 14(2), 1995), summarised in Khalil and Dombre, *Modeling,
   Identification and Control of Robots* (2002), base inertial parameters:
   across a prismatic joint the angular velocity does not change, so link j's
   inertia tensor merges into link j-1's; a slide before the first revolute
   joint carries only its mass; the first revolute joint r1 keeps only ZZ (with
   Ia), and its MX, MY drop when its axis is vertical. Each count below is
   derived from the efforts themselves, so it does not lean on those rules:

   * Cartesian gantry P-P-P, z1 vertical, z2 and z3 horizontal and mutually
     orthogonal. Nothing rotates, so only masses act, and no joint's
     acceleration projects on another's axis:
     tau1 = (M1+M2+M3)(qdd1 + g) + Ia1 qdd1, tau2 = (M2+M3+Ia2) qdd2,
     tau3 = (M3+Ia3) qdd3. Inertial only: {M1+M2+M3, M2+M3, M3} = 3; with Ia:
     {M1+M2+M3, Ia1 (told apart by g), M2+M3+Ia2, M3+Ia3} = 4; with fv, fc:
     4 + 2*3 = 10.
   * Lifting column and horizontal arm P-R-R, all axes vertical (a SCARA on a
     slide). The rotating links move in horizontal planes: no vertical force
     but their weight, no torque about a vertical axis from a vertical
     acceleration or from g. tau1 = (M1+M2+M3)(qdd1 + g) + Ia1 qdd1; joints
     2-3 are the horizontal planar 2R arm: ZZ2R, ZZ3R, MX3R, MY3R (MX2, MY2
     never act: O2 only accelerates vertically). Inertial: 1 + 4 = 5; with Ia:
     + Ia1 (told apart by g) + Ia3 (its column qdd3 in row 3 alone), Ia2 merges
     into ZZ2R: 7; with friction: 7 + 6 = 13.
   * Polar arm R-P: z1 vertical, the slide z2 horizontal through z1 (alpha2 =
     pi/2, d2 = 0, so z1 = y2). Link 2's angular velocity is qd1 z1, its origin
     moves at qd2 z2 + qd1 q2' x2 (q2' = q2 + r2), and g does no work. The
     Lagrangian is 1/2 (ZZ1 + Ia1 + YY2 + M2 r2^2 + 2 MZ2 r2) qd1^2
     + (M2 r2 + MZ2) q2 qd1^2 + 1/2 M2 (q2^2 qd1^2 + qd2^2) - MX2 qd1 qd2
     + 1/2 Ia2 qd2^2: five independent quadratic forms in qd (none is a null
     Lagrangian), so inertial {ZZ1R, MZ2R, M2, MX2} = 4, with Ia 5, with
     friction 5 + 4 = 9.

2. For chains where a hand count is not safe (R-P-R-R with a general geometry,
   the 6-joint ``boom`` arm), the count is the numerical rank of a regressor
   built independently from Drake: the efforts are linear in the parameters,
   so column c of Drake's regressor is tau(chi0 + e_c) - tau(chi0), a finite
   difference of ``CalcInverseDynamics`` (exact up to round-off), over random
   states. It is also run on the three closed-form chains.

Inertial + Ia (11 per link) is checked against Drake (its plant has no Coulomb
friction); 13 per link adds exactly 2 n, because fv_j and fc_j act alone in row
j with qd_j and sign(qd_j), which no inertial column can produce.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_dynamics_regressor import drake_inverse_dynamics

from rmdrake.dynamics import (
    base_parameters,
    random_standard_parameters,
    regressor,
    standard_parameters,
)
from rmdrake.model.plant import (
    MakePlant,
    mdh_static_transform,
    spatial_inertia_from_standard,
)
from rmdrake.model.robot import JointLimits, RobotModel

H = np.pi / 2
CHAINS = {  # rows alpha, d, theta, r, beta; sigma; closed-form counts (10, 11, 13)
    "gantry PPP": (
        [[0, 0, 0, 0.3, 0], [-H, 0.1, -H, 0.2, 0], [-H, 0.05, 0, 0.1, 0]],
        [1, 1, 1],
        (3, 4, 10),
    ),
    "lift+SCARA PRR": (
        [[0, 0, 0, 0.4, 0], [0, 0.1, 0.2, 0.05, 0], [0, 0.4, 0, 0.03, 0]],
        [1, 0, 0],
        (5, 7, 13),
    ),
    "polar RP": ([[0, 0, 0, 0.3, 0], [H, 0, 0, 0.2, 0]], [0, 1], (4, 5, 9)),
    "RPRR": (
        [
            [0, 0, 0, 0.3, 0],
            [-H, 0.05, 0.1, 0.2, 0],
            [H, 0.02, 0.3, 0.1, 0],
            [-H, 0.1, 0, 0.05, 0],
        ],
        [0, 1, 0, 0],
        None,
    ),  # fmt: skip
}


def arm(name: str, rng) -> RobotModel:
    mdh, sigma, _ = CHAINS[name]
    n = len(sigma)
    return RobotModel(
        name=name.split()[-1],
        mdh=np.array(mdh, dtype=float),
        tool=np.zeros(5),
        sigma=np.array(sigma),
        limits=JointLimits(
            lower=[-1.0] * n, upper=[1.0] * n, velocity=[1.0] * n,
            acceleration=[1.0] * n, effort=[100.0] * n,
        ),
        dynamics=random_standard_parameters(n, rng).reshape(n, 13),
    )  # fmt: skip


def drake_regressor_rank(model: RobotModel, rng, n_states: int = 40) -> int:
    """Rank of d tau / d chi (10 inertial + Ia per link) from Drake's inverse
    dynamics by finite differences of the (linear) parameter dependence."""
    plant, _ = MakePlant(model, visual=False)
    ctx = plant.CreateDefaultContext()
    n = model.n_joints
    chi0 = standard_parameters(model).reshape(n, 13)
    bodies = [plant.GetBodyByName(f"link{j}") for j in range(1, n + 1)]
    acts = [plant.GetJointActuatorByName(f"joint{j}") for j in range(1, n + 1)]
    states = [rng.uniform(-1.5, 1.5, (3, n)) for _ in range(n_states)]

    def efforts(chi: np.ndarray) -> np.ndarray:
        for j in range(n):
            bodies[j].SetSpatialInertiaInBodyFrame(
                ctx, spatial_inertia_from_standard(chi[j], True)
            )
            acts[j].SetRotorInertia(ctx, chi[j, 10])
        q, v, a = np.moveaxis(np.array(states), 1, 0)
        return drake_inverse_dynamics(plant, q, v, a, context=ctx).ravel()

    tau0 = efforts(chi0)
    cols = []
    for j in range(n):
        for c in range(11):
            chi = chi0.copy()
            chi[j, c] += 1.0
            cols.append(efforts(chi) - tau0)
    W = np.array(cols).T
    norms = np.linalg.norm(W, axis=0)
    W = W[:, norms > 1e-9 * norms.max()] / norms[norms > 1e-9 * norms.max()]
    s = np.linalg.svd(W, compute_uv=False)
    rank = int(np.sum(s > 1e-7 * s[0]))
    # a clear gap between the kept singular values and round-off
    assert s[rank - 1] > 1e-5 * s[0] and (rank == s.size or s[rank] < 1e-10 * s[0])
    return rank


def test_gantry_axes_are_orthogonal():
    """The closed-form gantry count assumes z1 vertical and z1, z2, z3
    mutually orthogonal: checked on the MDH rows themselves."""
    R = np.eye(3)
    z = []
    for row in CHAINS["gantry PPP"][0]:
        R = R @ mdh_static_transform(np.array(row, float)).rotation().matrix()
        z.append(R[:, 2])
    np.testing.assert_allclose(z[0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(np.array(z) @ np.array(z).T, np.eye(3), atol=1e-15)


@pytest.mark.parametrize("name", ["gantry PPP", "lift+SCARA PRR", "polar RP"])
def test_closed_form_counts(name, rng):
    model = arm(name, rng)
    for per_link, count in zip((10, 11, 13), CHAINS[name][2], strict=True):
        base = base_parameters(model, per_link)
        assert base.count == count, (per_link, base.names)


@pytest.mark.parametrize("name", [*CHAINS, "boom"])
def test_counts_equal_the_rank_of_drakes_regressor(name, rng, boom):
    model = boom if name == "boom" else arm(name, rng)
    n = model.n_joints
    b11 = base_parameters(model, 11)
    assert b11.count == drake_regressor_rank(model, rng)
    assert base_parameters(model, 13).count == b11.count + 2 * n
    assert base_parameters(model, 10).count < b11.count


def test_boom_base_regressor_reproduces_the_efforts(boom):
    base = base_parameters(boom)
    assert base.r_diagonal[base.count - 1] > 1e-6
    assert np.all(base.r_diagonal[base.count :] < 1e-12)
    rng = np.random.default_rng(5)  # states unlike those that found the base
    q, qd, qdd = (rng.uniform(-2, 2, (40, 6)) for _ in range(3))
    for chi in (standard_parameters(boom), random_standard_parameters(6, rng)):
        full = regressor(boom, q, qd, qdd) @ chi
        got = base.regressor(boom, q, qd, qdd) @ base.regroup(chi)
        assert np.max(np.abs(got - full)) < 1e-9 * np.max(np.abs(full))
    # link 4 follows a slide: its six inertia entries merge into link 3's
    assert not {"XX4", "XY4", "XZ4", "YY4", "YZ4", "ZZ4"} & set(base.names)
