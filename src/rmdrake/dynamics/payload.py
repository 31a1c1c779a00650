"""A tool payload identified from a short excitation of an identified arm.

The payload is a rigid body fixed on the tool frame E, itself fixed in link n.
Its 10 inertial parameters phi_E (``XX..ZZ MX MY MZ M`` about the tool origin
Eo in E axes: kg m^2, kg m, kg) enter the joint efforts through the regressor
columns of link n's 10 inertial parameters (``cols = 13 (n-1) + 0..9`` of
:func:`rmdrake.dynamics.regressor.regressor`), moved to the tool frame by the
linear map T of :func:`rmdrake.model.dynamic_parameters.payload_map`
(phi_n = T phi_E, the tool row's pose X_nE):

    tau_loaded - tau_arm(q, qd, qdd) = Y_n(q, qd, qdd)[:, cols] T phi_E.

tau_arm is what the identified arm (without payload) predicts
(:func:`rmdrake.dynamics.validation.predict_torques`: rigid body, rotor
inertia, friction, offsets). With a log of the same trajectory without the
payload, the right-hand side is instead

    (tau_loaded - tau_arm(loaded states)) - (tau_unloaded - tau_arm(unloaded
    states)),

the samples paired by time stamp: the arm's model error, the same on both runs
of one trajectory, cancels, and the arm's prediction only accounts for the
small difference between the two runs' states.

An elastic arm (``compliance`` stiffness k_j > 0) logs its motor side: the
encoder's q_m and the motor's effort tau, which drives the rotor (Ia, friction,
on the motor side) and the spring k (q_m - q_l). The payload acts on the link
side, so each sample is moved there first: q_l = q_m - (tau - Ia qdd - f(qd)) /
k (the arm's own rotor and friction terms), velocities and accelerations kept.
That is exact at rest and close while the excitation's top frequency stays well
below the lowest structural mode: on the DEMO-class arm (mode 1.8 Hz unloaded,
1.4 Hz with the module) a 3-harmonic design at 0.1 Hz (top 0.3 Hz) identifies
the 4.5 t module within 0.08 % and 4 mm over seeds 0..2, where the motor-side
samples left 1.1 % and 39 mm.

Fit. Least squares first, each joint's rows weighted by the inverse of its
residual standard deviation (two passes, as Gautier's weighted LS), with
columns scaled to unit norm; the 10 columns must have full rank on the motion
(relative singular value over :data:`RANK_RTOL`), else the payload is not
identifiable and refused. That solution is kept when its 4x4 pseudo-inertia
(:func:`rmdrake.model.dynamic_parameters.pseudo_inertia`) is positive
semidefinite with mass > 0; otherwise the same weighted problem is solved
under those constraints with cvxpy + Clarabel (the pseudo-inertia map of
:func:`rmdrake.dynamics.physical_fit.pseudo_inertia_map`). Standard deviations
are the weighted least squares' (sigma^2 (A^T A)^-1 in the weighted metric),
the centre of mass's by first-order propagation through p_EPcm = (MX, MY, MZ)
/ M.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from rmdrake.dynamics.chain import SerialChain
from rmdrake.dynamics.compliance import joint_compliances
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.friction import friction_torque
from rmdrake.dynamics.physical_fit import lift_to_physical, pseudo_inertia_map
from rmdrake.dynamics.regressor import regressor
from rmdrake.dynamics.validation import predict_torques
from rmdrake.model.dynamic_parameters import (
    INERTIAL_KEYS,
    N_PER_LINK,
    check_physical,
    payload_from_inertial,
    payload_map,
)
from rmdrake.model.robot import DYNAMIC_KEYS, Payload, RobotModel

__all__ = [
    "MASS_SIGMAS",
    "MAX_COM_STD",
    "MAX_MASS_RATIO",
    "RANK_RTOL",
    "PayloadColumns",
    "PayloadIdentification",
    "check_payload",
    "identify_payload",
    "payload_warnings",
    "link_side",
    "link_side_positions",
    "pair_samples",
]

RANK_RTOL = 1e-6
"""Relative singular value (columns scaled to unit norm) under which a
direction of the payload's 10 parameters counts as unseen by the motion."""

