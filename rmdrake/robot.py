"""Robot description: modified-DH table, tool, limits and dynamic parameters.

A :class:`RobotModel` is what every part of rmdrake works on, read from and
written to one robot YAML schema (a calibrated robot can be fed back in).

Kinematic convention (Khalil-Kleinfinger modified DH plus Hayati's beta): the pose
of frame j in frame j-1 is::

    X_{j-1,j} = Rot_y(beta_j) Rot_x(alpha_j) Trans_x(d_j) Rot_z(theta_j) Trans_z(r_j)

with theta_j = q_j + theta_j0 for a revolute joint (``sigma: 0``, the default) and
r_j = q_j + r_j0 for a prismatic one (``sigma: 1``), j = 1..n; the table holds the
offsets theta_j0 and r_j0. The tool frame E is one more row (n+1) with no joint.
Angles in rad, lengths in m. The MDH table of a model is the (n+1, 5) array of
these rows with columns ``alpha, d, theta, r, beta``; the joint types are
``RobotModel.sigma``. A prismatic joint's q, limits and effort are in m, m/s,
m/s^2 and N, and its link's ``fv``, ``fc``, ``Ia`` in N s/m, N and kg.

Error parameters (``dalpha<j>`` .. ``dbeta<j>``): :mod:`rmdrake.error_parameters`.

Dynamic parameters: 13 per link in the paper's (Khalil's) order
``XX XY XZ YY YZ ZZ MX MY MZ M Ia fv fc``: inertia tensor entries about the link
frame origin in link frame axes (kg m^2; XY is the tensor entry, i.e. -∫xy dm),
first moments M * p_com (kg m), mass (kg), rotor inertia reflected to the joint
(kg m^2), viscous (N m s/rad) and Coulomb (N m) friction.

Which of these terms (and two more) the robot's model has is the optional
``model: {rotor_inertia, viscous, coulomb, offset, coulomb_asymmetric}``
(:class:`DynamicTerms`; absent: the first three on, the others off). Each
``dynamics`` mapping may add ``fcn`` (the Coulomb level for negative velocity,
N m or N, >= 0: Coulomb effort fc for qd > 0 and -fcn for qd < 0; absent, fcn =
fc) and ``tau0`` (a constant joint effort, N m or N; absent, 0):
:attr:`RobotModel.fcn`, :attr:`RobotModel.tau0`. A term that is off is 0 in
an identified model.

``limits.acceleration`` may be left out (a URDF has none): it then defaults to
the velocity limit reached in 0.5 s (``velocity / DEFAULT_ACCELERATION_TIME``).

The optional top-level ``base_frame: {link, xyz, rpy}`` is the pose X_LB of the
MDH base frame B in a link L of the robot's source (a URDF whose first joint axis
one MDH row cannot reach from L, see :mod:`rmdrake.urdf`): p_L = X_LB p_B (m; rad,
Drake RollPitchYaw). Everything else in the file (gravity, targets) is in B.

The optional top-level ``drive: {gain: [...]}`` gives per joint the drive gain
k_j with tau_j = k_j * i_j (N m per A, or N per A on a prismatic joint; gear
ratio included): :attr:`RobotModel.drive_gain`.
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rmdrake.arrays import as_finite_array
from rmdrake.error_parameters import (
    MDH_KEYS,
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.io import atomic_write_text
from rmdrake.model_units import check_units
from rmdrake.robot_parts import (
    _LIMIT_KEYS,
    EXTRA_DYNAMIC_KEYS,
    BaseFrame,
    Compliance,
    DynamicTerms,
    JointLimits,
    MassBounds,
    Payload,
    _base_frame,
    _compliance,
    _drive_gain,
    _dynamics,
    _frozen,
    _mass_bounds,
    _plain,
    _row,
    _sigma,
)
from rmdrake.yaml_io import load_yaml, read_yaml, yaml_number, yaml_vector

__all__ = [
    "DEFAULT_ACCELERATION_TIME",
    "BaseFrame",
    "Compliance",
    "DYNAMIC_KEYS",
    "DynamicTerms",
    "EXTRA_DYNAMIC_KEYS",
    "MDH_KEYS",
    "JointLimits",
    "MassBounds",
    "Payload",
    "RobotModel",
    "apply_deltas",
    "error_parameter_indices",
    "error_parameter_names",
    "load_robot",
    "shipped_robots",
]

DYNAMIC_KEYS: tuple[str, ...] = (
    "XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "Ia", "fv", "fc",
)  # fmt: skip
_MODELS = "rmdrake.models"
DEFAULT_ACCELERATION_TIME = 0.5
"""s: acceleration limit, where none is given, = velocity limit / this time."""


@dataclasses.dataclass(frozen=True)
class RobotModel:
    """A serial manipulator in modified DH form (see module docstring).

    Attributes:
      name: short identifier.
      mdh: (n, 5) joint rows, columns ``alpha, d, theta, r, beta`` (rad, m).
      sigma: (n,) joint types, 0 revolute and 1 prismatic (default all 0).
      tool: (5,) tool row, same columns; r is the flange-to-tool distance.
      limits: joint limits.
      gravity: (3,) gravity in the base frame, m/s^2.
      dynamics: (n, 13) standard parameters per link (see module docstring),
        or None when the robot has no dynamic model.
      payload: optional rigid payload on the tool.
      calibration: free-form record written by calibrate/identify, or None.
      base_frame: X_LB of B in the source URDF's base link, or None (B = L).
      terms: the dynamic model's terms (``model:``), or None (not given: the
        default :class:`DynamicTerms`; see :attr:`dynamic_terms`).
      fcn: (n,) Coulomb level for negative velocity (N m or N), or None (=
        fc: symmetric).
      tau0: (n,) constant joint-effort offsets (N m or N), or None (0).
      drive_gain: (n,) torque per motor current, N m/A (N/A on a prismatic
        joint), gear ratio included (positive), or None when unknown.
      compliance: elastic joints (:class:`Compliance`), or None (rigid).
      mass_bounds: bounds of identified masses (:class:`MassBounds`), or None.
    """

    name: str
    mdh: np.ndarray
    tool: np.ndarray
    limits: JointLimits
    gravity: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([0.0, 0.0, -9.81])
    )
    dynamics: np.ndarray | None = None
    payload: Payload | None = None
    calibration: dict[str, Any] | None = None
    sigma: np.ndarray | None = None
    base_frame: BaseFrame | None = None
    drive_gain: np.ndarray | None = None
    terms: DynamicTerms | None = None
    fcn: np.ndarray | None = None
    tau0: np.ndarray | None = None
    compliance: Compliance | None = None
    mass_bounds: MassBounds | None = None

    def __post_init__(self) -> None:
        mdh = as_finite_array(self.mdh, "mdh", (None, 5))
        n = mdh.shape[0]
        if n < 1:
            raise ValueError("mdh: expected at least one joint row, found none")
        object.__setattr__(self, "mdh", _frozen(mdh))
        sigma = np.zeros(n) if self.sigma is None else self.sigma
        sigma = as_finite_array(sigma, "sigma", (n,))
        if np.any((sigma != 0) & (sigma != 1)):
            j = int(np.flatnonzero((sigma != 0) & (sigma != 1))[0])
            raise ValueError(
                f"sigma: joint {j + 1} has {sigma[j]:g}: expected 0 (revolute) or 1 "
                "(prismatic)"
            )
        sigma = np.array(sigma, dtype=np.int64)
        sigma.flags.writeable = False
        object.__setattr__(self, "sigma", sigma)
        object.__setattr__(
            self, "tool", _frozen(as_finite_array(self.tool, "tool", (5,)))
        )
        object.__setattr__(
            self, "gravity", _frozen(as_finite_array(self.gravity, "gravity", (3,)))
        )
        for key in _LIMIT_KEYS:
            as_finite_array(getattr(self.limits, key), f"limits.{key}", (n,))
        bad = np.flatnonzero(self.limits.lower > self.limits.upper)
        if bad.size:
            j = int(bad[0])
            raise ValueError(
                f"limits: joint {j + 1} has lower {self.limits.lower[j]} > upper "
                f"{self.limits.upper[j]}"
            )
        for key in ("velocity", "acceleration", "effort"):
            vals = getattr(self.limits, key)
            if np.any(vals <= 0):
                j = int(np.flatnonzero(vals <= 0)[0])
                raise ValueError(
                    f"limits.{key}: expected positive values, found {vals[j]} for "
                    f"joint {j + 1}"
                )
        if self.dynamics is not None:
            dyn = as_finite_array(self.dynamics, "dynamics", (n, len(DYNAMIC_KEYS)))
            object.__setattr__(self, "dynamics", _frozen(dyn))
        if self.drive_gain is not None:
            gain = as_finite_array(self.drive_gain, "drive.gain", (n,))
            if np.any(gain <= 0):
                j = int(np.flatnonzero(gain <= 0)[0])
                raise ValueError(
                    f"drive.gain: expected positive values (N m/A or N/A), found "
                    f"{gain[j]:g} for joint {j + 1}"
                )
            object.__setattr__(self, "drive_gain", _frozen(gain))
        for key in EXTRA_DYNAMIC_KEYS:
            if getattr(self, key) is not None:
                if self.dynamics is None:
                    raise ValueError(f"dynamics: {key} given without dynamics")
                v = as_finite_array(getattr(self, key), f"dynamics.{key}", (n,))
                object.__setattr__(self, key, _frozen(v))
        if self.compliance is not None:
            if not isinstance(self.compliance, Compliance):
                raise ValueError("compliance: expected a Compliance")
            as_finite_array(self.compliance.stiffness, "compliance.stiffness", (n,))
        if self.terms is not None and not isinstance(self.terms, DynamicTerms):
            raise ValueError("model: expected a DynamicTerms")

    @property
    def dynamic_terms(self) -> DynamicTerms:
        """The model's terms: ``terms``, or the default when not given."""
        return DynamicTerms() if self.terms is None else self.terms

    # ---- shape and tables -------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.mdh.shape[0])

    @property
    def table(self) -> np.ndarray:
        """(n+1, 5) MDH table: the joint rows followed by the tool row."""
        return np.vstack([self.mdh, self.tool[None, :]])

    def with_table(self, table: np.ndarray) -> RobotModel:
        """Returns a copy whose MDH rows and tool row are taken from ``table``."""
        table = as_finite_array(table, "table", (self.n_joints + 1, 5))
        return dataclasses.replace(self, mdh=table[:-1], tool=table[-1])

    def with_dynamics(self, dynamics: np.ndarray | None) -> RobotModel:
        """Returns a copy with the (n, 13) standard parameters replaced."""
        return dataclasses.replace(self, dynamics=dynamics)

    # ---- YAML ---------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The robot-YAML mapping of this model (plain Python types)."""

        def row(values: np.ndarray, keys: Sequence[str]) -> dict[str, float]:
            return {k: float(v) for k, v in zip(keys, values, strict=True)}

        out: dict[str, Any] = {"name": self.name}
        out["mdh"] = [row(r, MDH_KEYS) for r in self.mdh]
        for r, s in zip(out["mdh"], self.sigma, strict=True):
            if s:  # revolute rows stay as they were (sigma: 0 is the default)
                r["sigma"] = 1
        out["tool"] = row(self.tool, MDH_KEYS)
        out["limits"] = {
            k: [float(v) for v in getattr(self.limits, k)] for k in _LIMIT_KEYS
        }
        if self.dynamics is not None:
            out["dynamics"] = [row(r, DYNAMIC_KEYS) for r in self.dynamics]
            for key in EXTRA_DYNAMIC_KEYS:
                if getattr(self, key) is not None:
                    for r, v in zip(out["dynamics"], getattr(self, key), strict=True):
                        r[key] = float(v)
        if self.terms is not None:
            out["model"] = self.terms.to_dict()
        if self.payload is not None:
            out["payload"] = {
                "mass": self.payload.mass,
                "com": [float(v) for v in self.payload.p_EPcm],
                "inertia": [float(v) for v in self.payload.inertia],
            }
        out["gravity"] = [float(v) for v in self.gravity]
        if self.base_frame is not None:
            bf = self.base_frame
            out["base_frame"] = {
                "link": bf.link,
                "xyz": [float(v) for v in bf.xyz],
                "rpy": [float(v) for v in bf.rpy],
            }
        if self.compliance is not None:
            out["compliance"] = self.compliance.to_dict()
        if self.mass_bounds is not None:
            out["mass_bounds"] = self.mass_bounds.to_dict()
        if self.drive_gain is not None:
            out["drive"] = {"gain": [float(v) for v in self.drive_gain]}
        if self.calibration is not None:
            out["calibration"] = _plain(self.calibration)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "robot") -> RobotModel:
        """Builds and validates a model from a robot-YAML mapping.

        Raises:
          ValueError: one line naming ``source`` and the offending field.
        """
        try:
            return cls._from_dict(data)
        except ValueError as e:
            raise ValueError(f"{source}: {e}") from None

    @classmethod
    def _from_dict(cls, data: Mapping[str, Any]) -> RobotModel:
        if not isinstance(data, Mapping):
            raise ValueError(
                f"expected a mapping at top level, found {type(data).__name__}"
            )
        for key in ("name", "mdh", "tool", "limits"):
            if key not in data:
                raise ValueError(f"missing key '{key}'")
        rows = data["mdh"]
        if not isinstance(rows, list) or not rows:
            raise ValueError("mdh: expected a non-empty list of joint rows")
        mdh = np.array([_row(r, f"mdh[{i}]", MDH_KEYS) for i, r in enumerate(rows)])
        sigma = np.array([_sigma(r, f"mdh[{i}]") for i, r in enumerate(rows)])
        tool = _row(data["tool"], "tool", MDH_KEYS)
        lim = data["limits"]
        if not isinstance(lim, Mapping):
            raise ValueError("limits: expected a mapping")
        n = len(rows)
        limits = {}
        for key in _LIMIT_KEYS:
            if key == "acceleration" and key not in lim and "velocity" in limits:
                limits[key] = limits["velocity"] / DEFAULT_ACCELERATION_TIME
                continue
            if key not in lim:
                raise ValueError(f"limits: missing key '{key}'")
            limits[key] = yaml_vector(lim[key], f"limits.{key}", n)
        # A file in mm or degrees is refused here, at load; a model computed in
        # SI (a calibration result) is judged by the calibration's own checks.
        check_units(mdh, tool, JointLimits(**limits), sigma)
        dynamics = fcn = tau0 = None
        if data.get("dynamics") is not None:
            dynamics, fcn, tau0 = _dynamics(data["dynamics"], n, DYNAMIC_KEYS)
        terms = data.get("model")
        terms = None if terms is None else DynamicTerms.from_dict(terms)
        payload = None
        if data.get("payload") is not None:
            p = data["payload"]
            if not isinstance(p, Mapping) or "mass" not in p:
                raise ValueError("payload: expected a mapping with 'mass'")
            payload = Payload(
                mass=yaml_number(p["mass"], "payload.mass"),
                p_EPcm=yaml_vector(p.get("com", [0.0, 0.0, 0.0]), "payload.com", 3),
                inertia=yaml_vector(p.get("inertia", [0.0] * 6), "payload.inertia", 6),
            )
            if payload.mass < 0:
                raise ValueError(f"payload.mass: expected >= 0, found {payload.mass}")
        gravity = yaml_vector(data.get("gravity", [0.0, 0.0, -9.81]), "gravity", 3)
        base_frame = _base_frame(data.get("base_frame"))
        calibration = data.get("calibration")
        if calibration is not None and not isinstance(calibration, Mapping):
            raise ValueError("calibration: expected a mapping")
        return cls(
            name=str(data["name"]),
            mdh=mdh,
            tool=tool,
            limits=JointLimits(**limits),
            gravity=gravity,
            dynamics=dynamics,
            payload=payload,
            calibration=dict(calibration) if calibration is not None else None,
            sigma=sigma,
            base_frame=base_frame,
            drive_gain=_drive_gain(data.get("drive"), n),
            terms=terms,
            fcn=fcn,
            tau0=tau0,
            compliance=_compliance(data.get("compliance"), n),
            mass_bounds=_mass_bounds(data.get("mass_bounds"), n),
        )

    def to_yaml(self) -> str:
        """The model as YAML text (floats written with full precision)."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None)

    def save(self, path: str | os.PathLike) -> Path:
        """Writes the model to ``path`` atomically; returns the path."""
        return atomic_write_text(path, self.to_yaml())


def shipped_robots() -> list[str]:
    """Names of the robots shipped in ``rmdrake/models``."""
    files = resources.files(_MODELS).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".yaml"))


def load_robot(
    robot: str | os.PathLike, *, base: str | None = None, tip: str | None = None
) -> RobotModel:
    """Loads a shipped robot by name (``rv3sb``, ``demo_rh``), a robot YAML by
    path, or the serial chain from link ``base`` to link ``tip`` of a URDF (a
    path ending in ``.urdf``; see :func:`rmdrake.urdf.robot_from_urdf`).

    Raises:
      ValueError: unknown name, unreadable file or invalid content (one line);
        ``base``/``tip`` given for a robot that is not a URDF.
    """
    text_name = str(robot)
    if text_name.lower().endswith(".urdf"):
        from rmdrake.urdf import robot_from_urdf

        return robot_from_urdf(robot, base=base, tip=tip)
    if base is not None or tip is not None:
        raise ValueError(
            f"{text_name}: --base and --tip pick the chain of a URDF; this robot is "
            "a robot YAML or a shipped model"
        )
    is_name = isinstance(robot, str) and re.fullmatch(r"[A-Za-z0-9_\-]+", text_name)
    if is_name and not Path(text_name).exists():
        res = resources.files(_MODELS).joinpath(f"{text_name}.yaml")
        if not res.is_file():
            raise ValueError(
                f"unknown robot '{text_name}': expected a shipped model "
                f"({', '.join(shipped_robots())}) or a path to a robot YAML"
            )
        name = f"{text_name}.yaml"
        return RobotModel.from_dict(load_yaml(res.read_text(), name), name)
    path = Path(robot)
    data = read_yaml(path, "robot YAML")
    return RobotModel.from_dict(data, str(path))
