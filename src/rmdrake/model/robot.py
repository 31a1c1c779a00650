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

Error parameters (``dalpha<j>`` .. ``dbeta<j>``): :mod:`rmdrake.model.error_parameters`.

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

``limits.effort`` may be left out too: the robot's joint effort limits are then
unknown (``JointLimits.effort`` None, :attr:`RobotModel.has_effort_limits`
False), as in a URDF made for kinematics (``effort="0"``). Given, every value
must be positive: a 0 is refused, not read as unknown (leave the key out).
A model without ``dynamics`` or without effort limits is *kinematic-only*
(:attr:`RobotModel.kinematic_only`): the kinematic commands (show, calibrate,
correct, export-urdf, excite) take it, and what needs the missing part refuses
it with one line (:func:`require_dynamics`).

The optional top-level ``base_frame: {link, xyz, rpy}`` is the pose X_LB of the
MDH base frame B in a link L of the robot's source (a URDF whose first joint axis
one MDH row cannot reach from L, see :mod:`rmdrake.model.urdf.importer`): p_L = X_LB
p_B (m; rad,
Drake RollPitchYaw). Everything else in the file (gravity, targets) is in B.

The optional top-level ``drive: {gain: [...]}`` gives per joint the drive gain
k_j with tau_j = k_j * i_j (N m per A, or N per A on a prismatic joint; gear
ratio included): :attr:`RobotModel.drive_gain`.

The optional top-level ``transmission: {ratio, coupling, torque_constant}``
gives the motor-to-joint map q_m = diag(ratio) C q of an arm whose drives log
the motor side (:mod:`rmdrake.model.transmission`): :attr:`RobotModel.transmission`.
A coupled motor m (a row of C with an off-diagonal entry, e.g. a coupled
wrist's motor 6) has three dynamic parameters of its own, in joint-reflected
units, written in link m's ``dynamics`` mapping as ``Iam`` (kg m^2), ``fvm``
(N m s/rad) and ``fcm`` (N m) (absent: 0): :attr:`RobotModel.motor_terms`.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rmdrake.arrays import as_finite_array
from rmdrake.io.atomic import atomic_write_text
from rmdrake.io.yaml import yaml_number, yaml_vector
from rmdrake.model.transmission import Transmission, transmission_from_dict
from rmdrake.model.units import MAX_ANGLE, MAX_LENGTH, check_units

__all__ = [
    "DEFAULT_ACCELERATION_TIME",
    "BaseFrame",
    "Compliance",
    "DYNAMIC_KEYS",
    "DynamicTerms",
    "EXTRA_DYNAMIC_KEYS",
    "MDH_KEYS",
    "MOTOR_KEYS",
    "JointLimits",
    "MassBounds",
    "Payload",
    "ROBOT_KEYS",
    "RobotModel",
    "check_link_inertia",
    "require_dynamics",
]

MAX_JOINTS = 64
"""The most joints a robot model may have: a serial arm with more is a file
error (a robot of 1000 joints hung simulate-plates), not a manipulator."""
MDH_KEYS: tuple[str, ...] = ("alpha", "d", "theta", "r", "beta")
"""The columns of an MDH row, in order (rad, m, rad, m, rad)."""
_LIMIT_KEYS = ("lower", "upper", "velocity", "acceleration", "effort")


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """Per-joint limits: position (rad), velocity (rad/s), acceleration (rad/s^2)
    and effort (N m), each an array of length n (m, m/s, m/s^2 and N on a
    prismatic joint); ``effort`` None when the robot's effort limits are
    unknown (a kinematic-only model).

    Example:

    >>> import numpy as np
    >>> from rmdrake import JointLimits
    >>> limits = JointLimits(
    ...     lower=[-1.0, -2.0],
    ...     upper=[1.0, 2.0],
    ...     velocity=[3.0, 3.0],
    ...     acceleration=[10.0, 10.0],
    ... )
    >>> limits.upper, limits.effort is None
    (array([1., 2.]), True)
    """

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray | None = None

    def __post_init__(self) -> None:
        for key in _LIMIT_KEYS:
            if getattr(self, key) is not None or key != "effort":
                object.__setattr__(self, key, _frozen(getattr(self, key)))


@dataclasses.dataclass(frozen=True)
class Payload:
    """A rigid payload held by the tool (the robot YAML's optional ``payload``
    entry: ``{mass, com, inertia}`` at the tool frame).

    Attributes:
      mass: kg.
      p_EPcm: centre of mass in the tool frame E, m.
      inertia: rotational inertia about the centre of mass in E axes,
        ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (tensor entries), kg m^2.

    Example:

    >>> from rmdrake import Payload
    >>> inertia = [0.01, 0.01, 0.02, 0.0, 0.0, 0.0]  # Ixx Iyy Izz Ixy Ixz Iyz, kg m^2
    >>> tool = Payload(mass=2.0, p_EPcm=[0.0, 0.0, 0.1], inertia=inertia)
    >>> tool.with_mass(1.0).inertia.tolist()
    [0.005, 0.005, 0.01, 0.0, 0.0, 0.0]
    """

    mass: float
    p_EPcm: np.ndarray
    inertia: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "p_EPcm", _frozen(self.p_EPcm))
        object.__setattr__(self, "inertia", _frozen(self.inertia))

    def with_mass(self, mass: float) -> Payload:
        """The same payload with ``mass`` kg (inertia scaled with the mass, zero
        from a massless one): a lighter or heavier module of the same shape."""
        scale = mass / self.mass if self.mass > 0 else 0.0
        return Payload(float(mass), self.p_EPcm, np.asarray(self.inertia) * scale)