MAX_MASS_RATIO = 10.0
"""A payload over this many times the arm's own moving mass is refused."""
MASS_SIGMAS = 3.0
"""A least-squares mass under this many of its standard deviations is not
told from no payload, and refused ("no payload seen"): two logs of the arm
without one gave 0.6 and 2.3 std in the Drake station (a 0.2 kg payload on
the RV-3SB: 240-340 std)."""
MAX_COM_STD = 0.05
"""m: the largest standard deviation of the centre of mass (any axis) of a
payload written: beyond, the motion did not determine it (logs without a
payload: 80-820 mm; the RV-3SB's 2 kg and 0.2 kg payloads: 0.1-1.4 mm, on 28
samples 0.7 mm). The inertia's std, as a radius of gyration sqrt(std(I) /
mass), over the same bound only warns (:func:`payload_warnings`): a light
payload's inertia is at the noise (0.2 kg: 37-57 mm) and moves little torque."""


class PayloadColumns:
    """The payload's 10 regressor columns, phi_E about the tool origin Eo in E
    axes (module docstring); the interface of
    :class:`~rmdrake.dynamics.base.BaseParameters` that the excitation design
    uses (``count``, ``regressor``).

    Attributes:
      T: (10, 10) phi_n = T phi_E
        (:func:`~rmdrake.model.dynamic_parameters.payload_map`).
      columns: (10,) link n's inertial columns of the standard regressor.
      count: 10.
    """

    def __init__(self, model: RobotModel) -> None:
        n = model.n_joints
        self.T = payload_map(model)
        self.columns = N_PER_LINK * (n - 1) + np.arange(10)
        self.count = 10

    @property
    def names(self) -> list[str]:
        """``XX..ZZ MX MY MZ M`` of the payload at the tool frame."""
        return list(INERTIAL_KEYS)

    def regressor(
        self,
        chain: SerialChain | RobotModel,
        q: object,
        qd: object,
        qdd: object,
        *,
        out: np.ndarray | None = None,
        coulomb_width: float = 0.0,
    ) -> np.ndarray:
        """(N, n, 10) payload regressor (N m or N per unit of phi_E), or (n, 10)
        for one sample; ``coulomb_width`` is accepted for the interface and
        unused (no friction column); ``out`` likewise."""
        del out, coulomb_width
        return regressor(chain, q, qd, qdd, self.columns) @ self.T


@dataclasses.dataclass(frozen=True)
class PayloadIdentification:
    """Result of :func:`identify_payload`.

    Attributes:
      payload: the identified payload (mass kg, p_EPcm m in E, inertia about
        its centre of mass in E axes, kg m^2), physically consistent.
      phi: (10,) its parameters about Eo in E axes (kg m^2, kg m, kg).
      phi_ls: (10,) the weighted least-squares solution (maybe not physical).
      physical_ls: whether ``phi_ls`` was physically consistent (kept as is).
      mass_std: kg; com_std: (3,) m; phi_std: (10,) standard deviations of the
        weighted least squares.
      residual_rms: (n,) per joint, N m or N.
      condition: cond of the 10 payload columns (scaled to unit norm, weighted).
      condition_raw: cond of the 10 columns in SI units, unweighted (the
        excitation design's figure).
      samples: equations' sample count; paired: an unloaded log was used.
    """

    payload: Payload
    phi: np.ndarray
    phi_ls: np.ndarray
    physical_ls: bool
    mass_std: float
    com_std: np.ndarray
    phi_std: np.ndarray
    residual_rms: np.ndarray
    condition: float
    condition_raw: float
    samples: int
    paired: bool

    def summary(self) -> list[str]:
        """Lines: mass and centre of mass (mm) with standard deviations, the
        inertia, the fit."""
        p = self.payload
        com = ", ".join(f"{1e3 * v:.2f}" for v in p.p_EPcm)
        com_std = ", ".join(f"{1e3 * v:.2f}" for v in self.com_std)
        inertia = ", ".join(f"{v:.4g}" for v in p.inertia)
        rms = ", ".join(f"{v:.4g}" for v in self.residual_rms)
        how = "least squares (physically consistent)"
        if not self.physical_ls:
            how = "physically consistent least squares (LS was not physical)"
        return [
            f"payload mass {p.mass:.6g} kg (std {self.mass_std:.3g} kg)",
            f"centre of mass in the tool frame [mm]: {com} (std {com_std})",
            f"inertia about the centre of mass [kg m^2] (Ixx, Iyy, Izz, Ixy, Ixz, "
            f"Iyz): {inertia}",
            f"{how}; {self.samples} samples"
            f"{' paired with the unloaded log' if self.paired else ''}; cond of the "
            f"10 payload columns {self.condition_raw:.4g} "
            f"(scaled {self.condition:.3g})",
            f"residual RMS per joint [N m or N]: {rms}",
        ]


