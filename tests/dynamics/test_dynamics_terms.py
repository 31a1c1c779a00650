"""The dynamic terms a robot really has (issue 12 item 4): rotor inertia,
viscous and Coulomb friction chosen per robot, constant offsets and asymmetric
Coulomb friction.

Oracles: the numeric rank (SVD) of the chosen columns at random states for the
base-parameter counts; Drake's CalcInverseDynamics plus the friction/offset law
written out here with np.where for the regressor (1e-9 relative); known truth
for noise-free identification (1e-9).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_dynamics_regressor import drake_inverse_dynamics

from rmdrake.dynamics import base_parameters, regressor, torques
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.friction import friction_torque
from rmdrake.dynamics.identification import identified_model, identify
from rmdrake.model.dynamic_parameters import (
    extended_names,
    extended_parameters,
    term_columns,
)
from rmdrake.model.loading import load_robot
from rmdrake.model.plant import MakePlant
from rmdrake.model.robot import DynamicTerms, RobotModel

T = DynamicTerms
CHOICES = {
    "default": T(),
    "no-rotor": T(rotor_inertia=False),
    "offset": T(offset=True),
    "no-rotor,offset": T(rotor_inertia=False, offset=True),
    "asymmetric": T(coulomb_asymmetric=True),
    "asymmetric,offset": T(coulomb_asymmetric=True, offset=True),
    "rigid": T(rotor_inertia=False, viscous=False, coulomb=False),
}


def _with_extras(model: RobotModel, rng) -> RobotModel:
    n = model.n_joints
    fc = model.dynamics[:, 12]
    return dataclasses.replace(
        model,
        fcn=fc * rng.uniform(0.5, 1.5, n) + 0.1,
        tau0=rng.uniform(-2.0, 2.0, n),
    )


def _law(model: RobotModel, qd: np.ndarray) -> np.ndarray:
    """Friction + offset written out independently of rmdrake's law."""
    d = model.dynamics
    coulomb = np.where(qd > 0, d[:, 12], np.where(qd < 0, -model.fcn, 0.0))
    return d[:, 11] * qd + coulomb + model.tau0


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
@pytest.mark.parametrize("choice", list(CHOICES))
def test_base_count_equals_numeric_rank(robot, choice, request):
    """The base-parameter count of each choice of terms equals the SVD rank of
    the chosen regressor columns at random states, and K regroups exactly."""
    model = load_robot(robot) if robot == "rv3sb" else request.getfixturevalue(robot)
    terms = CHOICES[choice]
    base = base_parameters(model, terms=terms)
    n = model.n_joints
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.uniform(-2, 2, (3, 150, n))
    cols = term_columns(n, terms)
    asym = terms.coulomb_asymmetric
    W = regressor(model, q, qd, qdd, cols, asymmetric=asym).reshape(-1, cols.size)
    norms = np.linalg.norm(W, axis=0)
    W = W[:, norms > 1e-9 * norms.max()]  # columns that never act: round-off
    s = np.linalg.svd(W / np.linalg.norm(W, axis=0), compute_uv=False)
    assert s[base.count - 1] > 1e-6 * s[0]  # a clear gap at the count
    assert s[base.count :].max(initial=0.0) < 1e-11 * s[0]
    assert base.count == int(np.sum(s > 1e-9 * s[0]))
    chi = rng.standard_normal(base.width)
    Ystd = regressor(model, q[:20], qd[:20], qdd[:20], cols, asymmetric=asym)
    tau_base = base.regressor(model, q[:20], qd[:20], qdd[:20]) @ (base.K_full @ chi)
    np.testing.assert_allclose(
        tau_base, Ystd @ chi[cols], rtol=0, atol=1e-9 * abs(tau_base).max()
    )