DEFAULT_DAMPING_TIME = 0.01
"""s: structural damping of an elastic joint, where none is given, is this
time times its stiffness (stiffness-proportional Rayleigh damping: a mode at
omega rad/s gets a damping ratio of omega * 0.01 / 2, 8 % at 16 rad/s)."""


@dataclasses.dataclass(frozen=True)
class Compliance:
    """Elastic joints (the robot YAML's optional ``compliance`` entry:
    ``{stiffness: [...], damping: [...]}``, damping optional).

    An elastic joint j has a motor side (the encoder's q_m) and a link side q_l
    joined by a spring: at rest k_j (q_m - q_l) balances the generalized force
    the link side receives from outside the joint (gravity, a payload), so
    q_l = q_m + tau_j / k_j with tau_j that force (Drake's sign:
    ``CalcGravityGeneralizedForces``).

    Attributes:
      stiffness: (n,) k_j in N m/rad (N/m on a prismatic joint); 0 = rigid.
      damping: (n,) structural damping of the spring in N m s/rad (N s/m); 0
        on rigid joints. Default ``DEFAULT_DAMPING_TIME`` x stiffness.

    Example:

    >>> from rmdrake import Compliance
    >>> joints = Compliance(stiffness=[0.0, 2e5, 1e5])
    >>> joints.elastic.tolist(), joints.damping.tolist()
    ([False, True, True], [0.0, 2000.0, 1000.0])
    """

    stiffness: np.ndarray
    damping: np.ndarray | None = None

    def __post_init__(self) -> None:
        k = as_finite_array(self.stiffness, "compliance.stiffness", (None,))
        if np.any(k < 0):
            j = int(np.flatnonzero(k < 0)[0])
            raise ValueError(
                f"compliance.stiffness: expected > 0 (N m/rad or N/m; 0 = rigid), "
                f"found {k[j]:g} for joint {j + 1}"
            )
        c = DEFAULT_DAMPING_TIME * k if self.damping is None else self.damping
        c = as_finite_array(c, "compliance.damping", k.shape)
        if np.any(c < 0):
            j = int(np.flatnonzero(c < 0)[0])
            raise ValueError(
                f"compliance.damping: expected >= 0 (N m s/rad or N s/m), found "
                f"{c[j]:g} for joint {j + 1}"
            )
        object.__setattr__(self, "stiffness", _frozen(k))
        object.__setattr__(self, "damping", _frozen(np.where(k > 0, c, 0.0)))

    @property
    def elastic(self) -> np.ndarray:
        """Which joints are elastic (stiffness > 0), an (n,) bool array."""
        return self.stiffness > 0

    @property
    def compliances(self) -> np.ndarray:
        """(n,) c_j = 1 / k_j in rad/(N m) (m/N), 0 on rigid joints."""
        k = self.stiffness
        return np.divide(1.0, k, out=np.zeros_like(k), where=k > 0)

    def to_dict(self) -> dict[str, list[float]]:
        """The YAML mapping (plain floats)."""
        return {
            "stiffness": [float(v) for v in self.stiffness],
            "damping": [float(v) for v in self.damping],
        }