def pair_samples(
    loaded: JointSamples, unloaded: JointSamples, *, max_q_share: float = 0.1
) -> tuple[JointSamples, JointSamples]:
    """The samples of two runs of one trajectory at common time stamps.

    Raises:
      ValueError: different rates, under half of the loaded samples in
        common, or joint paths that differ by over ``max_q_share`` of a
        joint's motion (RMS): not the same trajectory.
    """
    if not np.isclose(loaded.rate, unloaded.rate, rtol=1e-9):
        raise ValueError(
            f"logs: loaded at {loaded.rate:g} Hz, unloaded at {unloaded.rate:g} Hz; "
            "prepare both at one --rate"
        )
    kl = np.round(loaded.t * loaded.rate).astype(np.int64)
    ku = np.round(unloaded.t * loaded.rate).astype(np.int64)
    _, il, iu = np.intersect1d(kl, ku, return_indices=True)
    if il.size < 0.5 * loaded.n_samples:
        raise ValueError(
            f"logs: {il.size} of {loaded.n_samples} loaded samples have an unloaded "
            "sample at the same time: not the same trajectory"
        )
    L, U = loaded.select(il), unloaded.select(iu)
    motion = np.sqrt(np.mean((L.q - L.q.mean(axis=0)) ** 2, axis=0))
    diff = np.sqrt(np.mean((L.q - U.q) ** 2, axis=0))
    off = np.flatnonzero(diff > max_q_share * np.maximum(motion, 1e-9))
    if off.size:
        j = int(off[0])
        raise ValueError(
            f"logs: joint {j + 1} differs by {diff[j]:.3g} RMS between the loaded "
            f"and the unloaded log ({motion[j]:.3g} of motion): not the same "
            "trajectory"
        )
    return L, U


def _arm_residual(arm: RobotModel, s: JointSamples, coulomb_width: float) -> np.ndarray:
    """(N, n) logged effort minus the arm's prediction, N m or N."""
    pred = predict_torques([arm], s.q, s.qd, s.qdd, coulomb_width=coulomb_width)
    return s.tau - pred[0]


def link_side_positions(
    arm: RobotModel,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    tau: np.ndarray,
    coulomb_width: float = 0.0,
) -> np.ndarray:
    """An elastic ``arm``'s link-side positions q_l = q_m - (tau - Ia qdd -
    f(qd)) / k (module docstring) from its motor side: q, qd, qdd, tau (N, n)
    in rad, rad/s, rad/s^2, N m (m, N on a prismatic joint); rigid joints keep
    q. The motor-side terms are the arm's rotor inertia Ia qdd and its joint
    friction, offsets included (:func:`~rmdrake.dynamics.friction.
    friction_torque`, the formula of the regressor's friction columns): a few
    microseconds a sample, so the online estimator can call it every update."""
    c = joint_compliances(arm)
    if not np.any(c):
        return q
    dynamics = np.asarray(arm.dynamics, dtype=np.float64)
    Ia, fv, fc = (dynamics[:, DYNAMIC_KEYS.index(k)] for k in ("Ia", "fv", "fc"))
    motor = Ia * qdd + friction_torque(
        qd, fv, fc, coulomb_width, fcn=arm.fcn, tau0=arm.tau0
    )
    return q - c * (tau - motor)