def test_counts_relations(rv3sb, boom):
    """Offsets and asymmetric Coulomb each add one base parameter per joint; both
    together also one (fc+, fc- and an offset are two values when moving). On
    the boom arm the vertical slide (joint 1) carries the constant weight of
    the arm: with its Ia (kg) the columns qdd_1 + g and qdd_1 span the offset's
    constant, one fewer there; without Ia, all six offsets count."""
    want = {
        "rv3sb": (52, 48, 58, 54, 58, 58, 36),
        "boom_arm": (45, 41, 50, 47, 50, 50, 29),
    }
    for model in (rv3sb, boom):
        c = tuple(base_parameters(model, terms=t).count for t in CHOICES.values())
        assert c == want[model.name]
    assert base_parameters(rv3sb, terms=T()).count == 52
    assert base_parameters(rv3sb, terms=CHOICES["rigid"]).count == 36


@pytest.mark.parametrize("robot", ["rv3sb", "boom"])
def test_regressor_with_terms_matches_drake(robot, request):
    """Y_ext @ chi_ext == Drake's inverse dynamics + fv qd + asymmetric Coulomb +
    offset, and torques() and friction_torque() agree with it (1e-9)."""
    model = load_robot(robot) if robot == "rv3sb" else request.getfixturevalue(robot)
    rng = np.random.default_rng(7)
    model = _with_extras(model, rng)
    n = model.n_joints
    q, qd, qdd = rng.uniform(-2, 2, (3, 8, n))
    qd[0, 1] = 0.0  # at rest: no Coulomb effort, only the offset
    plant, _ = MakePlant(model, visual=False)
    ref = drake_inverse_dynamics(plant, q, qd, qdd) + _law(model, qd)
    chi = extended_parameters(model)
    tau = torques(model, q, qd, qdd, chi)
    scale = np.abs(ref).max()
    assert np.max(np.abs(tau - ref)) < 1e-9 * scale
    d = model.dynamics
    law = friction_torque(qd, d[:, 11], d[:, 12], fcn=model.fcn, tau0=model.tau0)
    np.testing.assert_allclose(law, _law(model, qd), rtol=0, atol=1e-12)
    # Symmetric law when fcn = fc: the extended vector predicts as the 13.
    sym = dataclasses.replace(model, fcn=None, tau0=None)
    np.testing.assert_allclose(
        torques(sym, q, qd, qdd, extended_parameters(sym)),
        torques(sym, q, qd, qdd, chi[: 13 * n]),
        atol=1e-12 * scale,
    )
    assert extended_names(n)[13 * n] == "fcn1" and extended_names(n)[-1] == f"tau0{n}"


def _samples(model: RobotModel, rng, N=400) -> JointSamples:
    n = model.n_joints
    q, qd, qdd = rng.uniform(-2, 2, (3, N, n))
    tau = torques(model, q, qd, qdd, extended_parameters(model))
    return JointSamples(np.arange(N) / 100.0, q, qd, qdd, tau, 100.0)


@pytest.mark.parametrize("choice", ["no-rotor,offset", "asymmetric", "offset"])
def test_noise_free_identification_is_exact(rv3sb, choice, tmp_path):
    """Noise-free torques of a robot with the chosen terms (the others 0) give
    back its base parameters to 1e-9; the written YAML has the terms, fcn and
    tau0 where on, and predicts the data."""
    rng = np.random.default_rng(11)
    terms = CHOICES[choice]
    true = _with_extras(rv3sb, rng)
    d = true.dynamics.copy()
    if not terms.rotor_inertia:
        d[:, 10] = 0.0
    true = dataclasses.replace(
        true,
        dynamics=d,
        fcn=true.fcn if terms.coulomb_asymmetric else None,
        tau0=true.tau0 if terms.offset else None,
    )
    samples = _samples(true, rng)
    model = dataclasses.replace(rv3sb, terms=terms)
    result = identify(model, samples, method="ols")
    truth = result.base.K_full @ extended_parameters(true)[: result.base.width]
    np.testing.assert_allclose(
        result.params, truth, rtol=0, atol=1e-9 * abs(truth).max()
    )
    if terms.offset:
        names = list(result.base.names)
        for j in range(6):
            assert abs(result.params[names.index(f"tau0{j + 1}")] - true.tau0[j]) < 1e-9
    out = identified_model(model, result)
    again = load_robot(out.save(tmp_path / "id.yaml"))
    assert again.terms == terms
    assert (again.tau0 is not None) == terms.offset
    assert (again.fcn is not None) == terms.coulomb_asymmetric
    if not terms.rotor_inertia:
        assert np.all(again.dynamics[:, 10] == 0.0)
    pred = torques(
        again, samples.q, samples.qd, samples.qdd, extended_parameters(again)
    )
    np.testing.assert_allclose(pred, samples.tau, atol=1e-5 * abs(samples.tau).max())


