"""ros_control transmissions in URDF, in and out (issue 41).

Oracle: ros_control's own position maps (transmission_interface,
simple_transmission.h: x_a = n x_j; four_bar_linkage_transmission.h:
x_a1 = n_j1 n_a1 x_j1, x_a2 = n_a2 (x_j1 + n_j2 x_j2)) evaluated by hand
against the imported transmission's motor positions."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from rmdrake.model.loading import load_robot
from rmdrake.model.transmission import Transmission
from rmdrake.model.urdf.importer import robot_from_urdf, robot_to_urdf

_TWO = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
  {transmissions}
</robot>
"""


def _import(tmp_path, transmissions: str):
    path = tmp_path / "two.urdf"
    path.write_text(_TWO.replace("{transmissions}", transmissions))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = robot_from_urdf(path, base="base", tip="l2")
    return model, [str(w.message) for w in caught]


def test_four_bar_is_ros_controls_position_map(tmp_path):
    """A FourBarLinkageTransmission (n_a = 80, 40; n_j = 1.5, 2) imports as
    ratios (120, 80) and motor 2 coupled to joint 1 by 1/2: T q equals
    ros_control's x_a1 = n_j1 n_a1 x_j1, x_a2 = n_a2 (x_j1 + n_j2 x_j2)."""
    model, notes = _import(
        tmp_path,
        """<transmission name="wrist">
    <type>transmission_interface/FourBarLinkageTransmission</type>
    <joint name="j1"><mechanicalReduction>1.5</mechanicalReduction></joint>
    <joint name="j2"><mechanicalReduction>2</mechanicalReduction></joint>
    <actuator name="a1"><mechanicalReduction>80</mechanicalReduction></actuator>
    <actuator name="a2"><mechanicalReduction>40</mechanicalReduction></actuator>
  </transmission>""",
    )
    tr = model.transmission
    q = np.random.default_rng(0).standard_normal((5, 2))
    ros = np.stack([1.5 * 80 * q[:, 0], 40 * (q[:, 0] + 2 * q[:, 1])], axis=1)
    np.testing.assert_allclose(tr.motor_positions(q), ros, rtol=1e-14)
    assert tr.coupled == (1,)
    assert any("Iam, fvm, fcm are not in a URDF" in n for n in notes)
    assert not any("Drake's URDF parser" in n for n in notes)


def test_simple_reduction_and_unread_types(tmp_path):
    """SimpleTransmission's mechanicalReduction is the gear ratio; a type
    rmdrake does not read is left out with a warning naming it; reductions
    all 1 give no transmission; a zero reduction is one line."""
    model, notes = _import(
        tmp_path,
        """<transmission name="s1">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"/><actuator name="m1"><mechanicalReduction>-30</mechanicalReduction>
    </actuator></transmission>
  <transmission name="d"><type>transmission_interface/DifferentialTransmission</type>
    <joint name="j1"/><joint name="j2"/><actuator name="x"/><actuator name="y"/>
  </transmission>""",
    )
    np.testing.assert_array_equal(model.transmission.ratio, [-30, 1])
    assert any("'d'" in n and "not read" in n for n in notes)
    none, _ = _import(
        tmp_path,
        """<transmission name="s1">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"/><actuator name="m1"/></transmission>""",
    )
    assert none.transmission is None
    with pytest.raises(ValueError, match="mechanicalReduction '0'") as e:
        _import(
            tmp_path,
            """<transmission name="z"><type>SimpleTransmission</type><joint name="j1"/>
    <actuator name="m"><mechanicalReduction>0</mechanicalReduction></actuator>
    </transmission>""",
        )
    assert "\n" not in str(e.value)


def test_geared_arm_round_trips_through_urdf(tmp_path):
    """export-urdf writes the geared arm's ratios (SimpleTransmission) and its
    coupled wrist (FourBarLinkageTransmission); import reads the same
    transmission back, and Drake's reflected inertia of an uncoupled joint
    is still Ia. A coupling with no ros_control form is refused."""
    model = load_robot("rv3sb_geared")
    with pytest.warns(UserWarning, match="Iam, fvm, fcm"):
        text = robot_to_urdf(model)
    assert text.count("FourBarLinkageTransmission") == 1
    path = tmp_path / "g.urdf"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = robot_from_urdf(path, base="base", tip="tool")
    np.testing.assert_allclose(back.transmission.matrix, model.transmission.matrix)
    np.testing.assert_allclose(back.dynamics[:4, 10], model.dynamics[:4, 10])
    C = np.eye(6)
    C[5, 3:5] = [0.5, 1.0]  # motor 6 with joints 4 and 5: no four-bar
    odd = dataclasses.replace(
        model, transmission=Transmission(model.transmission.ratio, C), motor_terms=None
    )
    with pytest.raises(ValueError, match="no ros_control transmission form"):
        robot_to_urdf(odd)
