"""Standard parameters: conversions, physical checks and bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_dynamics_regressor import write_urdf

from rmdrake.dynamics import (
    SerialChain,
    StandardParameters,
    check_physical,
    parameter_names,
    plant_standard_parameters,
    pseudo_inertia,
    random_standard_parameters,
    regressor,
    require_physical,
    spatial_inertia_from_standard,
    standard_from_spatial_inertia,
    standard_parameters,
    transform_inertial,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant


def test_names_and_named_vector(rv3sb):
    names = parameter_names(6)
    assert names[:13] == [
        "XX1", "XY1", "XZ1", "YY1", "YZ1", "ZZ1", "MX1", "MY1", "MZ1", "M1",
        "Ia1", "fv1", "fc1",
    ]  # fmt: skip
    assert len(parameter_names(6, 10)) == 60
    p = StandardParameters.from_vector(standard_parameters(rv3sb))
    assert p.n == 6 and p["M2"] == 9.5 and p["fc6"] == 0.4
    assert p.as_dict()["ZZ3"] == p["ZZ3"]
    with pytest.raises(KeyError, match="unknown parameter 'M7'"):
        p["M7"]


def test_spatial_inertia_round_trip(rng):
    chi = random_standard_parameters(4, rng).reshape(4, 13)
    for row in chi:
        back = standard_from_spatial_inertia(spatial_inertia_from_standard(row))
        np.testing.assert_allclose(back, row[:10], rtol=1e-12, atol=1e-14)


def test_transform_inertial_matches_drake(rng):
    from pydrake.math import RigidTransform, RotationMatrix

    p10 = random_standard_parameters(1, rng)[:10]
    X_AB = RigidTransform(RotationMatrix.MakeXRotation(0.7), [0.1, -0.2, 0.3])
    M_BBo_B = spatial_inertia_from_standard(p10)
    # Drake: M_BAo_A = (M_BBo_B re-expressed in A) shifted from Bo to Ao.
    M_BAo_A = M_BBo_B.ReExpress(X_AB.rotation()).Shift(-X_AB.translation())
    got = transform_inertial(p10, X_AB.rotation().matrix(), X_AB.translation())
    np.testing.assert_allclose(got, standard_from_spatial_inertia(M_BAo_A), atol=1e-12)


def test_payload_is_folded_into_last_link():
    model = load_robot("demo_rh")
    chi = standard_parameters(model).reshape(6, 13)
    assert chi[5, 9] == pytest.approx(400.0 + 4500.0)
    # payload COM 0.8 m ahead of the tool, tool 1.0 m along z6: MZ6 gains 4500*1.8
    assert chi[5, 8] == pytest.approx(240.0 + 4500.0 * 1.8)
    bare = dataclasses.replace(model, payload=None)
    np.testing.assert_array_equal(standard_parameters(bare).reshape(6, 13)[:5], chi[:5])


def test_plant_parameters_equal_model_parameters(shipped):
    """Drake's composite inertia of link n + welded payload == the fold; the
    plant has no joint damping or Coulomb friction, so fv = fc = 0 there."""
    plant, _ = MakePlant(shipped, visual=False)
    from_plant = plant_standard_parameters(plant).reshape(-1, 13)
    expected = standard_parameters(shipped).reshape(-1, 13)
    scale = np.max(np.abs(expected))  # Drake's shifts leave round-off, not zeros
    np.testing.assert_allclose(
        from_plant[:, :11], expected[:, :11], rtol=1e-12, atol=1e-14 * scale
    )
    assert np.all(from_plant[:, 11:] == 0.0)


def test_shipped_and_random_parameters_are_physical(shipped, rng):
    report = check_physical(standard_parameters(shipped))
    assert report.ok, str(report)
    assert check_physical(random_standard_parameters(7, rng)).ok
    require_physical(standard_parameters(shipped))  # does not raise


@pytest.mark.parametrize(
    ("column", "value", "check"),
    [
        (9, -1.0, "mass > 0"),
        (0, 5.0, "pseudo-inertia PSD"),  # XX > YY + ZZ: no body has it
        (10, -0.1, "Ia >= 0"),
        (11, -0.1, "fv >= 0"),
        (12, -0.1, "fc >= 0"),
    ],
)
def test_invalid_parameters_name_link_and_check(rv3sb, column, value, check):
    chi = standard_parameters(rv3sb).reshape(6, 13)
    chi[2, column] = value
    report = check_physical(chi)
    assert not report.ok
    assert any(j == 3 and c == check for j, c, _ in report.failures)
    with pytest.raises(ValueError, match=f"link 3: {check}"):
        require_physical(chi, "robot 'rv3sb'")


def test_pseudo_inertia_of_a_point_mass():
    m, p = 2.0, np.array([0.1, 0.2, 0.3])
    P = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    I = -m * P @ P
    params = [I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2], *(m * p), m]
    J = pseudo_inertia(params)
    # The formula against an outer product: a few ulp of the 2 kg scale.
    np.testing.assert_allclose(J, m * np.outer([*p, 1], [*p, 1]), atol=1e-14)
    assert check_physical(np.concatenate([params, [0, 0, 0]])).ok  # singular J


def test_bad_parameter_input():
    with pytest.raises(ValueError, match=r"expected shape \(13n,\) or \(n, 13\)"):
        check_physical(np.ones(12))
    with pytest.raises(ValueError, match="expected finite numbers, found nan"):
        check_physical(np.full(13, np.nan))
    with pytest.raises(ValueError, match="per_link: expected 10, 11 or 13"):
        parameter_names(3, 12)
    model = dataclasses.replace(load_robot("rv3sb"), dynamics=None)
    with pytest.raises(ValueError, match="expected a 'dynamics' section"):
        standard_parameters(model)


def test_bad_states(rv3sb):
    q = np.zeros((4, 6))
    with pytest.raises(
        ValueError,
        match=r"q: expected shape \(N, 6\) or \(6,\) in rad or m, "
        r"found \(4, 5\)",
    ):
        regressor(rv3sb, q[:, :5], q, q)
    with pytest.raises(
        ValueError,
        match=r"qd: expected the shape of q \(4, 6\), "
        r"found \(3, 6\)",
    ):
        regressor(rv3sb, q, q[:3], q)
    bad = q.copy()
    bad[2, 1] = np.nan
    with pytest.raises(
        ValueError,
        match=r"qdd: expected finite numbers, found nan at "
        r"index \(2, 1\)",
    ):
        regressor(rv3sb, q, q, bad)
    with pytest.raises(TypeError, match="expected a SerialChain or RobotModel"):
        regressor("rv3sb", q, q, q)


def test_other_joint_type_names_the_joint():
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import PlanarJoint, SpatialInertia

    plant = MultibodyPlant(0.0)
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(1, 0.1, 0.1, 0.1))
    plant.AddJoint(
        PlanarJoint("slider", plant.world_frame(), box.body_frame(), np.zeros(3))
    )
    plant.Finalize()
    with pytest.raises(
        ValueError,
        match="joint 'slider' is planar: expected a serial arm of revolute and "
        "prismatic joints",
    ):
        SerialChain.from_plant(plant)


def test_branched_urdf_names_the_joint(tmp_path, rng):
    path = tmp_path / "branch.urdf"
    write_urdf(path, rng, 3, branch=True)
    with pytest.raises(
        ValueError,
        match=r"joint '(jb|j2)': not a serial chain: "
        r"joints .* all follow link 'l1'",
    ):
        SerialChain.from_urdf(path)


def test_free_body_plant_names_the_joint():
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import SpatialInertia

    plant = MultibodyPlant(0.0)
    plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1))
    plant.Finalize()
    with pytest.raises(ValueError, match="joint 'box' is quaternion_floating"):
        SerialChain.from_plant(plant)


def test_unreadable_urdf(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(ValueError, match="cannot parse URDF"):
        SerialChain.from_urdf(path)