def test_terms_text_and_yaml(rv3sb, tmp_path):
    """--terms syntax, the model: entry and the fcn/tau0 keys round-trip; bad
    entries are one-line errors naming the field."""
    assert T().with_text("no-rotor,offset") == T(rotor_inertia=False, offset=True)
    assert T().with_text("rotor_inertia=0, offset=1") == T(
        rotor_inertia=False, offset=True
    )
    assert T().with_text("asymmetric") == T(coulomb_asymmetric=True)
    assert T(coulomb_asymmetric=True).with_text("coulomb=0") == T(coulomb=False)
    for bad in ("rotr", "offset=2", "no-"):
        with pytest.raises(ValueError, match="terms"):
            T().with_text(bad)
    model = _with_extras(rv3sb, np.random.default_rng(1))
    model = dataclasses.replace(model, terms=T(offset=True, coulomb_asymmetric=True))
    again = load_robot(model.save(tmp_path / "r.yaml"))
    assert again.terms == model.terms
    assert again.tau0.tobytes() == model.tau0.tobytes()
    assert again.fcn.tobytes() == model.fcn.tobytes()
    assert again.to_yaml() == model.to_yaml()
    assert "model" not in rv3sb.to_dict() and rv3sb.dynamic_terms == T()
    data = rv3sb.to_dict()
    data["dynamics"][2]["tau0"] = 0.5  # one link only: the others 0
    part = RobotModel.from_dict(data)
    np.testing.assert_array_equal(part.tau0, [0, 0, 0.5, 0, 0, 0])
    assert part.fcn is None
    for edit, field in (
        (lambda d: d.update(model={"rotor": True}), "model: unknown key"),
        (lambda d: d.update(model={"offset": 1}), "model.offset: expected true"),
        (
            lambda d: d.update(model={"coulomb": False, "coulomb_asymmetric": True}),
            "model: coulomb_asymmetric needs",
        ),
        (lambda d: d["dynamics"][0].update(tau0="x"), r"dynamics\[0\].tau0"),
    ):
        data = rv3sb.to_dict()
        edit(data)
        with pytest.raises(ValueError, match=field) as e:
            RobotModel.from_dict(data)
        assert "\n" not in str(e.value)


def test_physical_fit_with_offsets_and_asymmetric_coulomb(rv3sb):
    """The physically consistent fit on the extended vector: noise-free data give
    the truth's base parameters to the solver's accuracy (1e-6 relative, as
    for the 13 per link), with fcn >= 0 in the written model."""
    rng = np.random.default_rng(11)
    true = _with_extras(rv3sb, rng)
    samples = _samples(true, rng)
    terms = T(offset=True, coulomb_asymmetric=True)
    model = dataclasses.replace(rv3sb, terms=terms)
    result = identify(model, samples, method="physical")
    truth = result.base.K_full @ extended_parameters(true)
    assert np.abs(result.params - truth).max() < 1e-6 * np.abs(truth).max()
    out = identified_model(model, result)
    assert out.terms == terms and np.all(out.fcn >= 0) and out.tau0 is not None


def test_contradictory_terms_are_refused():
    """`--terms no-rotor,rotor` used to take the last word silently."""
    from rmdrake.model.robot import DynamicTerms

    with pytest.raises(ValueError, match=r"'no-rotor' and 'rotor' contradict"):
        DynamicTerms().with_text("no-rotor,rotor")
    assert DynamicTerms().with_text("rotor,ia") == DynamicTerms()  # said twice