def _compliance(value: Any, n: int) -> Compliance | None:
    """The optional ``compliance: {stiffness, damping}`` entry; None when absent
    or when every stiffness is 0 (a rigid robot)."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or not set(value) <= {"stiffness", "damping"}:
        raise ValueError(
            "compliance: expected a mapping with stiffness (N m/rad per joint) and "
            "optionally damping"
        )
    if "stiffness" not in value:
        raise ValueError("compliance: missing key 'stiffness'")
    k = yaml_vector(value["stiffness"], "compliance.stiffness", n)
    c = value.get("damping")
    c = None if c is None else yaml_vector(c, "compliance.damping", n)
    out = Compliance(k, c)
    return out if np.any(out.elastic) else None


@dataclasses.dataclass(frozen=True)
class MassBounds:
    """Bounds of the physically consistent fit's masses (the robot YAML's
    optional ``mass_bounds: {links: [LO, HI] or [[LO, HI], ...], total: [LO,
    HI]}``, kg; HI may be ``.inf``), used by ``identify`` where its
    ``--mass-bounds`` and ``--total-mass`` are not given.

    Attributes:
      links: (n, 2) per-link [lo, hi], or None.
      total: (2,) [lo, hi] of the sum of the link masses, or None.

    Example:

    >>> from rmdrake import MassBounds
    >>> MassBounds(total=[20.0, 40.0]).to_dict()
    {'total': [20.0, 40.0]}
    """

    links: np.ndarray | None = None
    total: np.ndarray | None = None

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping (plain floats)."""
        out: dict[str, Any] = {}
        if self.links is not None:
            out["links"] = [[float(a), float(b)] for a, b in self.links]
        if self.total is not None:
            out["total"] = [float(v) for v in self.total]
        return out


def _bounds_pair(value: Any, what: str) -> np.ndarray:
    """[lo, hi] in kg with 0 <= lo <= hi (hi may be inf)."""
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise ValueError(f"{what}: expected [LO, HI] in kg, found {value!r}")
    pair = np.array([v if v == np.inf else yaml_number(v, what) for v in value])
    if not (0 <= pair[0] <= pair[1]) or np.isinf(pair[0]):
        raise ValueError(f"{what}: expected 0 <= LO <= HI kg, found {value!r}")
    return pair