def link_side(arm: RobotModel, s: JointSamples, coulomb_width: float) -> JointSamples:
    """Samples of an elastic ``arm``'s motor side moved to its link side
    (:func:`link_side_positions`); velocities, accelerations and efforts
    unchanged."""
    q = link_side_positions(arm, s.q, s.qd, s.qdd, s.tau, coulomb_width)
    return s if q is s.q else dataclasses.replace(s, q=q)


def identify_payload(
    model: RobotModel,
    loaded: JointSamples,
    unloaded: JointSamples | None = None,
    *,
    coulomb_width: float = 0.0,
) -> PayloadIdentification:
    """The payload's 10 inertial parameters at the tool frame (module
    docstring).

    Args:
      model: the identified arm (its ``dynamics``; its own ``payload`` is
        ignored: the arm is predicted without one). An elastic arm's samples
        are moved to its link side first (:func:`link_side`).
      loaded: prepared samples of the arm carrying the payload.
      unloaded: optional samples of the same trajectory without it.
      coulomb_width: the Coulomb sign's width the arm was identified with,
        rad/s or m/s (0: sign(qd)).

    Raises:
      ValueError: one line: a robot without dynamics, joint counts not the
        robot's, too few samples, a payload the motion does not identify (the
        unseen parameters named), or a failed constrained solve.
    """
    if model.dynamics is None:
        raise ValueError(
            f"robot '{model.name}': has no dynamics; identify the arm first "
            "(rmdrake identify), then its payload"
        )
    n = model.n_joints
    for what, s in (("loaded", loaded), ("unloaded", unloaded)):
        if s is not None and s.n_joints != n:
            raise ValueError(
                f"{what} log: {s.n_joints} joints, expected {n} (robot '{model.name}')"
            )
    arm = dataclasses.replace(model, payload=None)
    loaded = link_side(arm, loaded, coulomb_width)
    if unloaded is not None:
        unloaded = link_side(arm, unloaded, coulomb_width)
    arm = dataclasses.replace(arm, compliance=None)
    if unloaded is not None:
        loaded, unloaded = pair_samples(loaded, unloaded)
        rhs = _arm_residual(arm, loaded, coulomb_width) - _arm_residual(
            arm, unloaded, coulomb_width
        )
    else:
        rhs = _arm_residual(arm, loaded, coulomb_width)
    cols = PayloadColumns(model)
    Y = cols.regressor(model, loaded.q, loaded.qd, loaded.qdd)
    if Y.shape[0] * n < 10 * 2:
        raise ValueError(
            f"log: {Y.shape[0]} samples x {n} joints for 10 payload parameters; "
            "log more"
        )
    condition_raw = _condition(Y.reshape(-1, 10))
    phi, sigma, cov, condition = _weighted_ls(Y, rhs)
    physical = bool(check_physical(np.r_[phi, 0.0, 0.0, 0.0]).ok)
    if physical:
        phi_fit = phi
    else:  # a mass <= 0 ends on its bound, refused by check_payload
        phi_fit = _physical_fit(Y / sigma[:, None], rhs / sigma, phi)
    payload = payload_from_inertial(phi_fit)
    m, c = phi_fit[9], phi_fit[6:9]
    J = np.zeros((3, 10))
    J[:, 6:9] = np.eye(3) / m
    J[:, 9] = -c / m**2
    com_std = np.sqrt(np.maximum(np.diag(J @ cov @ J.T), 0.0))
    residual = rhs - Y @ phi_fit
    return PayloadIdentification(
        payload=payload,
        phi=phi_fit,
        phi_ls=phi,
        physical_ls=physical,
        mass_std=float(np.sqrt(max(cov[9, 9], 0.0))),
        com_std=com_std,
        phi_std=np.sqrt(np.maximum(np.diag(cov), 0.0)),
        residual_rms=np.sqrt(np.mean(residual**2, axis=0)),
        condition=condition,
        condition_raw=condition_raw,
        samples=int(Y.shape[0]),
        paired=unloaded is not None,
    )


