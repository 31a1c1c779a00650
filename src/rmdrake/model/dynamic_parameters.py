"""Standard dynamic parameters: the named 13-per-link vector, conversions, checks.

The standard parameter vector chi of an n-link arm is link-major: link j (1-based)
owns entries ``13 (j-1) .. 13 j - 1`` in this order
(``rmdrake.model.robot.DYNAMIC_KEYS``),

    XX XY XZ YY YZ ZZ  MX MY MZ  M  Ia  fv fc

Inertia I_LLo_L about the link frame origin Lo in link axes L (kg m^2; XY = the
tensor entry, i.e. -∫ x y dm), first moments M * p_LoLcm in L (kg m), mass (kg),
rotor inertia reflected to the joint (kg m^2), viscous (N m s/rad) and Coulomb
(N m) friction (on a prismatic joint: Ia in kg, fv in N s/m, fc in N):
tau_f = fv * qd + fc * sign(qd) (:mod:`rmdrake.dynamics.friction`, which also
has the simulator's smooth sign). The link frame of a
:class:`~rmdrake.model.robot.RobotModel` is MDH frame j (= the Drake body frame of
``link<j>`` in :func:`rmdrake.model.plant.MakePlant`).

Further terms (:class:`~rmdrake.model.robot.DynamicTerms`). The extended vector (15n,)
appends to chi the n Coulomb levels for negative velocity ``fcn1 .. fcnn`` and
the n joint-effort offsets ``tau01 .. tau0n`` (N m or N): entry 13 n + j - 1 is
fcn_j, 14 n + j - 1 is tau0_j. With fcn the Coulomb effort is fc_j for
qd_j > 0 and -fcn_j for qd_j < 0; the regressor's fc column is then
max(s, 0) and the fcn column min(s, 0) (:mod:`rmdrake.dynamics.regressor`), so
fcn = fc is the symmetric law. :func:`term_columns` lists the entries a choice
of terms has; :func:`extended_parameters` is a model's (15n,) vector.

Coupled motors. A robot whose transmission has k coupled motors
(:mod:`rmdrake.model.transmission`, e.g. a coupled wrist's motor 6) extends
the vector by 3 k entries after the 15n: for the i-th coupled motor m
(ascending), entry 15 n + 3 i + (0, 1, 2) is ``Iam, fvm, fcm`` (named
``Iam6 fvm6 fcm6`` for motor 6), its rotor inertia, viscous and Coulomb
friction in joint-reflected units acting on its own speed s_m = c_m . qd
(:func:`extended_width`; their regressor columns are in
:mod:`rmdrake.dynamics.regressor`).

The first 10 entries of a link ("inertial parameters") are an affine image of its
mass distribution; :func:`transform_inertial` re-expresses them in another frame
fixed on the same body (a linear map), :func:`pseudo_inertia` gives the 4x4
pseudo-inertia J = ∫ [r; 1][r; 1]^T dm whose positive semidefiniteness (with
M > 0) is the condition for physical realisability (Wensing et al. 2017).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.model.robot import (
    DYNAMIC_KEYS,
    EXTRA_DYNAMIC_KEYS,
    MOTOR_KEYS,
    DynamicTerms,
    Payload,
    RobotModel,
)

if TYPE_CHECKING:  # a type only: the parameters need no Drake
    from pydrake.multibody.tree import SpatialInertia

__all__ = [
    "payload_parameters",
    "INERTIAL_KEYS",
    "N_PER_LINK",
    "PhysicalCheck",
    "StandardParameters",
    "check_physical",
    "extended_names",
    "extended_width",
    "extended_parameters",
    "term_columns",
    "parameter_names",
    "payload_from_inertial",
    "payload_inertial",
    "payload_map",
    "perturb_standard_parameters",
    "pseudo_inertia",
    "random_standard_parameters",
    "require_physical",
    "standard_from_spatial_inertia",
    "standard_parameters",
    "transform_inertial",
]

N_PER_LINK = len(DYNAMIC_KEYS)  # 13
INERTIAL_KEYS: tuple[str, ...] = DYNAMIC_KEYS[:10]


def parameter_names(n: int, per_link: int = N_PER_LINK) -> list[str]:
    """Names of the link-major standard parameters (``XX1`` to ``fc6``).

    Args:
      n: number of links.
      per_link: 10 (inertial only), 11 (+ Ia) or 13 (+ fv, fc): the first
        ``per_link`` keys of the order above for every link.

    Example:

    >>> from rmdrake.dynamics import parameter_names
    >>> parameter_names(2)[8:15]
    ['MZ1', 'M1', 'Ia1', 'fv1', 'fc1', 'XX2', 'XY2']
    >>> len(parameter_names(6, per_link=10))
    60
    """
    if per_link not in (10, 11, 13):
        raise ValueError(f"per_link: expected 10, 11 or 13, found {per_link}")
    return [f"{k}{j}" for j in range(1, n + 1) for k in DYNAMIC_KEYS[:per_link]]


N_EXTENDED = N_PER_LINK + len(EXTRA_DYNAMIC_KEYS)  # 15 entries per link


def extended_width(n: int, motors: int = 0) -> int:
    """Length of the extended vector of n links and ``motors`` coupled motors:
    15 n + 3 motors (e.g. 93 for a six-axis arm with a coupled wrist)."""
    return N_EXTENDED * n + len(MOTOR_KEYS) * motors


def extended_names(n: int, motors: Sequence[int] = ()) -> list[str]:
    """Names of the extended vector: ``XX1 .. fcn``, ``fcn1 .. fcnn``,
    ``tau01 .. tau0n``, then ``Iam<m> fvm<m> fcm<m>`` for each coupled motor
    (``motors``: 0-based indices, e.g. (5,) gives ``Iam6 fvm6 fcm6``)."""
    extra = [f"{k}{j}" for k in EXTRA_DYNAMIC_KEYS for j in range(1, n + 1)]
    extra += [f"{k}{m + 1}" for m in motors for k in MOTOR_KEYS]
    return parameter_names(n) + extra


def term_columns(n: int, terms: DynamicTerms, motors: int = 0) -> np.ndarray:
    """Ascending indices into the extended vector of the parameters a
    model with ``terms`` has: per link the 10 inertial ones, then Ia, fv, fc
    where on; then fcn_j (asymmetric Coulomb) and tau0_j (offset) where on;
    then each of the ``motors`` coupled motors' Iam, fvm, fcm where Ia, fv, fc
    are on (their Coulomb friction is symmetric)."""
    keep = [True] * 10 + [terms.rotor_inertia, terms.viscous, terms.coulomb]
    cols = [13 * j + c for j in range(n) for c in range(13) if keep[c]]
    if terms.coulomb_asymmetric:
        cols += [13 * n + j for j in range(n)]
    if terms.offset:
        cols += [14 * n + j for j in range(n)]
    on = (terms.rotor_inertia, terms.viscous, terms.coulomb)
    cols += [
        N_EXTENDED * n + 3 * i + c for i in range(motors) for c in range(3) if on[c]
    ]
    return np.array(cols, dtype=np.int64)


def extended_parameters(model: RobotModel) -> np.ndarray:
    """The extended vector of ``model`` ((15n,), or (15n + 3k,) with k coupled
    motors): :func:`standard_parameters`, then fcn (``model.fcn``, else fc),
    tau0 (``model.tau0``, else 0) and the coupled motors' ``Iam, fvm, fcm``
    (``model.motor_terms``)."""
    chi = standard_parameters(model)
    n = model.n_joints
    fcn = chi[12::13] if model.fcn is None else model.fcn
    tau0 = np.zeros(n) if model.tau0 is None else model.tau0
    k = len(model.coupled_motors)
    motors = np.zeros(3 * k) if model.motor_terms is None else model.motor_terms
    return np.concatenate([chi, fcn, tau0, np.ravel(motors)])


def _as_links(chi: object, what: str = "parameters") -> np.ndarray:
    """(n, 13) view of a (13n,) vector or an (n, 13) array (finite, float64)."""
    arr = np.asarray(chi, dtype=np.float64) if not isinstance(chi, str) else None
    if arr is None or arr.ndim not in (1, 2) or arr.shape[-1] % N_PER_LINK:
        shape = None if arr is None else arr.shape
        raise ValueError(
            f"{what}: expected shape (13n,) or (n, 13) standard parameters, "
            f"found {shape}"
        )
    arr = as_finite_array(arr, what)
    return arr.reshape(-1, N_PER_LINK)


@dataclasses.dataclass(frozen=True, eq=False)
class StandardParameters:
    """A named standard-parameter vector (see module docstring).

    Attributes:
      values: (n, 13) parameters, one row per link.

    Example:

    >>> from rmdrake.dynamics import StandardParameters, standard_parameters
    >>> from rmdrake import load_robot
    >>> p = StandardParameters.from_vector(standard_parameters(load_robot("rv3sb")))
    >>> p.n, p.names[:3]
    (6, ['XX1', 'XY1', 'XZ1'])
    >>> round(float(p.as_dict()["M1"]), 3)
    10.0
    """

    values: np.ndarray

    def __post_init__(self) -> None:
        v = _as_links(self.values).copy()
        v.flags.writeable = False
        object.__setattr__(self, "values", v)

    @classmethod
    def from_vector(cls, chi: np.ndarray) -> StandardParameters:
        """From the link-major (13n,) vector."""
        return cls(_as_links(chi))

    @property
    def n(self) -> int:
        """Number of links."""
        return int(self.values.shape[0])

    @property
    def vector(self) -> np.ndarray:
        """The link-major (13n,) vector chi (a copy)."""
        return self.values.ravel().copy()

    @property
    def names(self) -> list[str]:
        """``XX1 .. fcn`` in vector order."""
        return parameter_names(self.n)

    def __getitem__(self, name: str) -> float:
        """The value of one named parameter, e.g. ``p["ZZ2"]``."""
        try:
            i = self.names.index(name)
        except ValueError:
            raise KeyError(
                f"unknown parameter '{name}': expected <key><link> with key in "
                f"{' '.join(DYNAMIC_KEYS)} and link in 1..{self.n}"
            ) from None
        return float(self.values.flat[i])

    def as_dict(self) -> dict[str, float]:
        """{name: value} in vector order."""
        return dict(zip(self.names, self.values.ravel().tolist(), strict=True))


def _skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _inertia_matrix(p10: np.ndarray) -> np.ndarray:
    XX, XY, XZ, YY, YZ, ZZ = p10[:6]
    return np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])


def _inertia_entries(I: np.ndarray) -> np.ndarray:
    return np.array([I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]])


def transform_inertial(
    params_B: np.ndarray, R_AB: np.ndarray, p_AB: np.ndarray
) -> np.ndarray:
    """Re-expresses the 10 inertial parameters of one body from frame B to frame A.

    Both frames are fixed on the same body; X_AB = (R_AB, p_AB) is the pose of B
    in A (p_AB in m). The result is the inertia about Ao in A axes, the first
    moment M * p_AoBcm in A and the mass. The map is linear in ``params_B``.

    Args:
      params_B: (10,) ``XX..ZZ MX MY MZ M`` about Bo in B.
      R_AB: (3, 3) rotation; p_AB: (3,) position of Bo in A.

    Returns:
      (10,) parameters about Ao in A.

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import transform_inertial
    >>> params_B = np.array([0.0, 0, 0, 0, 0, 0, 0, 0, 0, 2.0])  # 2 kg at Bo
    >>> params_A = transform_inertial(params_B, np.eye(3), np.array([0.1, 0, 0]))
    >>> params_A[6:].round(3)
    array([0.2, 0. , 0. , 2. ])
    """
    p10 = np.asarray(params_B, dtype=np.float64)[:10]
    R = np.asarray(R_AB, dtype=np.float64)
    p = np.asarray(p_AB, dtype=np.float64)
    m = p10[9]
    c = R @ p10[6:9]  # first moment about Bo, in A axes
    P, C = _skew(p), _skew(c)
    I_A = R @ _inertia_matrix(p10) @ R.T - P @ C - C @ P - m * P @ P
    return np.concatenate([_inertia_entries(I_A), c + m * p, [m]])


def pseudo_inertia(params: np.ndarray) -> np.ndarray:
    """4x4 pseudo-inertia J = ∫ [r; 1][r; 1]^T dm of one link (r from Lo, in L).

    J = [[tr(I)/2 1 - I, M p_cm], [M p_cm^T, M]] for the inertia I about Lo.
    A mass distribution exists iff J is positive semidefinite (with M > 0).

    Args:
      params: at least the first 10 standard parameters of one link.

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import pseudo_inertia
    >>> params = np.array([0.0, 0, 0, 0.02, 0, 0.02, 0.2, 0, 0, 2.0])
    >>> J = pseudo_inertia(params)
    >>> J.shape, bool(np.linalg.eigvalsh(J).min() >= -1e-12)
    ((4, 4), True)
    """
    p10 = np.asarray(params, dtype=np.float64)[:10]
    I = _inertia_matrix(p10)
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I) * np.eye(3) - I
    J[:3, 3] = J[3, :3] = p10[6:9]
    J[3, 3] = p10[9]
    return J


def standard_from_spatial_inertia(M_BBo_B: SpatialInertia) -> np.ndarray:
    """The 10 inertial standard parameters of a Drake SpatialInertia about Bo in B.

    Inverse of :func:`rmdrake.model.plant.spatial_inertia_from_standard`.

    Example:

    >>> import numpy as np
    >>> from pydrake.multibody.tree import SpatialInertia
    >>> from rmdrake.dynamics import standard_from_spatial_inertia
    >>> M = SpatialInertia.SolidSphereWithMass(2.0, 0.1)
    >>> standard_from_spatial_inertia(M).round(4).tolist()
    [0.008, 0.0, 0.0, 0.008, 0.0, 0.008, 0.0, 0.0, 0.0, 2.0]
    """
    m = float(M_BBo_B.get_mass())
    I = M_BBo_B.CalcRotationalInertia().CopyToFullMatrix3()
    c = m * np.asarray(M_BBo_B.get_com())
    return np.concatenate([_inertia_entries(I), c, [m]])


def standard_parameters(model: RobotModel) -> np.ndarray:
    """The link-major (13n,) standard parameters chi of ``model``.

    A rigid payload (``model.payload``) is folded into link n: its inertia about
    its centre of mass is moved to the tool origin (parallel axis) and then
    re-expressed about the origin of MDH frame n in frame-n axes with the tool
    row's pose X_nE. The result is what the regressor of
    :func:`rmdrake.dynamics.regressor` multiplies to give the torques of
    :func:`rmdrake.model.plant.MakePlant` (which welds the payload as its own body).

    Raises:
      ValueError: when the model has no dynamic parameters.

    Example:

    >>> from rmdrake import load_robot, standard_parameters
    >>> chi = standard_parameters(load_robot("rv3sb"))
    >>> chi.shape
    (78,)
    """
    if model.dynamics is None:
        raise ValueError(
            f"robot '{model.name}': expected a 'dynamics' section with 13 standard "
            "parameters per link, found none"
        )
    chi = np.array(model.dynamics, dtype=np.float64)
    if model.payload is not None:
        chi[-1, :10] += payload_parameters(model, model.payload)
    return chi.ravel()


def payload_parameters(model: RobotModel, payload: Payload) -> np.ndarray:
    """(10,) inertial parameters of ``payload`` about the origin of MDH frame n
    in frame-n axes (``XX..ZZ MX MY MZ M``: kg m^2, kg m, kg): the amount
    :func:`standard_parameters` adds to link n (zeros for a massless payload)."""
    if payload.mass <= 0:
        return np.zeros(10)
    from rmdrake.model.plant import mdh_static_transform  # Drake's transforms

    X_nE = mdh_static_transform(model.tool)
    return transform_inertial(
        payload_inertial(payload), X_nE.rotation().matrix(), X_nE.translation()
    )


def payload_inertial(payload: Payload) -> np.ndarray:
    """(10,) inertial parameters ``XX..ZZ MX MY MZ M`` of a tool payload about
    the tool origin Eo in E axes (kg m^2, kg m, kg): its inertia about its
    centre of mass moved to Eo (parallel axis), first moments mass * p_EPcm.
    Inverse: :func:`payload_from_inertial`."""
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = payload.inertia
    I_com = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])
    P = _skew(payload.p_EPcm)
    I_E = I_com - payload.mass * P @ P  # about Eo (parallel axis), E axes
    m_c = payload.mass * payload.p_EPcm
    return np.concatenate([_inertia_entries(I_E), m_c, [payload.mass]])


def payload_from_inertial(phi_E: np.ndarray) -> Payload:
    """The :class:`~rmdrake.model.robot.Payload` (mass kg, p_EPcm m, inertia
    about its centre of mass in E axes kg m^2) of 10 inertial parameters about
    the tool origin Eo in E axes (:func:`payload_inertial`'s inverse).

    Raises:
      ValueError: a mass that is not > 0 (no centre of mass).
    """
    p10 = np.asarray(phi_E, dtype=np.float64)[:10]
    m = float(p10[9])
    if not m > 0:
        raise ValueError(f"payload: expected a mass > 0 kg, found {m:.6g}")
    com = p10[6:9] / m
    P = _skew(com)
    I_c = _inertia_matrix(p10) + m * P @ P  # back to the centre of mass
    inertia = [I_c[0, 0], I_c[1, 1], I_c[2, 2], I_c[0, 1], I_c[0, 2], I_c[1, 2]]
    return Payload(m, com, np.array(inertia))


def payload_map(model: RobotModel) -> np.ndarray:
    """(10, 10) linear map T with phi_n = T @ phi_E: 10 inertial parameters of
    a body fixed on the tool, about the tool origin Eo in E axes, to the same
    body's about the origin of MDH frame n in frame-n axes (the tool row's pose
    X_nE; :func:`transform_inertial` column by column)."""
    from rmdrake.model.plant import mdh_static_transform  # Drake's transforms

    X_nE = mdh_static_transform(model.tool)
    R, p = X_nE.rotation().matrix(), X_nE.translation()
    return np.stack([transform_inertial(e, R, p) for e in np.eye(10)], axis=1)


@dataclasses.dataclass(frozen=True, eq=False)
class PhysicalCheck:
    """Result of :func:`check_physical`.

    Attributes:
      failures: one ``(link, check, detail)`` per failed check; link is 1-based,
        check one of ``"mass > 0"``, ``"pseudo-inertia PSD"``, ``"Ia >= 0"``,
        ``"fv >= 0"``, ``"fc >= 0"``.
      min_eigenvalues: (n,) smallest eigenvalue of each link's pseudo-inertia
        (kg m^2).

    Example:

    >>> from rmdrake import check_physical, load_robot, standard_parameters
    >>> chi = standard_parameters(load_robot("rv3sb"))
    >>> chi[9] = -1.0
    >>> report = check_physical(chi)
    >>> report.ok, report.failures[0][:2]
    (False, (1, 'mass > 0'))
    """

    failures: tuple[tuple[int, str, str], ...]
    min_eigenvalues: np.ndarray

    @property
    def ok(self) -> bool:
        """True when every link passes every check."""
        return not self.failures

    def __str__(self) -> str:
        if self.ok:
            return "physically consistent"
        return "; ".join(f"link {j}: {c} fails ({d})" for j, c, d in self.failures)


def check_physical(chi: object, rtol: float = 1e-10) -> PhysicalCheck:
    """Physical-consistency report of standard parameters.

    Per link: mass > 0; the pseudo-inertia (:func:`pseudo_inertia`) positive
    semidefinite, i.e. its smallest eigenvalue >= -rtol * its largest absolute
    eigenvalue (point masses and thin rods are exactly singular); Ia, fv and
    fc >= 0.

    Args:
      chi: (13n,) vector or (n, 13) array.
      rtol: relative eigenvalue tolerance (dimensionless).

    Example:

    >>> from rmdrake import check_physical, load_robot, standard_parameters
    >>> chi = standard_parameters(load_robot("rv3sb"))
    >>> check_physical(chi).ok
    True
    >>> chi[9] = -1.0  # link 1's mass
    >>> check_physical(chi).ok
    False
    """
    links = _as_links(chi)
    failures: list[tuple[int, str, str]] = []
    mins = np.empty(links.shape[0])
    for j, p in enumerate(links, start=1):
        if not p[9] > 0:
            failures.append((j, "mass > 0", f"M = {p[9]:.6g} kg"))
        ev = np.linalg.eigvalsh(pseudo_inertia(p))
        mins[j - 1] = ev[0]
        if ev[0] < -rtol * max(np.max(np.abs(ev)), np.finfo(float).tiny):
            failures.append(
                (
                    j,
                    "pseudo-inertia PSD",
                    f"smallest eigenvalue {ev[0]:.6g} kg m^2 (no mass distribution "
                    "has these inertia, first moments and mass)",
                )
            )
        units = ("kg m^2 or kg", "N m s/rad or N s/m", "N m or N")
        for k, unit in zip((10, 11, 12), units, strict=True):
            if p[k] < 0:
                key = DYNAMIC_KEYS[k]
                failures.append((j, f"{key} >= 0", f"{key} = {p[k]:.6g} {unit}"))
    return PhysicalCheck(tuple(failures), mins)


def require_physical(chi: object, what: str = "dynamic parameters") -> None:
    """Raises ValueError naming the first failing link and check, if any.

    Use before giving parameters to a simulator.

    Example:

    >>> from rmdrake.dynamics import require_physical
    >>> from rmdrake import load_robot, standard_parameters
    >>> chi = standard_parameters(load_robot("rv3sb"))
    >>> require_physical(chi)
    >>> chi[9] = -1.0
    >>> try:
    ...     require_physical(chi)
    ... except ValueError as error:
    ...     print(str(error)[:38])
    ...
    dynamic parameters: physically invalid
    """
    report = check_physical(chi)
    if not report.ok:
        j, check, detail = report.failures[0]
        more = len(report.failures) - 1
        tail = f" (and {more} more: {report})" if more else ""
        raise ValueError(
            f"{what}: physically invalid: link {j}: {check} fails ({detail}){tail}"
        )


def random_standard_parameters(
    n: int,
    rng: np.random.Generator,
    *,
    mass: Sequence[float] = (0.5, 10.0),
    size: float = 0.3,
) -> np.ndarray:
    """Random physically valid standard parameters (13n,), for tests and studies.

    Per link: a mass uniform in ``mass`` (kg), a centre of mass uniform in a cube
    of half side ``size`` (m) about the origin, principal moments of a random
    solid (satisfying the triangle inequalities) rotated randomly, moved to the
    link origin; Ia, fv, fc uniform in [0, 1) (SI units).

    Example:

    >>> import numpy as np
    >>> from rmdrake.dynamics import check_physical, random_standard_parameters
    >>> chi = random_standard_parameters(3, np.random.default_rng(0))
    >>> chi.shape, check_physical(chi).ok
    ((39,), True)
    """
    out = np.empty((n, N_PER_LINK))
    for j in range(n):
        m = rng.uniform(*mass)
        com = rng.uniform(-size, size, 3)
        # Second moments of a box-like body: Sigma = diag(s) >= 0 gives
        # principal moments s_y + s_z etc., always physically valid.
        s = m * (size * rng.uniform(0.05, 1.0, 3)) ** 2
        Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        I_c = Q @ np.diag([s[1] + s[2], s[0] + s[2], s[0] + s[1]]) @ Q.T
        P = _skew(com)
        I_o = I_c - m * P @ P
        out[j, :10] = np.concatenate([_inertia_entries(I_o), m * com, [m]])
        out[j, 10:] = rng.uniform(0.0, 1.0, 3)
    return out.ravel()


def perturb_standard_parameters(
    chi: object, rng: np.random.Generator, *, low: float = 0.1, high: float = 0.3
) -> np.ndarray:
    """A physically valid "true" robot near ``chi`` (13n,), for studies.

    Per link, with u ~ U[low, high] drawn afresh for each effect and a random
    sign: the mass distribution is scaled by 1 + u, rotated about its centre of
    mass by u rad about a random axis and moved by u times its size (|p_com| or
    its radius of gyration, whichever is larger) in a random direction; Ia, fv
    and fc are each scaled by 1 + u. Scaling, rotating and moving a mass
    distribution keeps its pseudo-inertia positive semidefinite, so the result
    is physically valid whenever ``chi`` is.
    """
    from scipy.spatial.transform import Rotation

    links = _as_links(chi).copy()
    for j in range(links.shape[0]):
        p = links[j]
        m = p[9]
        if m <= 0:
            continue

        def u() -> float:
            return float(rng.uniform(low, high) * rng.choice((-1.0, 1.0)))

        com = p[6:9] / m
        I_o = _inertia_matrix(p[:10])
        P = _skew(com)
        I_c = I_o + m * P @ P  # about the centre of mass
        size = max(float(np.linalg.norm(com)), float(np.sqrt(np.trace(I_c) / (2 * m))))
        R = Rotation.from_rotvec(abs(u()) * _unit(rng)).as_matrix()
        new_com = com + abs(u()) * size * _unit(rng)
        m_new = m * (1.0 + u())
        I_c_new = (m_new / m) * R @ I_c @ R.T
        Pn = _skew(new_com)
        I_o_new = I_c_new - m_new * Pn @ Pn
        p[:10] = np.concatenate([_inertia_entries(I_o_new), m_new * new_com, [m_new]])
        p[10:] = p[10:] * (1.0 + np.array([u(), u(), u()]))
    return links.ravel()


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)