def _mass_bounds(value: Any, n: int) -> MassBounds | None:
    """The optional ``mass_bounds`` entry (see :class:`MassBounds`)."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or not set(value) <= {"links", "total"}:
        raise ValueError("mass_bounds: expected a mapping with links and/or total")
    links = value.get("links")
    if links is not None:
        nested = isinstance(links, list) and links and isinstance(links[0], list)
        rows = links if nested else [links] * n
        if len(rows) != n:
            raise ValueError(
                f"mass_bounds.links: expected one [LO, HI] or {n}, found {len(rows)}"
            )
        links = np.array(
            [_bounds_pair(r, f"mass_bounds.links[{i}]") for i, r in enumerate(rows)]
        )
    total = value.get("total")
    total = None if total is None else _bounds_pair(total, "mass_bounds.total")
    return MassBounds(links, total)


@dataclasses.dataclass(frozen=True)
class BaseFrame:
    """The pose X_LB of the MDH base frame B in the source's link named ``link``
    (L): p_L = X_LB p_B; ``xyz`` = p_LB (m), ``rpy`` = R_LB as Drake
    RollPitchYaw (rad). The robot YAML's optional ``base_frame``.

    Example:

    >>> from rmdrake import BaseFrame
    >>> frame = BaseFrame(link="base_link", xyz=[0.0, 0.0, 0.3], rpy=[0.0, 0.0, 0.0])
    >>> frame.link, frame.xyz.tolist()
    ('base_link', [0.0, 0.0, 0.3])
    """

    link: str
    xyz: np.ndarray
    rpy: np.ndarray

    def __post_init__(self) -> None:
        for key in ("xyz", "rpy"):
            v = as_finite_array(getattr(self, key), f"base_frame.{key}", (3,))
            object.__setattr__(self, key, _frozen(v))


@dataclasses.dataclass(frozen=True)
class DynamicTerms:
    """Which joint-effort terms a robot's dynamic model has, besides the rigid
    bodies (the robot YAML's optional ``model:`` entry; by default rotor inertia,
    viscous and Coulomb friction).

    Attributes:
      rotor_inertia: Ia_j * qdd_j (off for a joint-torque sensor on the link
        side, which does not see the rotor).
      viscous: fv_j * qd_j.
      coulomb: Coulomb friction fc_j * s(qd_j).
      offset: a constant effort tau0_j per joint (N m, or N on a prismatic
        joint): a sensor's or a current loop's bias.
      coulomb_asymmetric: Coulomb friction fc_j for qd_j > 0 and -fcn_j for
        qd_j < 0 (needs ``coulomb``).

    The text form (``rmdrake identify --terms``) is a comma-separated list of
    changes to a starting set: ``NAME`` or ``NAME=1`` turns a term on,
    ``no-NAME`` or ``NAME=0`` turns it off, with NAME one of the attribute names
    or a short alias (``rotor``, ``ia``; ``fv``; ``fc``; ``tau0``;
    ``asymmetric``, ``fcn``), e.g. ``no-rotor,offset``.

    Example:

    >>> from rmdrake import DynamicTerms
    >>> terms = DynamicTerms().with_text("no-rotor,offset")
    >>> terms.rotor_inertia, terms.offset, terms.is_default
    (False, True, False)
    """

    rotor_inertia: bool = True
    viscous: bool = True
    coulomb: bool = True
    offset: bool = False
    coulomb_asymmetric: bool = False

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if not isinstance(getattr(self, f.name), bool):
                raise ValueError(
                    f"model.{f.name}: expected true or false, found "
                    f"{getattr(self, f.name)!r}"
                )
        if self.coulomb_asymmetric and not self.coulomb:
            raise ValueError(
                "model: coulomb_asymmetric needs coulomb: true (fc for qd > 0, "
                "fcn for qd < 0)"
            )

    @property
    def is_default(self) -> bool:
        """True for the default terms (Ia, fv, fc; no offset; symmetric)."""
        return self == DynamicTerms()

    def to_dict(self) -> dict[str, bool]:
        """The ``model:`` mapping."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, value: Any) -> DynamicTerms:
        """From the ``model:`` mapping (missing keys keep the defaults)."""
        if not isinstance(value, Mapping):
            raise ValueError("model: expected a mapping of term: true/false")
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(value) - names
        if unknown:
            raise ValueError(
                f"model: unknown key(s) {', '.join(sorted(map(str, unknown)))}: "
                f"expected {', '.join(sorted(names))}"
            )
        return cls(**dict(value))

    def with_text(self, text: str) -> DynamicTerms:
        """These terms changed by the text form of the class docstring.

        Raises:
          ValueError: an unknown term, a bad value, or one term given twice
            with opposite values (``no-rotor,rotor``).
        """
        out = self.to_dict()
        said: dict[str, tuple[bool, str]] = {}
        for item in (t.strip() for t in text.split(",")):
            if not item:
                continue
            name, value = item, True
            if "=" in item:
                name, _, v = item.partition("=")
                if v.strip().lower() not in ("0", "1", "true", "false", "on", "off"):
                    raise ValueError(f"terms: {item!r}: expected NAME=0 or NAME=1")
                value = v.strip().lower() in ("1", "true", "on")
            elif item.startswith("no-"):
                name, value = item[3:], False
            key = _TERM_ALIASES.get(name.strip().lower().replace("-", "_"))
            if key is None:
                raise ValueError(
                    f"terms: unknown term {name!r}: expected one of "
                    f"{', '.join(out)} (or rotor, viscous, coulomb, offset, "
                    "asymmetric), optionally as no-NAME or NAME=0/1"
                )
            if key in said and said[key][0] != value:
                raise ValueError(
                    f"terms: {said[key][1]!r} and {item!r} contradict each other: "
                    "give each term once"
                )
            said[key] = (value, item)
            out[key] = value
            if key == "coulomb_asymmetric" and value:
                out["coulomb"] = True
            if key == "coulomb" and not value:
                out["coulomb_asymmetric"] = False
        return DynamicTerms(**out)

    def __str__(self) -> str:
        on = [f.name for f in dataclasses.fields(self) if getattr(self, f.name)]
        return ", ".join(on) if on else "rigid bodies only"