def _condition(A: np.ndarray) -> float:
    """cond(A) of a (rows, 10) matrix (inf when singular)."""
    s = np.linalg.svd(A, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def _weighted_ls(
    Y: np.ndarray, rhs: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(phi, sigma (n,), covariance (10, 10), condition) of the joint-weighted
    least squares of Y (N, n, 10) phi = rhs (N, n) (module docstring).

    Raises:
      ValueError: the scaled columns rank deficient (the unseen parameters
        named)."""
    N, n, _ = Y.shape
    sigma = np.ones(n)
    for _ in range(2):  # OLS, then weighted by the residual's per-joint std
        A = (Y / sigma[None, :, None]).reshape(-1, 10)
        b = (rhs / sigma).ravel()
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        U, s, Vt = np.linalg.svd(A / scale, full_matrices=False)
        unseen = s < RANK_RTOL * s[0]
        if np.any(unseen):
            weight = np.abs(Vt[unseen]).max(axis=0)
            names = [k for k, w in zip(INERTIAL_KEYS, weight, strict=True) if w > 0.1]
            raise ValueError(
                f"payload: not identifiable from this motion (its 10 columns have "
                f"rank {int(np.sum(~unseen))}: {', '.join(names)} unseen); log an "
                "excitation that moves every joint (rmdrake excite --payload)"
            )
        phi = (Vt.T @ ((U.T @ b) / s)) / scale
        r = (b - A @ phi).reshape(N, n) * sigma
        dof = max(N - 10 / n, 1.0)
        std = np.sqrt(np.sum(r**2, axis=0) / dof)
        sigma = np.maximum(std, 1e-12 * max(float(std.max()), 1e-300))
    A = (Y / sigma[None, :, None]).reshape(-1, 10)
    b = (rhs / sigma).ravel()
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    U, s, Vt = np.linalg.svd(A / scale, full_matrices=False)
    phi = (Vt.T @ ((U.T @ b) / s)) / scale
    r = b - A @ phi
    var = float(r @ r) / max(A.shape[0] - 10, 1)
    inv = (Vt.T / s**2) @ Vt
    cov = var * inv / np.outer(scale, scale)
    return phi, sigma, cov, float(s[0] / s[-1])


def _physical_fit(Y: np.ndarray, rhs: np.ndarray, start: np.ndarray) -> np.ndarray:
    """phi (10,) minimising ||Y phi - rhs|| (Y (N, n, 10) and rhs (N, n)
    already weighted) subject to the pseudo-inertia >= 0 and mass > 0
    (cvxpy + Clarabel), in variables scaled by |start| (at least a tenth of
    the largest of its kind), then lifted onto the cone
    (:func:`~rmdrake.dynamics.physical_fit.lift_to_physical`).

    Raises:
      ValueError: the solver failed (its status)."""
    import cvxpy as cp

    A, b = Y.reshape(-1, 10), rhs.ravel()
    Q, R = np.linalg.qr(A)
    c = Q.T @ b
    mag = np.abs(start)
    D = np.empty(10)
    for g in (slice(0, 6), slice(6, 9), slice(9, 10)):
        D[g] = np.maximum(mag[g], 0.1 * max(float(mag[g].max()), 1e-12))
    RD = R * D
    norm = max(float(np.linalg.norm(RD)), 1e-300)
    x = cp.Variable(10)
    J = cp.reshape((pseudo_inertia_map() * D) @ x, (4, 4), order="C")
    cons = [0.5 * (J + J.T) >> 0, x[9] >= 1e-9]
    problem = cp.Problem(cp.Minimize(cp.sum_squares((RD @ x - c) / norm)), cons)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Solution may be inaccurate")
        try:
            problem.solve(
                solver="CLARABEL", tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10
            )
        except cp.error.SolverError:
            raise ValueError(
                "payload: physically consistent fit failed: CLARABEL failed"
            ) from None
    if problem.status not in ("optimal", "optimal_inaccurate") or x.value is None:
        raise ValueError(
            f"payload: physically consistent fit failed: solver status "
            f"'{problem.status}'"
        )
    return lift_to_physical(D * np.asarray(x.value, dtype=np.float64), 1, 10)


def check_payload(
    result: PayloadIdentification,
    model: RobotModel,
    *,
    max_mass_ratio: float = MAX_MASS_RATIO,
) -> list[str]:
    """Reasons (one line each; empty: plausible) to refuse an identified
    payload: a least-squares mass <= 0 (the physical fit then sits on its
    bound) or under :data:`MASS_SIGMAS` of its std (no payload seen); else
    a centre of mass the motion left undetermined (std over
    :data:`MAX_COM_STD`), or a mass
    over ``max_mass_ratio`` times the arm's own moving mass (the sum of its
    link masses, kg)."""
    reasons = []
    m_ls = float(result.phi_ls[9])
    m_std = float(result.mass_std)
    if not m_ls > 0:
        reasons.append(
            f"payload: least-squares mass {m_ls:.4g} kg is not positive: the log "
            "shows no payload, or its torques' sign is reversed"
        )
    elif not m_ls > MASS_SIGMAS * m_std:
        g = m_std < 1.0  # grams for a payload not told from none
        unit, f = ("g", 1e3) if g else ("kg", 1.0)
        reasons.append(
            f"payload: no payload seen: mass {f * m_ls:.2g} {unit} +- "
            f"{f * m_std:.2g} {unit} (under {MASS_SIGMAS:g} std from 0); log "
            "the arm carrying the payload (--log), the same trajectory without "
            "it as --log-unloaded"
        )
    if reasons:  # a payload not seen has no centre of mass to judge
        return reasons
    com_std = float(np.max(result.com_std))
    if not com_std <= MAX_COM_STD:
        reasons.append(
            f"payload: undetermined: com std {1e3 * com_std:.3g} mm (over "
            f"{1e3 * MAX_COM_STD:g} mm); excite more (rmdrake excite --payload) "
            "or log longer"
        )

    arm_mass = float(np.sum(np.asarray(model.dynamics)[:, 9]))
    m = result.payload.mass
    if arm_mass > 0 and m > max_mass_ratio * arm_mass:
        reasons.append(
            f"payload: mass {m:.4g} kg is over {max_mass_ratio:g}x the arm's own "
            f"{arm_mass:.4g} kg: a log of another robot or unit (N mm?)"
        )
    return reasons


def payload_warnings(result: PayloadIdentification) -> list[str]:
    """Warnings (one line each) on a payload written: an inertia the motion
    left undetermined, its std as a radius of gyration sqrt(std(I) / mass)
    over :data:`MAX_COM_STD` (the torque it moves is small: written, said)."""
    m = max(float(result.payload.mass), 1e-300)
    std = float(np.max(result.phi_std[:3]))
    gyration = float(np.sqrt(std / m))
    if gyration <= MAX_COM_STD:
        return []
    return [
        f"payload: inertia undetermined: std {std:.3g} kg m^2 (a radius of "
        f"gyration of {1e3 * gyration:.3g} mm, over {1e3 * MAX_COM_STD:g} mm); "
        "its torque is small; excite more (rmdrake excite --payload) to know it"
    ]
