"""A "true" robot drawn near a nominal one: the robot a calibration or an
identification should find, for simulations and tutorials.

:func:`perturb_robot` adds zero-mean normal errors to named MDH error
parameters (:mod:`rmdrake.model.error_parameters`: lengths in m, angles in
rad), and optionally scales the standard dynamic parameters
(:mod:`rmdrake.model.dynamic_parameters`) and the joint stiffnesses
(:class:`~rmdrake.model.robot.Compliance`) by random factors. Each of the three
draws has its own stream of ``numpy.random.SeedSequence(seed).spawn(3)``, so
turning one on leaves the others' draws as they were; the same seed gives the
same robot, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from rmdrake.model.dynamic_parameters import (
    N_PER_LINK,
    check_physical,
    parameter_names,
)
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_names,
    is_compliance_name,
    split_error_parameters,
)
from rmdrake.model.robot import Compliance, RobotModel

__all__ = [
    "MAX_ANGLE_STD",
    "MAX_DYNAMICS_STD",
    "MAX_LENGTH_STD",
    "MAX_SCALE_FACTOR",
    "MAX_STIFFNESS_STD",
    "PERTURB_PRESETS",
    "perturb_names",
    "perturb_robot",
    "scale_dynamics",
]

#: m: the largest ``length_std`` (a tenth of a metre is no longer an error of
#: the same robot).
MAX_LENGTH_STD = 0.1
#: rad: the largest ``angle_std`` (5.7 deg).
MAX_ANGLE_STD = 0.1
#: The largest relative ``dynamics_std`` (a factor 1 +- 0.5 at one sigma).
MAX_DYNAMICS_STD = 0.5
#: The largest ``stiffness_std``, of log k (a factor e^{+-1} at one sigma).
MAX_STIFFNESS_STD = 1.0
#: The largest factor (and the inverse of the smallest) of
#: :func:`scale_dynamics`: a worn joint's friction is a few times the new one's,
#: a heavier link a few times the nominal; 100x is no longer the same robot.
MAX_SCALE_FACTOR = 100.0
#: The parameter presets of :func:`perturb_names`.
PERTURB_PRESETS: tuple[str, ...] = ("paper", "full")
#: Draws of one link's dynamics before :func:`perturb_robot` gives up.
MAX_DYNAMICS_TRIES = 10_000


def perturb_names(model: RobotModel, params: str | Sequence[str]) -> list[str]:
    """The MDH error-parameter names of ``params``: a preset (``paper``,
    ``full``: :func:`~rmdrake.model.error_parameters.error_parameter_names`),
    a comma-separated string of names or a sequence of names; joint
    compliances ``c<j>`` are left out (they are not errors to add; see
    ``stiffness_std`` of :func:`perturb_robot`).

    Raises:
      ValueError: an unknown preset or name, or a duplicated name (one line,
        naming it).
    """
    if isinstance(params, str):
        text = params.strip()
        if text in PERTURB_PRESETS:
            return error_parameter_names(model, text)
        if "," not in text and not text.startswith(("d", "c")):
            raise ValueError(
                f"unknown parameter preset '{text}': expected 'paper', 'full' or a "
                "comma-separated list of names such as dalpha2,dd3,dr4"
            )
        params = [p.strip() for p in text.split(",") if p.strip()]
    names = [str(p) for p in params]
    if not names:
        raise ValueError("error parameters: none given")
    split_error_parameters(model, names)  # raises naming an unknown name
    return [n for n in names if not is_compliance_name(n)]


def _check_std(value: float, name: str, bound: float, unit: str) -> float:
    """``value`` as a float in [0, bound], else a one-line ValueError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, found {value!r}") from None
    if not math.isfinite(v) or v < 0:
        raise ValueError(f"{name}: expected a finite number >= 0, found {value}")
    if v > bound:
        raise ValueError(
            f"{name} {v:g}{unit}: over {bound:g}{unit}, beyond an error of the "
            "same robot"
        )
    return v