_TERM_ALIASES = {
    **{f.name: f.name for f in dataclasses.fields(DynamicTerms)},
    "rotor": "rotor_inertia",
    "ia": "rotor_inertia",
    "fv": "viscous",
    "fc": "coulomb",
    "tau0": "offset",
    "offsets": "offset",
    "asymmetric": "coulomb_asymmetric",
    "fcn": "coulomb_asymmetric",
}


def _plain(obj: Any) -> Any:
    """Converts numpy scalars/arrays inside nested containers to plain Python."""
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _base_frame(value: Any) -> BaseFrame | None:
    """The optional ``base_frame: {link, xyz, rpy}`` entry (m, rad)."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or set(value) != {"link", "xyz", "rpy"}:
        raise ValueError("base_frame: expected a mapping with link, xyz, rpy only")
    if not isinstance(value["link"], str) or not value["link"]:
        raise ValueError("base_frame.link: expected a link name")
    xyz = yaml_vector(value["xyz"], "base_frame.xyz", 3)
    rpy = yaml_vector(value["rpy"], "base_frame.rpy", 3)
    if np.any(np.abs(xyz) > MAX_LENGTH) or np.any(np.abs(rpy) > MAX_ANGLE):
        raise ValueError(
            "base_frame: xyz beyond 100 m or rpy beyond 4 pi: expected m and rad"
        )
    return BaseFrame(value["link"], xyz, rpy)


EXTRA_DYNAMIC_KEYS = ("fcn", "tau0")
"""Optional per-link ``dynamics`` keys beyond the 13: the Coulomb level for
negative velocity (N m or N, >= 0) and the constant joint-effort offset (N m or
N)."""
MOTOR_KEYS = ("Iam", "fvm", "fcm")
"""The ``dynamics`` keys of a coupled motor m, in link m's mapping: its rotor
inertia, viscous and Coulomb friction in joint-reflected units (kg m^2,
N m s/rad, N m; :mod:`rmdrake.model.transmission`)."""


def _dynamics(
    value: Any, n: int, keys: Sequence[str], coupled: Sequence[int] = ()
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """The ``dynamics`` list: (n, 13) standard parameters, then (n,) fcn and
    (n,) tau0 where any link gives them (else None; a link without fcn has
    fcn = its fc, one without tau0 has 0), then the (k, 3) ``Iam, fvm, fcm``
    of the ``coupled`` motors (0-based; None when there are none; a missing
    key is 0). ``Iam``.. on a link whose motor is not coupled are refused."""
    if not isinstance(value, list) or len(value) != n:
        found = len(value) if isinstance(value, list) else type(value).__name__
        raise ValueError(f"dynamics: expected {n} link mappings, found {found}")
    rows, extra = [], {k: [] for k in EXTRA_DYNAMIC_KEYS}
    motors = np.zeros((len(coupled), len(MOTOR_KEYS)))
    for i, r in enumerate(value):
        what = f"dynamics[{i}]"
        if isinstance(r, Mapping):
            for k in EXTRA_DYNAMIC_KEYS:
                extra[k].append(yaml_number(r[k], f"{what}.{k}") if k in r else None)
            for c, k in enumerate(MOTOR_KEYS):
                if k not in r:
                    continue
                if i not in coupled:
                    raise ValueError(
                        f"{what}.{k}: motor {i + 1} is not coupled (its row of "
                        "transmission.coupling has no off-diagonal entry): its "
                        "rotor and friction are the link's Ia, fv, fc"
                    )
                motors[list(coupled).index(i), c] = yaml_number(r[k], f"{what}.{k}")
            r = {
                k: v
                for k, v in r.items()
                if k not in EXTRA_DYNAMIC_KEYS and k not in MOTOR_KEYS
            }
        rows.append(_row(r, what, keys))
    dyn = np.array(rows)
    fc = dyn[:, keys.index("fc")]
    out = []
    for k, default in zip(EXTRA_DYNAMIC_KEYS, (fc, np.zeros(n)), strict=True):
        vals = extra[k]
        if all(v is None for v in vals):
            out.append(None)
        else:
            out.append(
                np.array(
                    [d if v is None else v for v, d in zip(vals, default, strict=True)]
                )
            )
    return dyn, out[0], out[1], motors if len(coupled) else None


def _drive_gain(value: Any, n: int) -> np.ndarray | None:
    """The optional ``drive: {gain: [...]}`` entry: n positive gains, N m/A (N/A
    on a prismatic joint); checked for sign by RobotModel."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or set(value) != {"gain"}:
        raise ValueError("drive: expected a mapping with gain only")
    return yaml_vector(value["gain"], "drive.gain", n)


