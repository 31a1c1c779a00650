"""RobotModel: YAML round trip, validation messages, error parameters."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.loading import load_robot, shipped_robots
from rmdrake.model.robot import JointLimits, RobotModel, require_dynamics


def test_shipped_robots_present():
    assert {"rv3sb", "demo_rh"} <= set(shipped_robots())


def test_yaml_round_trip_is_exact(any_robot, tmp_path):
    """load -> save -> load gives identical numbers (and identical YAML text),
    joint types included."""
    shipped = any_robot
    path = tmp_path / "robot.yaml"
    shipped.save(path)
    again = load_robot(path)
    for field in ("mdh", "tool", "gravity", "dynamics", "sigma"):
        np.testing.assert_array_equal(getattr(again, field), getattr(shipped, field))
    for key in ("lower", "upper", "velocity", "acceleration", "effort"):
        np.testing.assert_array_equal(
            getattr(again.limits, key), getattr(shipped.limits, key)
        )
    assert (again.payload is None) == (shipped.payload is None)
    if shipped.payload is not None:
        assert again.payload.mass == shipped.payload.mass
        np.testing.assert_array_equal(again.payload.inertia, shipped.payload.inertia)
    assert again.to_yaml() == shipped.to_yaml()


def test_calibration_section_round_trips(rv3sb, tmp_path):
    import dataclasses

    record = {"method": "lm", "deltas": {"dd2": {"value": 1e-4, "std": 2e-6}}}
    model = dataclasses.replace(rv3sb, calibration=record)
    model.save(tmp_path / "c.yaml")
    assert load_robot(tmp_path / "c.yaml").calibration == record


def _data(robot="rv3sb"):
    return copy.deepcopy(load_robot(robot).to_dict())


def _break(path, edit):
    data = _data()
    edit(data)
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d.pop("mdh"), "missing key 'mdh'"),
        (lambda d: d.pop("limits"), "missing key 'limits'"),
        (lambda d: d["mdh"][2].pop("alpha"), r"mdh\[2\]: missing key 'alpha'"),
        (lambda d: d["mdh"][1].update(r="abc"), r"mdh\[1\].r: expected a number"),
        (
            lambda d: d["mdh"][0].update(d=float("nan")),
            r"mdh\[0\].d: expected a finite",
        ),
        (lambda d: d["tool"].update(r=float("inf")), r"tool.r: expected a finite"),
        (lambda d: d["tool"].update(foo=1.0), r"tool: unknown key\(s\) foo"),
        (lambda d: d["limits"]["lower"].pop(), r"limits.lower: expected 6 values"),
        (lambda d: d["limits"].pop("velocity"), r"limits: missing key 'velocity'"),
        (  # 0 is not "unknown": leave the key out for that
            lambda d: d["limits"]["effort"].__setitem__(2, 0.0),
            r"limits.effort: expected positive values, found 0.0 for joint 3; "
            r"leave 'effort' out",
        ),
        (
            lambda d: d["limits"]["upper"].__setitem__(1, -3.0),
            r"limits: joint 2 has lower .* > upper",
        ),
        (
            lambda d: d["limits"]["velocity"].__setitem__(0, 0.0),
            r"limits.velocity: expected positive",
        ),
        (lambda d: d["dynamics"].pop(), "dynamics: expected 6 link mappings"),
        (lambda d: d["dynamics"][3].pop("fc"), r"dynamics\[3\]: missing key 'fc'"),
        (lambda d: d.update(gravity=[0, 0]), "gravity: expected 3 values"),
        (
            lambda d: d["mdh"][0].update(type="prismatic"),
            r"mdh\[0\]: unknown key\(s\) type \(a joint's type is sigma: 0",
        ),
        (lambda d: d["mdh"][1].update(sigma=2), r"mdh\[1\].sigma: expected 0"),
        (lambda d: d["tool"].update(sigma=1), r"tool: unknown key\(s\) sigma"),
        (  # a prismatic joint's travel in mm
            lambda d: (
                d["mdh"][0].update(sigma=1),
                d["limits"]["upper"].__setitem__(0, 800.0),
            ),
            r"limits.upper: joint 1 has 800, beyond 100 m: .*looks like mm",
        ),
    ],
)
def test_bad_yaml_raises_naming_the_field(tmp_path, edit, message):
    path = _break(tmp_path / "bad.yaml", edit)
    with pytest.raises(ValueError, match=message) as info:
        load_robot(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_unknown_robot_and_unreadable_file(tmp_path):
    with pytest.raises(ValueError, match="unknown robot 'nope'.*rv3sb"):
        load_robot("nope")
    with pytest.raises(ValueError, match="cannot read robot YAML"):
        load_robot(tmp_path / "missing.yaml")
    (tmp_path / "x.yaml").write_text("name: [unclosed")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_robot(tmp_path / "x.yaml")


@pytest.mark.parametrize("absent", ["left out", "null"])
def test_yaml_without_effort_is_kinematic_only(absent, tmp_path):
    """``limits.effort`` left out (or null) and no ``dynamics``: the model
    loads, kinematic-only, with its kinematics; its YAML writes neither and
    round-trips exactly."""
    data = _data()
    if absent == "null":
        data["limits"]["effort"] = None
    else:
        del data["limits"]["effort"]
    del data["dynamics"]
    (tmp_path / "k.yaml").write_text(yaml.safe_dump(data))
    model = load_robot(tmp_path / "k.yaml")
    assert model.limits.effort is None and not model.has_effort_limits
    assert model.dynamics is None and model.kinematic_only
    np.testing.assert_array_equal(model.table, load_robot("rv3sb").table)
    written = model.to_dict()
    assert "effort" not in written["limits"] and "dynamics" not in written
    again = load_robot(model.save(tmp_path / "again.yaml"))
    assert again.to_yaml() == model.to_yaml()


def test_kinematic_only_and_require_dynamics(rv3sb):
    """A full model passes; one without effort limits, dynamics or both is
    kinematic-only and refused in one line naming the robot, only what it
    lacks of what is asked for, and the command."""
    assert not rv3sb.kinematic_only and rv3sb.has_effort_limits
    require_dynamics(rv3sb, "rmdrake simulate")
    no_effort = dataclasses.replace(
        rv3sb, limits=dataclasses.replace(rv3sb.limits, effort=None)
    )
    assert no_effort.kinematic_only and rv3sb.with_dynamics(None).kinematic_only
    with pytest.raises(ValueError) as e:
        require_dynamics(no_effort, "rmdrake simulate")
    assert str(e.value) == (
        "robot 'rv3sb' has no joint effort limits (a kinematic-only model; "
        "expected 'limits: effort'): rmdrake simulate needs them"
    )
    require_dynamics(no_effort, "the controller", effort=False)
    require_dynamics(rv3sb.with_dynamics(None), "identify", dynamics=False)
    bare = no_effort.with_dynamics(None)
    with pytest.raises(ValueError) as e:
        require_dynamics(bare, "the station", role="true robot", remedy="do X")
    assert str(e.value).startswith(
        "true robot 'rv3sb' has no dynamics and no joint effort limits"
    )
    assert str(e.value).endswith("): the station needs them; do X")
    with pytest.raises(ValueError, match=r"no dynamics \(.*'dynamics' section"):
        require_dynamics(bare, "the station", effort=False)


def test_scientific_notation_accepted(tmp_path):
    """PyYAML reads 1.5e5 as a string (YAML 1.1); the model accepts it."""
    data = _data()
    data["limits"]["effort"] = ["1.5e5"] * 6
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(data))
    assert load_robot(tmp_path / "s.yaml").limits.effort[0] == 1.5e5


def test_error_parameter_presets(rv3sb):
    paper = error_parameter_names(rv3sb, "paper")
    assert len(paper) == 17
    assert set(paper) == {
        *(f"dalpha{j}" for j in range(2, 8)),
        *(f"dd{j}" for j in range(2, 8)),
        "dr2", "dr4", "dr5", "dr6", "dbeta3",
    }  # fmt: skip
    full = error_parameter_names(rv3sb, "full")
    assert len(full) == 35 and len(set(full)) == 35
    np.testing.assert_array_equal(
        np.sort(error_parameter_indices(rv3sb, full)), np.arange(35)
    )
    with pytest.raises(ValueError, match="unknown parameter preset"):
        error_parameter_names(rv3sb, "all")


@pytest.mark.parametrize("name", ["dgamma2", "dd0", "dd8", "alpha2", "dr"])
def test_unknown_error_parameter_is_named(rv3sb, name):
    with pytest.raises(ValueError, match=f"unknown error parameter '{name}'"):
        error_parameter_indices(rv3sb, [name])


def test_apply_deltas(rv3sb):
    model = apply_deltas(rv3sb, ["dd3", "dbeta3", "dr7"], [1e-3, 2e-3, -5e-4])
    assert model.mdh[2, 1] == rv3sb.mdh[2, 1] + 1e-3
    assert model.mdh[2, 4] == 2e-3
    assert model.tool[3] == rv3sb.tool[3] - 5e-4
    changed = np.flatnonzero(model.table != rv3sb.table)
    assert changed.size == 3
    assert isinstance(model, RobotModel) and rv3sb.mdh[2, 1] == 0.245
    with pytest.raises(ValueError, match=r"deltas: expected shape \(3,\)"):
        apply_deltas(rv3sb, ["dd3", "dbeta3", "dr7"], [1.0])
    with pytest.raises(ValueError, match="given twice"):
        apply_deltas(rv3sb, ["dd3", "dd3"], [1.0, 1.0])


def test_model_arrays_are_read_only(rv3sb):
    with pytest.raises(ValueError):
        rv3sb.mdh[0, 0] = 1.0


# Any finite value within the SI bounds of rmdrake.model.units (12 < 4 pi rad
# and < 100 m): beyond them a model is refused as written in mm or degrees.
finite = st.floats(min_value=-12.0, max_value=12.0, width=64)


@settings(max_examples=60, deadline=None)
@given(
    mdh=st.lists(st.lists(finite, min_size=5, max_size=5), min_size=1, max_size=8),
    tool=st.lists(finite, min_size=5, max_size=5),
    dyn_scale=finite,
)
def test_any_finite_model_round_trips_exactly(tmp_path_factory, mdh, tool, dyn_scale):
    """Property: every finite number (subnormals, -0.0, 1e308 ...) survives
    save -> load bit for bit (inertia and mass >= 0: a body's, else refused)."""
    n = len(mdh)
    dynamics = np.full((n, 13), dyn_scale)
    dynamics[:, [0, 1, 2, 3, 4, 5, 9]] = abs(dyn_scale)  # PSD, rank 1
    model = RobotModel(
        name="any",
        mdh=np.array(mdh),
        tool=np.array(tool),
        limits=JointLimits(
            lower=-np.ones(n), upper=np.ones(n), velocity=np.ones(n),
            acceleration=np.ones(n), effort=np.ones(n),
        ),
        dynamics=dynamics,
    )  # fmt: skip
    path = tmp_path_factory.mktemp("rt") / "m.yaml"
    again = load_robot(model.save(path))
    assert again.mdh.tobytes() == model.mdh.tobytes()
    assert again.tool.tobytes() == model.tool.tobytes()
    assert again.dynamics.tobytes() == model.dynamics.tobytes()


def test_base_frame_round_trips_and_is_checked(rv3sb, tmp_path):
    """The optional base_frame (X_LB, m and rad) survives save/load exactly; a
    bad one is refused with one line naming the field."""
    import dataclasses

    from rmdrake.model.robot import BaseFrame

    frame = BaseFrame("base_link", [0.1, -0.2, 0.3], [0.01, -0.02, 1.5])
    model = dataclasses.replace(rv3sb, base_frame=frame)
    again = load_robot(model.save(tmp_path / "b.yaml"))
    assert again.base_frame.link == "base_link"
    np.testing.assert_array_equal(again.base_frame.xyz, frame.xyz)
    np.testing.assert_array_equal(again.base_frame.rpy, frame.rpy)
    assert load_robot("rv3sb").base_frame is None
    for bad, field in (
        ({"link": "a", "xyz": [0, 0], "rpy": [0, 0, 0]}, "base_frame.xyz"),
        ({"link": "a", "xyz": [0, 0, 0]}, "base_frame"),
        ({"link": "a", "xyz": [0, 0, 0], "rpy": [0, 0, 90]}, "base_frame"),
        ({"link": 3, "xyz": [0, 0, 0], "rpy": [0, 0, 0]}, "base_frame.link"),
    ):
        data = _data()
        data["base_frame"] = bad
        with pytest.raises(ValueError, match=field) as e:
            RobotModel.from_dict(data)
        assert "\n" not in str(e.value)


def test_acceleration_limit_defaults_from_velocity():
    """limits.acceleration may be left out: velocity reached in 0.5 s."""
    from rmdrake.model.robot import DEFAULT_ACCELERATION_TIME

    data = _data()
    del data["limits"]["acceleration"]
    model = RobotModel.from_dict(data)
    assert DEFAULT_ACCELERATION_TIME == 0.5
    np.testing.assert_allclose(
        model.limits.acceleration, np.array(data["limits"]["velocity"]) / 0.5
    )
    del data["limits"]["velocity"]
    with pytest.raises(ValueError, match="limits: missing key 'velocity'"):
        RobotModel.from_dict(data)


def test_error_parameters_build_on_the_robot():
    """The error parameters name entries of the robot's MDH table: the module
    imports the robot description (the import graph has no cycle, see
    tests/test_layers.py), and the public API re-exports both."""
    import rmdrake
    import rmdrake.model.error_parameters as ep
    import rmdrake.model.robot as robot

    assert rmdrake.apply_deltas is ep.apply_deltas
    assert rmdrake.MDH_KEYS is robot.MDH_KEYS
    assert robot.MDH_KEYS == ("alpha", "d", "theta", "r", "beta")


def test_drive_gain_round_trips_and_is_checked(rv3sb, tmp_path):
    """drive: {gain} (N m/A, one per joint) survives save/load exactly; absent it
    is None; a bad gain is refused with one line naming the field."""
    import dataclasses

    gain = np.array([1.5, 2.25, 0.75, 0.3, 0.2, 0.125])
    model = dataclasses.replace(rv3sb, drive_gain=gain)
    again = load_robot(model.save(tmp_path / "d.yaml"))
    assert again.drive_gain.tobytes() == gain.tobytes()
    assert rv3sb.drive_gain is None and "drive" not in rv3sb.to_dict()
    for bad, field in (
        ({"gain": [1.0] * 5}, "drive.gain: expected 6 values"),
        ({"gain": [1.0] * 5 + [0.0]}, "drive.gain: expected positive"),
        ({"gain": [1.0] * 5 + [-2.0]}, "drive.gain: expected positive"),
        ({"gain": [1.0] * 5 + [".nan"]}, "drive.gain"),
        ({"gains": [1.0] * 6}, "drive: expected a mapping with gain"),
        ([1.0] * 6, "drive: expected a mapping with gain"),
    ):
        data = _data()
        data["drive"] = bad
        with pytest.raises(ValueError, match=field) as e:
            RobotModel.from_dict(data)
        assert "\n" not in str(e.value)