def perturb_robot(
    model: RobotModel,
    *,
    params: str | Sequence[str] = "paper",
    length_std: float = 0.0,
    angle_std: float = 0.0,
    dynamics_std: float = 0.0,
    stiffness_std: float = 0.0,
    seed: int = 0,
    name: str | None = None,
) -> tuple[RobotModel, dict[str, float]]:
    """Draws a "true" robot near ``model``.

    Kinematics: each MDH error parameter of ``params`` (:func:`perturb_names`)
    gets a delta ~ N(0, length_std^2) (m) if it is a length (``dd<j>``,
    ``dr<j>``) or N(0, angle_std^2) (rad) if an angle (``dalpha<j>``,
    ``dtheta<j>``, ``dbeta<j>``), added to the MDH table by
    :func:`~rmdrake.model.error_parameters.apply_deltas`. One standard normal
    is drawn per name whatever the stds, so a std of 0 only zeroes its
    parameters' deltas.

    Dynamics (``dynamics_std`` > 0): each of the 13 standard parameters of each
    link (``model.dynamics``, :mod:`rmdrake.model.dynamic_parameters`: inertia
    kg m^2, first moments kg m, mass kg, Ia, fv, fc) is multiplied by
    1 + dynamics_std * N(0, 1); a link whose draw fails a check of
    :func:`~rmdrake.model.dynamic_parameters.check_physical` that its nominal
    passes is drawn again (at most :data:`MAX_DYNAMICS_TRIES` times), so the
    factors are normal truncated to physical links. A tool payload (a separate
    body, ``model.payload``), ``fcn`` and ``tau0`` are kept as they are.

    Stiffness (``stiffness_std`` > 0): each joint's stiffness k_j > 0 (N m/rad
    or N/m) and its damping are multiplied by exp(stiffness_std * N(0, 1));
    rigid joints (k_j = 0) stay rigid.

    Args:
      model: the nominal robot.
      params: the error parameters (see :func:`perturb_names`); default the
        paper's 17.
      length_std: m, std of the length errors, 0..:data:`MAX_LENGTH_STD`
        (0.1 m).
      angle_std: rad, std of the angle errors, 0..:data:`MAX_ANGLE_STD`
        (0.1 rad).
      dynamics_std: relative std of the dynamic parameters (dimensionless),
        0..:data:`MAX_DYNAMICS_STD` (0.5).
      stiffness_std: std of log k (dimensionless),
        0..:data:`MAX_STIFFNESS_STD` (1.0).
      seed: seeds ``numpy.random.SeedSequence(seed).spawn(3)``: one stream
        each for the kinematics, the dynamics and the stiffness.
      name: the true robot's name; default ``<model name>_true``.

    Returns:
      (the true robot, {error-parameter name: delta} of the kinematic errors
      drawn with a std > 0, in m or rad).

    Raises:
      ValueError: (one line) a std negative, not finite or over its bound;
        every std 0 ("nothing to perturb"); ``dynamics_std`` > 0 on a robot
        without dynamics, ``stiffness_std`` > 0 on one without elastic joints;
        an unknown parameter; a link with no physical draw in
        :data:`MAX_DYNAMICS_TRIES`.
    """
    length_std = _check_std(length_std, "length_std", MAX_LENGTH_STD, " m")
    angle_std = _check_std(angle_std, "angle_std", MAX_ANGLE_STD, " rad")
    dynamics_std = _check_std(dynamics_std, "dynamics_std", MAX_DYNAMICS_STD, "")
    stiffness_std = _check_std(stiffness_std, "stiffness_std", MAX_STIFFNESS_STD, "")
    if not (length_std or angle_std or dynamics_std or stiffness_std):
        raise ValueError(
            "nothing to perturb: every std (length, angle, dynamics, stiffness) is 0"
        )
    if dynamics_std and model.dynamics is None:
        raise ValueError(
            f"dynamics_std {dynamics_std:g}: robot '{model.name}' has no dynamics "
            "to perturb"
        )
    if stiffness_std and (
        model.compliance is None or not np.any(model.compliance.elastic)
    ):
        raise ValueError(
            f"stiffness_std {stiffness_std:g}: robot '{model.name}' has no elastic "
            "joint (compliance: stiffness > 0) to perturb"
        )
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, found {seed!r}")
    rng_kin, rng_dyn, rng_k = (
        np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(3)
    )

    deltas: dict[str, float] = {}
    true = model
    if length_std or angle_std:
        names = perturb_names(model, params)
        std = np.array(
            [length_std if n.startswith(("dd", "dr")) else angle_std for n in names]
        )
        drawn = std * rng_kin.standard_normal(len(names))
        keep = std > 0
        kept = [n for n, k in zip(names, keep, strict=True) if k]
        if kept:
            true = apply_deltas(true, kept, drawn[keep])
        deltas = dict(zip(kept, drawn[keep].tolist(), strict=True))
        if not kept and not (dynamics_std or stiffness_std):
            raise ValueError(
                f"nothing to perturb: no parameter of {params!r} has a std > 0 "
                "(lengths dd, dr: length_std; angles: angle_std; compliances c<j> "
                "are not drawn)"
            )
    if dynamics_std:
        chi = _perturb_dynamics(model.dynamics, dynamics_std, rng_dyn)
        true = true.with_dynamics(chi.reshape(model.n_joints, N_PER_LINK))
    if stiffness_std:
        c = model.compliance
        factor = np.exp(stiffness_std * rng_k.standard_normal(model.n_joints))
        factor = np.where(c.elastic, factor, 1.0)
        true = dataclasses.replace(
            true,
            compliance=Compliance(c.stiffness * factor, damping=c.damping * factor),
        )
    name = f"{model.name}_true" if name is None else str(name)
    return dataclasses.replace(true, name=name), deltas


