"""Regressor oracle: Y @ chi == Drake's CalcInverseDynamics (+ friction).

Tolerance 1e-9 relative to the largest torque of the batch: both sides are exact
rigid-body dynamics in float64 (observed agreement ~1e-15), so anything above
round-off is a modelling difference.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces

from rmdrake.dynamics import (
    SerialChain,
    plant_standard_parameters,
    random_standard_parameters,
    regressor,
    regressor_columns,
    standard_parameters,
    torques,
    urdf_plant,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant

RTOL = 1e-9


def drake_inverse_dynamics(plant, q, qd, qdd, context=None) -> np.ndarray:
    """tau = M qdd + C qd - tau_g - tau_damping, per sample (N, n), plant order
    (the tests' oracle; ``context``: one with parameters set, else the
    default)."""
    ctx = plant.CreateDefaultContext() if context is None else context
    out = []
    for qi, vi, ai in zip(q, qd, qdd, strict=True):
        plant.SetPositions(ctx, qi)
        plant.SetVelocities(ctx, vi)
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, forces)  # gravity, damping
        out.append(plant.CalcInverseDynamics(ctx, ai, forces))
    return np.array(out)


def random_states(rng, N, n, scale=2.0):
    return tuple(rng.uniform(-scale, scale, (N, n)) for _ in range(3))


def assert_close(tau, ref):
    err = np.max(np.abs(tau - ref)) / np.max(np.abs(ref))
    assert err < RTOL, f"relative error {err:.3g}"


def friction(chi, qd):
    links = chi.reshape(-1, 13)
    return links[:, 11] * qd + links[:, 12] * np.sign(qd)


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh"])
def test_shipped_robot_matches_drake(name, rng):
    model = load_robot(name)  # demo_rh has a 4.5 t payload folded into link 6
    q, qd, qdd = random_states(rng, 8, model.n_joints)
    chi = standard_parameters(model)
    plant, _ = MakePlant(model, visual=False)
    ref = drake_inverse_dynamics(plant, q, qd, qdd) + friction(chi, qd)
    assert_close(regressor(model, q, qd, qdd) @ chi, ref)


@pytest.mark.parametrize("name", ["rv3sb", "demo_rh"])
def test_random_parameters_match_drake(name, rng):
    model = load_robot(name)
    n = model.n_joints
    for _ in range(3):
        chi = random_standard_parameters(n, rng)
        m = dataclasses.replace(model.with_dynamics(chi.reshape(n, 13)), payload=None)
        q, qd, qdd = random_states(rng, 6, n)
        plant, _ = MakePlant(m, visual=False)
        ref = drake_inverse_dynamics(plant, q, qd, qdd) + friction(chi, qd)
        assert_close(torques(SerialChain.from_model(m), q, qd, qdd, chi), ref)


def test_from_plant_equals_from_model(rv3sb, rng):
    plant, _ = MakePlant(rv3sb, visual=False)
    chain = SerialChain.from_plant(plant)
    q, qd, qdd = random_states(rng, 5, 6)
    np.testing.assert_allclose(
        regressor(chain, q, qd, qdd), regressor(rv3sb, q, qd, qdd), atol=1e-12
    )


def test_single_sample_shape(rv3sb, rng):
    q, qd, qdd = (x[0] for x in random_states(rng, 1, 6))
    Y = regressor(rv3sb, q, qd, qdd)
    assert Y.shape == (6, 78)
    np.testing.assert_array_equal(Y, regressor(rv3sb, q[None], qd[None], qdd[None])[0])
    # link k acts on joints 1..k only
    Yf = Y.reshape(6, 6, 13)
    for j in range(6):
        assert np.all(Yf[j, :j] == 0)


def test_large_batch_runs_in_chunks_with_the_same_result(rv3sb, rng):
    q, qd, qdd = random_states(rng, 3100, 6)  # three chunks
    Yc = regressor_columns(SerialChain.from_model(rv3sb), q.T.copy(), qd.T.copy(),
                           qdd.T.copy())  # fmt: skip
    np.testing.assert_array_equal(regressor(rv3sb, q, qd, qdd), Yc.transpose(2, 1, 0))


def test_out_buffer_is_reused(rv3sb, rng):
    q, qd, qdd = random_states(rng, 9, 6)
    out = np.full((9, 6, 78), np.nan)
    Y = regressor(rv3sb, q, qd, qdd, out=out)
    assert Y is out
    np.testing.assert_array_equal(out, regressor(rv3sb, q, qd, qdd))
    with pytest.raises(
        ValueError,
        match=r"out: expected a C-contiguous float64 "
        r"array of shape \(9, 6, 78\)",
    ):
        regressor(rv3sb, q, qd, qdd, out=np.zeros((9, 6, 77)))


def test_columns_option_selects_columns(rv3sb, rng):
    q, qd, qdd = random_states(rng, 7, 6)
    Y = regressor(rv3sb, q, qd, qdd)
    cols = [77, 5, 13, 10, 12]  # any order, any link
    np.testing.assert_array_equal(
        regressor(rv3sb, q, qd, qdd, columns=cols), Y[..., cols]
    )
    mask = np.zeros(78, bool)
    mask[::7] = True
    np.testing.assert_array_equal(
        regressor(rv3sb, q, qd, qdd, columns=mask), Y[..., mask]
    )
    with pytest.raises(ValueError, match="distinct"):
        regressor(rv3sb, q, qd, qdd, columns=[1, 1])


def _rpy(rng):
    return " ".join(f"{v:.6f}" for v in rng.uniform(-np.pi, np.pi, 3))


def _xyz(rng, s=0.3):
    return " ".join(f"{v:.6f}" for v in rng.uniform(-s, s, 3))


def write_urdf(path, rng, n, *, joint_type="revolute", branch=False) -> None:
    """A random serial arm: arbitrary joint origins and axes, inertial frames
    rotated and offset, joint damping, a fixed tool link at the end. Joint
    n // 2 + 1 is of ``joint_type`` and the others revolute, or ``joint_type``
    is a sequence of n URDF joint types."""
    links, joints = [], []

    def link(name):
        m = rng.uniform(0.5, 5.0)
        s = m * rng.uniform(0.005, 0.05, 3)  # second moments: valid inertia
        ixx, iyy, izz = s[1] + s[2], s[0] + s[2], s[0] + s[1]
        links.append(
            f'<link name="{name}"><inertial><origin xyz="{_xyz(rng)}" '
            f'rpy="{_rpy(rng)}"/><mass value="{m:.6f}"/><inertia ixx="{ixx:.6g}" '
            f'iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" iyz="0"/>'
            "</inertial></link>"
        )

    link("base")
    parent = "base"
    for j in range(1, n + 1):
        link(f"l{j}")
        axis = rng.standard_normal(3)
        if j == 2:
            axis = np.array([0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        if isinstance(joint_type, str):
            kind = joint_type if j == n // 2 + 1 else "revolute"
        else:  # one type per joint
            kind = joint_type[j - 1]
        joints.append(
            f'<joint name="j{j}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="l{j}"/><origin xyz="{_xyz(rng)}" rpy="{_rpy(rng)}"/>'
            f'<axis xyz="{" ".join(f"{v:.9f}" for v in axis)}"/>'
            '<limit lower="-3" upper="3" effort="100" velocity="5"/>'
            f'<dynamics damping="{rng.uniform(0, 2):.4f}"/></joint>'
        )
        parent = f"l{j}"
    link("tool")
    joints.append(
        f'<joint name="tool_weld" type="fixed"><parent link="{parent}"/>'
        f'<child link="tool"/><origin xyz="{_xyz(rng)}" rpy="{_rpy(rng)}"/></joint>'
    )
    if branch:
        link("extra")
        joints.append(
            '<joint name="jb" type="revolute"><parent link="l1"/>'
            '<child link="extra"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="100" velocity="5"/></joint>'
        )
    path.write_text(
        '<?xml version="1.0"?><robot name="arm">' + "".join(links + joints) + "</robot>"
    )


@pytest.mark.parametrize("n", [3, 7])
def test_urdf_arm_matches_drake(tmp_path, rng, n):
    path = tmp_path / "arm.urdf"
    write_urdf(path, rng, n)
    plant = urdf_plant(path)
    chain = SerialChain.from_urdf(path)
    assert chain.joint_names == tuple(f"j{j}" for j in range(1, n + 1))
    chi = plant_standard_parameters(plant)  # tool link folded into link n
    assert chi[12::13].max() == 0.0 and chi[11::13].min() > 0.0
    qp, vp, ap = random_states(rng, 6, n)
    ref = drake_inverse_dynamics(plant, qp, vp, ap)  # includes damping = fv qd
    idx = list(chain.q_indices)
    tau = regressor(chain, qp[:, idx], vp[:, idx], ap[:, idx]) @ chi
    assert_close(tau, ref[:, idx])
