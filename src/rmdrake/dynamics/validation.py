"""Held-out validation of dynamic models: how well each predicts logged torques.

For each model k and joint j, on prepared samples (:class:`JointSamples`, made
by :func:`rmdrake.dynamics.data.prepare_samples` as for identification)::

    tau_hat_k = Y_k(q, qd, qdd) @ chi_k          (N m, or N on a prismatic joint)
    rms_kj = sqrt(mean_i (tau_hat_k,ij - tau_ij)^2)
    relative_kj = rms_kj / sqrt(mean_i tau_ij^2)

with Y_k the regressor of model k's kinematics (:func:`rmdrake.dynamics.regressor`,
friction included with the Coulomb sign of ``coulomb_width``) and chi_k its
extended parameters (:func:`rmdrake.model.dynamic_parameters.extended_parameters`:
the standard ones with the payload folded in, then the negative-velocity
Coulomb level fcn and the torque offset tau0 of the robot's model terms): the
torques the station's true robot logs for that model.

Models that share their kinematics (an identified robot and its prior, say)
share one regressor. The samples are processed in blocks
(:func:`rmdrake.dynamics.regressor.regressor_blocks`) into one reused buffer,
so memory stays bounded on long logs and there is no Python loop per sample.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from rmdrake.dynamics.chain import SerialChain
from rmdrake.dynamics.data import JointSamples
from rmdrake.dynamics.regressor import regressor_blocks
from rmdrake.model.dynamic_parameters import extended_parameters
from rmdrake.model.robot import RobotModel

__all__ = ["TorqueErrors", "check_models", "predict_torques", "torque_errors"]


@dataclasses.dataclass(frozen=True)
class TorqueErrors:
    """Per-joint prediction errors of one or several models on one set of samples.

    Attributes:
      labels: m model labels, in the order of the rows below.
      rms: (m, n) RMS of predicted minus measured effort, N m (N on a
        prismatic joint).
      measured_rms: (n,) RMS of the measured effort, N m or N.
      relative: (m, n) ``rms / measured_rms`` (NaN where the measured RMS is 0).
      predicted: (m, N, n) the predicted efforts, N m or N.
      sigma: (n,) joint types, 0 revolute, 1 prismatic (for the units).
    """

    labels: tuple[str, ...]
    rms: np.ndarray
    measured_rms: np.ndarray
    relative: np.ndarray
    predicted: np.ndarray
    sigma: np.ndarray

    @property
    def mean_rms(self) -> np.ndarray:
        """(m,) mean over joints of :attr:`rms` (N m and N mixed if any joint
        is prismatic)."""
        return self.rms.mean(axis=1)

    @property
    def mean_relative(self) -> np.ndarray:
        """(m,) mean over joints of :attr:`relative` (NaN joints left out)."""
        ok = np.isfinite(self.relative)
        count = ok.sum(axis=1)
        total = np.where(ok, self.relative, 0.0).sum(axis=1)
        return np.divide(
            total, count, out=np.full(count.shape, np.nan), where=count > 0
        )

    def table(self) -> list[str]:
        """The figures as text lines: one row per joint (unit, measured RMS,
        then per model ``RMS (relative %)``), and a ``mean`` row."""
        heads = [f"{lab} RMS (rel.)" for lab in self.labels]
        rows = [
            [
                _cell(e, r)
                for e, r in zip(self.rms[:, j], self.relative[:, j], strict=True)
            ]
            for j in range(len(self.sigma))
        ]
        means = [
            _cell(e, r) for e, r in zip(self.mean_rms, self.mean_relative, strict=True)
        ]
        # two spaces at least between columns, however wide a figure is
        width = max(22, *(len(c) + 2 for c in [*heads, *means, *sum(rows, [])]))
        measured = [f"{m:.5g}" for m in self.measured_rms]
        mwidth = max(14, *(len(m) + 2 for m in measured))
        head = f"{'joint':<6}{'unit':<5}{'measured RMS':>{mwidth}}"
        lines = [head + "".join(f"{c:>{width}}" for c in heads)]
        for j, s in enumerate(self.sigma):
            row = f"{j + 1:<6}{'N' if s else 'N m':<5}{measured[j]:>{mwidth}}"
            lines.append(row + "".join(f"{c:>{width}}" for c in rows[j]))
        mean = f"{'mean':<11}{np.mean(self.measured_rms):>{mwidth}.5g}"
        mean += "".join(f"{c:>{width}}" for c in means)
        return [*lines, mean]


def _cell(rms: float, relative: float) -> str:
    rel = "n/a" if not np.isfinite(relative) else f"{100 * relative:.3g} %"
    return f"{rms:.4g} ({rel})"


def check_models(models: Mapping[str, RobotModel], n_joints: int | None = None) -> int:
    """The common joint count of ``models`` (label -> model), after checking that
    each has dynamics and the same joint count (``n_joints`` if given, the log's)
    and joint types.

    Raises:
      ValueError: one line naming the model (and the log's joint count).
    """
    if not models:
        raise ValueError("robots: expected at least one robot to validate")
    for label, model in models.items():
        if model.dynamics is None:
            raise ValueError(
                f"robot {label}: has no 'dynamics' section; nothing to validate "
                "(identify it first)"
            )
    counts = {label: m.n_joints for label, m in models.items()}
    if len(set(counts.values())) > 1:
        found = ", ".join(f"{lab} {n}" for lab, n in counts.items())
        raise ValueError(f"robots: expected one joint count, found {found}")
    n = next(iter(counts.values()))
    first, *rest = models.items()
    for label, model in rest:
        if not np.array_equal(model.sigma, first[1].sigma):
            raise ValueError(
                f"robots: {label} and {first[0]} differ in joint types (sigma "
                f"{list(model.sigma)} vs {list(first[1].sigma)})"
            )
    if n_joints is not None and n_joints != n:
        raise ValueError(f"log has {n_joints} joints, the robots {n}")
    return n


def _kinematics_key(model: RobotModel) -> tuple:
    """What the regressor of ``model`` depends on (its chain), hashable."""
    c = SerialChain.from_model(model)
    coupling = np.zeros(0) if c.coupling is None else c.coupling
    arrays = (c.X_PF, c.axis, c.X_CM, c.gravity, np.asarray(c.prismatic, bool))
    arrays += (coupling,)  # coupled motors: their own columns
    return tuple(np.ascontiguousarray(a, dtype=np.float64).tobytes() for a in arrays)


def predict_torques(
    models: Sequence[RobotModel],
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    *,
    coulomb_width: float = 0.0,
) -> np.ndarray:
    """The efforts each model predicts, (m, N, n) in N m or N.

    Args:
      models: m robots with ``dynamics``, n joints each.
      q, qd, qdd: (N, n) joint positions (rad or m), velocities and
        accelerations.
      coulomb_width: the Coulomb sign's width, rad/s or m/s (0: sign(qd)).
    """
    q, qd, qdd = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd))
    N, n = q.shape
    groups: dict[tuple, list[int]] = {}
    for k, model in enumerate(models):
        groups.setdefault(_kinematics_key(model), []).append(k)
    out = np.empty((len(models), N, n))
    for ks in groups.values():
        chain = SerialChain.from_model(models[ks[0]])
        chi = np.stack([extended_parameters(models[k]) for k in ks], axis=1)
        blocks = regressor_blocks(
            chain,
            q,
            qd,
            qdd,
            np.arange(chi.shape[0]),
            coulomb_width=coulomb_width,
            asymmetric=True,
        )
        for s, Y in blocks:
            out[ks, s] = np.moveaxis(Y @ chi, 2, 0)  # (b, n, g) -> (g, b, n)
    return out


def torque_errors(
    models: Mapping[str, RobotModel],
    samples: JointSamples,
    *,
    coulomb_width: float = 0.0,
) -> TorqueErrors:
    """Per-joint RMS and relative RMS errors of each model's predicted efforts
    against ``samples.tau`` (see the module docstring).

    Args:
      models: label -> robot with ``dynamics``; all with ``samples.n_joints``
        joints.
      samples: prepared samples (:func:`rmdrake.dynamics.data.prepare_samples`).
      coulomb_width: the Coulomb sign's width, rad/s or m/s (0: sign(qd)); the
        one the models were identified with.

    Raises:
      ValueError: a model without dynamics, or joint counts that differ.
    """
    check_models(models, samples.n_joints)
    ordered = list(models.values())
    predicted = predict_torques(
        ordered, samples.q, samples.qd, samples.qdd, coulomb_width=coulomb_width
    )
    rms = np.sqrt(np.mean((predicted - samples.tau) ** 2, axis=1))
    measured = np.sqrt(np.mean(samples.tau**2, axis=0))
    relative = np.divide(
        rms, measured, out=np.full(rms.shape, np.nan), where=measured > 0
    )
    return TorqueErrors(
        labels=tuple(models),
        rms=rms,
        measured_rms=measured,
        relative=relative,
        predicted=predicted,
        sigma=np.asarray(ordered[0].sigma, dtype=int),
    )