def scale_dynamics(
    model: RobotModel, factors: Mapping[str, float], *, name: str | None = None
) -> RobotModel:
    """``model`` with named standard dynamic parameters multiplied by factors: a
    worn joint (``{"fv3": 1.5, "fc3": 1.5}``: joint 3's viscous and Coulomb
    friction 50 % higher), a heavier link, a replaced motor (``Ia<j>``).

    Args:
      model: a robot with dynamics.
      factors: parameter name (``XX1`` .. ``fc<n>``, the link-major standard
        names of :func:`~rmdrake.model.dynamic_parameters.parameter_names`) ->
        factor, finite and within [1 / :data:`MAX_SCALE_FACTOR`,
        :data:`MAX_SCALE_FACTOR`].
      name: the result's name (default ``model``'s).

    Raises:
      ValueError: (one line) no dynamics, an unknown name, a factor not finite,
        <= 0 or beyond :data:`MAX_SCALE_FACTOR` either way, or a link that the
        scaling makes fail a physical check it passed
        (:func:`~rmdrake.model.dynamic_parameters.check_physical`).
    """
    if model.dynamics is None:
        raise ValueError(f"robot '{model.name}' has no dynamics to scale")
    names = parameter_names(model.n_joints)
    chi = np.array(model.dynamics, dtype=np.float64).ravel()
    for key, factor in factors.items():
        if key not in names:
            raise ValueError(
                f"scale {key}: not a dynamic parameter of '{model.name}' (expected "
                f"one of {names[0]} .. {names[-1]}, e.g. fv3, fc3, Ia2, M4)"
            )
        if not (math.isfinite(factor) and factor > 0):
            raise ValueError(f"scale {key}: expected a factor > 0, found {factor!r}")
        if not 1.0 / MAX_SCALE_FACTOR <= factor <= MAX_SCALE_FACTOR:
            raise ValueError(
                f"scale {key}={factor:g}: beyond the bound of a factor between "
                f"1/{MAX_SCALE_FACTOR:g} and {MAX_SCALE_FACTOR:g} (no longer the "
                "same robot; a worn joint's friction is fv<j>=1.5)"
            )
        chi[names.index(key)] *= factor
    links = chi.reshape(model.n_joints, N_PER_LINK)
    for j, (before, after) in enumerate(
        zip(np.asarray(model.dynamics), links, strict=True)
    ):
        broken = _failed_checks(after) - _failed_checks(before)
        if broken:
            raise ValueError(
                f"scale: link {j + 1} fails {', '.join(sorted(broken))} once scaled"
            )
    scaled = model.with_dynamics(links)
    return scaled if name is None else dataclasses.replace(scaled, name=str(name))


def _failed_checks(link: np.ndarray) -> set[str]:
    """The checks of :func:`check_physical` one link (13,) fails."""
    return {check for _, check, _ in check_physical(link[None, :]).failures}


def _perturb_dynamics(
    chi: np.ndarray, std: float, rng: np.random.Generator
) -> np.ndarray:
    """(13n,) ``chi`` with every entry times 1 + std N(0, 1), each link drawn
    again until it passes every physical check its nominal passes."""
    links = np.asarray(chi, dtype=np.float64).reshape(-1, N_PER_LINK)
    out = links.copy()
    for j, nominal in enumerate(links):
        allowed = _failed_checks(nominal)
        for _ in range(MAX_DYNAMICS_TRIES):
            draw = nominal * (1.0 + std * rng.standard_normal(N_PER_LINK))
            if _failed_checks(draw) <= allowed:
                out[j] = draw
                break
        else:
            raise ValueError(
                f"dynamics_std {std:g}: no physically consistent draw of link "
                f"{j + 1} in {MAX_DYNAMICS_TRIES} tries; use a smaller std"
            )
    return out.ravel()
