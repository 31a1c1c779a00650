"""MakePlant: inertias, rotor inertia, limits and payload carried into Drake."""

from __future__ import annotations

import numpy as np
import pytest

from rmdrake.model.plant import MakePlant, joint_name, link_name


def test_plant_carries_standard_parameters(any_robot):
    shipped = any_robot
    plant, _ = MakePlant(shipped, visual=False)
    context = plant.CreateDefaultContext()
    for j in range(1, shipped.n_joints + 1):
        XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M, Ia, _, _ = shipped.dynamics[j - 1]
        body = plant.GetBodyByName(link_name(j))
        M_BBo_B = body.CalcSpatialInertiaInBodyFrame(context)
        assert M_BBo_B.get_mass() == M
        np.testing.assert_allclose(M_BBo_B.get_com() * M, [MX, MY, MZ], rtol=1e-14)
        I = M_BBo_B.CalcRotationalInertia().CopyToFullMatrix3()
        expected = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
        np.testing.assert_allclose(I, expected, rtol=1e-12, atol=1e-12 * abs(I).max())
        actuator = plant.GetJointActuatorByName(joint_name(j))
        # Reflected inertia n^2 I_r = Ia (gear ratio n of the transmission, 1
        # without).
        tr = shipped.transmission
        ratio = 1.0 if tr is None else tr.ratio[j - 1]
        assert actuator.default_gear_ratio() == ratio
        assert actuator.default_rotor_inertia() * ratio**2 == pytest.approx(
            Ia, rel=1e-14, abs=1e-300
        )
        joint = plant.GetJointByName(joint_name(j))
        assert joint.position_lower_limits()[0] == shipped.limits.lower[j - 1]
        assert joint.velocity_upper_limits()[0] == shipped.limits.velocity[j - 1]
        assert joint.default_damping() == 0.0
    np.testing.assert_array_equal(
        plant.gravity_field().gravity_vector(), shipped.gravity
    )
    assert plant.num_positions() == shipped.n_joints
    assert plant.num_actuators() == shipped.n_joints
    assert plant.HasBodyNamed("payload") == (shipped.payload is not None)


def test_plant_in_builder_has_visual_geometry(rv3sb):
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant, scene_graph = MakePlant(rv3sb, builder=builder)
    inspector = scene_graph.model_inspector()
    assert inspector.num_geometries() > 2 * rv3sb.n_joints