def _sigma(value: Any, what: str) -> int:
    """The joint type of an MDH row mapping: ``sigma`` 0 (revolute, the default)
    or 1 (prismatic)."""
    s = value.get("sigma", 0) if isinstance(value, Mapping) else 0
    if isinstance(s, bool) or s not in (0, 1):
        raise ValueError(
            f"{what}.sigma: expected 0 (revolute) or 1 (prismatic), found {s!r}"
        )
    return int(s)


def _row(value: Any, what: str, keys: Sequence[str]) -> np.ndarray:
    if not isinstance(value, Mapping):
        raise ValueError(f"{what}: expected a mapping with keys {', '.join(keys)}")
    allowed = set(keys) | ({"sigma"} if what.startswith("mdh[") else set())
    unknown = set(value) - allowed
    if unknown:
        hint = (
            " (a joint's type is sigma: 0 revolute, 1 prismatic)"
            if (allowed != set(keys) and unknown & {"type", "joint", "kind"})
            else ""
        )
        raise ValueError(
            f"{what}: unknown key(s) {', '.join(sorted(map(str, unknown)))}{hint}"
        )
    out = []
    for k in keys:
        if k not in value:
            if k == "beta":  # optional: Hayati's angle is zero unless given
                out.append(0.0)
                continue
            raise ValueError(f"{what}: missing key '{k}'")
        out.append(yaml_number(value[k], f"{what}.{k}"))
    return np.array(out)


DYNAMIC_KEYS: tuple[str, ...] = (
    "XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "Ia", "fv", "fc",
)  # fmt: skip
DEFAULT_ACCELERATION_TIME = 0.5
ROBOT_KEYS: tuple[str, ...] = (
    "name", "mdh", "tool", "limits", "dynamics", "model", "payload", "gravity",
    "base_frame", "compliance", "mass_bounds", "drive", "transmission",
    "calibration",
)  # fmt: skip
"""The top-level keys of a robot YAML; any other is refused at load."""


def check_link_inertia(dynamics: np.ndarray, rtol: float = 1e-9) -> None:
    """Refuses link dynamics no body has: a mass < 0 kg, or a rotational
    inertia (XX, XY, XZ, YY, YZ, ZZ about the link frame, kg m^2) with an
    eigenvalue below -``rtol`` x its largest |eigenvalue| (not positive
    semi-definite; point masses and massless links, exactly 0, pass).

    Args:
      dynamics: (n, 13) standard parameters in :data:`DYNAMIC_KEYS` order.

    Raises:
      ValueError: ``dynamics[i] (link i + 1): ...`` naming the entry (0-based,
        as in the file's list), the link and the figure.
    """
    for i, p in enumerate(np.asarray(dynamics, float)):
        if p[9] < 0:
            raise ValueError(
                f"dynamics[{i}] (link {i + 1}): mass M = {p[9]:g} kg is negative: "
                "expected >= 0"
            )
        xx, xy, xz, yy, yz, zz = p[:6]
        ev = np.linalg.eigvalsh([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        if ev[0] < -rtol * max(np.abs(ev).max(), np.finfo(float).tiny):
            raise ValueError(
                f"dynamics[{i}] (link {i + 1}): inertia XX..ZZ is not positive "
                "semi-definite "
                f"(smallest eigenvalue {ev[0]:.4g} kg m^2): no body has it; check "
                "the signs and units (kg m^2)"
            )


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
      transmission: the motor-to-joint transmission
        (:class:`~rmdrake.model.transmission.Transmission`), or None (the
        joints are driven directly: logs are joint side).
      motor_terms: (k, 3) ``Iam, fvm, fcm`` of the k coupled motors
        (``transmission.coupled``, in that order), joint-reflected (kg m^2,
        N m s/rad, N m); None when there are none (or read as 0).

    Example:

    >>> from rmdrake import load_robot
    >>> robot = load_robot("rv3sb")
    >>> robot.n_joints, robot.table.shape
    (6, (7, 5))
    >>> robot.mdh[1].round(4).tolist()
    [-1.5708, 0.095, -1.5708, 0.0, 0.0]
    >>> robot.kinematic_only, robot.has_effort_limits
    (False, True)
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
    transmission: Transmission | None = None
    motor_terms: np.ndarray | None = None

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
            if getattr(self.limits, key) is not None or key != "effort":
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
            if vals is not None and np.any(vals <= 0):
                j = int(np.flatnonzero(vals <= 0)[0])
                unknown = (
                    "; leave 'effort' out where the effort limits are unknown (a "
                    "kinematic-only model)"
                    if key == "effort"
                    else ""
                )
                raise ValueError(
                    f"limits.{key}: expected positive values, found {vals[j]} for "
                    f"joint {j + 1}{unknown}"
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
        self._check_transmission(n)

    def _check_transmission(self, n: int) -> None:
        """The transmission's size, and motor_terms (k, 3) for its k coupled
        motors (zeros when the model has dynamics but none are given)."""
        tr = self.transmission
        if tr is not None:
            if not isinstance(tr, Transmission):
                raise ValueError("transmission: expected a Transmission")
            if tr.n != n:
                raise ValueError(
                    f"transmission: {tr.n} motors, expected {n} (one per joint)"
                )
        k = 0 if tr is None else len(tr.coupled)
        mt = self.motor_terms
        if mt is None and k and self.dynamics is not None:
            mt = np.zeros((k, len(MOTOR_KEYS)))
        if mt is not None:
            if k == 0:
                raise ValueError(
                    "dynamics: Iam, fvm, fcm given but the transmission has no "
                    "coupled motor"
                )
            mt = as_finite_array(mt, "dynamics.Iam/fvm/fcm", (k, len(MOTOR_KEYS)))
            object.__setattr__(self, "motor_terms", _frozen(mt))

    @property
    def coupled_motors(self) -> tuple[int, ...]:
        """0-based indices of the coupled motors (none without a transmission)."""
        return () if self.transmission is None else self.transmission.coupled

    @property
    def dynamic_terms(self) -> DynamicTerms:
        """The model's terms: ``terms``, or the default when not given."""
        return DynamicTerms() if self.terms is None else self.terms

    @property
    def has_effort_limits(self) -> bool:
        """Whether the joints' effort limits are known (``limits.effort``)."""
        return self.limits.effort is not None

    @property
    def kinematic_only(self) -> bool:
        """True for a model without ``dynamics`` or without joint effort limits:
        fit for kinematics only (module docstring)."""
        return self.dynamics is None or not self.has_effort_limits

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
            k: [float(v) for v in getattr(self.limits, k)]
            for k in _LIMIT_KEYS
            if getattr(self.limits, k) is not None
        }
        if self.dynamics is not None:
            out["dynamics"] = [row(r, DYNAMIC_KEYS) for r in self.dynamics]
            for key in EXTRA_DYNAMIC_KEYS:
                if getattr(self, key) is not None:
                    for r, v in zip(out["dynamics"], getattr(self, key), strict=True):
                        r[key] = float(v)
            if self.motor_terms is not None:
                motors = zip(self.coupled_motors, self.motor_terms, strict=True)
                for m, values in motors:
                    out["dynamics"][m].update(row(values, MOTOR_KEYS))
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
        if self.transmission is not None:
            out["transmission"] = self.transmission.to_dict()
        if self.calibration is not None:
            out["calibration"] = _plain(self.calibration)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "robot") -> RobotModel:
        """Builds and validates a model from a robot-YAML mapping, once, for
        every command: the top-level keys are those :meth:`to_dict` writes
        (:data:`ROBOT_KEYS`; a misspelt one is named with the closest); a
        file in mm or degrees, or with a gravity beyond 30 m/s^2, is refused
        (:func:`~rmdrake.model.units.check_units`); each joint's limits have
        lower <= upper and velocity, acceleration, effort > 0 (the model's
        own checks; ``effort`` left out or null: unknown, a 0 refused); each
        link's
        mass is >= 0 kg and its inertia (XX..ZZ, kg m^2) positive
        semi-definite (:func:`check_link_inertia`).

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
        unknown = [str(k) for k in data if k not in ROBOT_KEYS]
        if unknown:
            close = difflib.get_close_matches(unknown[0], ROBOT_KEYS, n=1)
            hint = f"did you mean '{close[0]}'?" if close else "expected one of"
            raise ValueError(
                f"unknown key '{unknown[0]}': {hint} (keys: {', '.join(ROBOT_KEYS)})"
            )
        for key in ("name", "mdh", "tool", "limits"):
            if key not in data:
                raise ValueError(f"missing key '{key}'")
        rows = data["mdh"]
        if not isinstance(rows, list) or not rows:
            raise ValueError("mdh: expected a non-empty list of joint rows")
        if len(rows) > MAX_JOINTS:
            raise ValueError(
                f"mdh: {len(rows)} joint rows, over the {MAX_JOINTS} of any serial "
                "arm rmdrake models (its batched kinematics and plants grow with "
                "the joints squared)"
            )
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
            if key == "effort" and lim.get(key) is None:
                continue  # unknown effort limits: a kinematic-only model
            if key not in lim:
                raise ValueError(f"limits: missing key '{key}'")
            limits[key] = yaml_vector(lim[key], f"limits.{key}", n)
        # A file in mm or degrees (or a gravity beyond physics) is refused here,
        # at load (the URDF importer applies the same check); a model computed
        # in SI (a calibration result) is judged by the calibration's own checks.
        gravity = yaml_vector(data.get("gravity", [0.0, 0.0, -9.81]), "gravity", 3)
        check_units(mdh, tool, JointLimits(**limits), sigma, gravity)
        transmission = transmission_from_dict(data.get("transmission"), n)
        coupled = () if transmission is None else transmission.coupled
        dynamics = fcn = tau0 = motor_terms = None
        if data.get("dynamics") is not None:
            dynamics, fcn, tau0, motor_terms = _dynamics(
                data["dynamics"], n, DYNAMIC_KEYS, coupled
            )
            check_link_inertia(dynamics)
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
            transmission=transmission,
            motor_terms=motor_terms,
        )

    def to_yaml(self) -> str:
        """The model as YAML text (floats written with full precision)."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None)

    def save(self, path: str | os.PathLike) -> Path:
        """Writes the model to ``path`` atomically; returns the path."""
        return atomic_write_text(path, self.to_yaml())


def require_dynamics(
    model: RobotModel,
    what: str,
    *,
    dynamics: bool = True,
    effort: bool = True,
    role: str = "robot",
    remedy: str = "",
) -> None:
    """Refuses a kinematic-only ``model`` (:attr:`RobotModel.kinematic_only`)
    where ``what`` (a command, ``rmdrake simulate``, or a system) needs its
    ``dynamics`` (the 13 standard parameters per link) and/or its joint effort
    limits (``limits.effort``), as the flags say.

    Args:
      role: how the model is named in the line (``robot``, ``true robot``).
      remedy: what to do, appended after a semicolon (none when empty).

    Raises:
      ValueError: one line naming the robot, what it lacks and ``what``, e.g.
        ``robot 'panda' has no joint effort limits (a kinematic-only model;
        expected 'limits: effort'): rmdrake simulate needs them``.
    """
    lacks = []
    if dynamics and model.dynamics is None:
        lacks.append(
            ("dynamics", "a 'dynamics' section with 13 standard parameters per link")
        )
    if effort and not model.has_effort_limits:
        lacks.append(("joint effort limits", "'limits: effort'"))
    if lacks:
        missing = " and no ".join(k for k, _ in lacks)
        expected = " and ".join(e for _, e in lacks)
        raise ValueError(
            f"{role} '{model.name}' has no {missing} (a kinematic-only model; "
            f"expected {expected}): {what} needs them{'; ' if remedy else ''}{remedy}"
        )
