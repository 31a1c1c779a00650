"""Kinematic calibration from 6-DoF pose measurements: :class:`PoseLM`.

The estimator follows the contract of
:class:`~rmdrake.calibration.points.lm.PointLM` (``__init__`` stores options,
``fit(data)`` checks the data and returns self, results end in ``_``; then
``record``, ``check``, ``summary``, ``predict``). Unknowns: the error
parameters (``dalpha<j>`` .. ``dbeta<j>``, rad or m), the instrument pose
X_IB (pose of the base B in the instrument frame I) and the marker pose X_FM
(pose of the marker M in the flange F)
(:class:`~rmdrake.calibration.poses.problem.PoseProblem`). Steps:

1. checks: :func:`~rmdrake.calibration.poses.checks.check_pose_measurements`;
2. start with no prior: the hand-eye
   :func:`~rmdrake.calibration.poses.problem.initial_alignment` on the nominal
   model, then Levenberg-Marquardt with X_IB and X_FM only (the nominal
   model's best fit);
3. noises: the declared ``noise_p`` (m) and ``noise_r`` (rad) weight the
   position and angle residuals; an undeclared one is estimated from the
   residuals of the identifiable ``full`` set, re-weighted until it settles
   (the weights of the two blocks are variance components; the nominal
   model's residuals would hold its kinematic errors too);
4. the parameter set (``params``: ``auto`` chosen by K-fold cross-validation
   over the readings and the one-SE rule,
   :func:`~rmdrake.calibration.poses.selection.select_parameters`; ``base``,
   ``offsets``, ``full`` (their identifiable subsets) or names, which must
   all be identifiable,
   :func:`~rmdrake.calibration.poses.identifiability.analyse_pose_identifiability`);
5. Levenberg-Marquardt on every unknown (MINPACK ``lm`` through
   :func:`~rmdrake.calibration.lm.solve_lm`; ``trf`` with a robust
   loss, ``f_scale`` in noise units);
6. standard deviations of every unknown
   (:func:`~rmdrake.calibration.lm.least_squares_std`), the
   ``calibration`` record on ``model_`` and the sanity report ``sanity_``
   (:func:`~rmdrake.calibration.poses.checks.check_pose_calibration`).

Residual figures: position errors |p_pred - p_meas| in m and angle errors
|Log(R_meas^T R_pred)| in rad, RMS over the readings.

Example::

    from rmdrake.calibration.poses.lm import PoseLM
    from rmdrake.calibration.poses.simulate import simulate_poses
    from rmdrake.model.loading import load_robot
    model = load_robot("rv3sb")
    sim = simulate_poses(model, poses=40, noise_p=2e-5, noise_r=5e-5, seed=1)
    est = PoseLM(model, params="full", noise_p=2e-5, noise_r=5e-5).fit(sim.data)
    print(est.summary())
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.calibration.identifiability import IdentifiabilityReport
from rmdrake.calibration.lm import (
    CALIBRATION_LOSSES,
    delta_lines,
    least_squares_std,
    solve_lm,
)
from rmdrake.calibration.parameters import joint_offset_names, resolve_parameters
from rmdrake.calibration.poses.checks import (
    check_pose_calibration,
    check_pose_measurements,
)
from rmdrake.calibration.poses.data import PoseMeasurements
from rmdrake.calibration.poses.identifiability import analyse_pose_identifiability
from rmdrake.calibration.poses.problem import (
    PoseProblem,
    initial_alignment,
    predict_poses,
)
from rmdrake.calibration.poses.so3 import so3_log_many
from rmdrake.calibration.sanity import CalibrationBounds, SanityReport
from rmdrake.kinematics.rotations import rpy_from_rotation
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)
from rmdrake.model.robot import RobotModel

__all__ = ["POSE_PRESETS", "PoseLM", "pose_errors"]

POSE_PRESETS: tuple[str, ...] = ("auto", "base", "offsets", "full")
"""Parameter presets of a pose calibration (as the points'): ``auto`` (chosen
by cross-validation), ``base`` (none: X_IB and X_FM only), ``offsets`` and
``full`` (their identifiable subsets)."""

_START_NOISE = (1e-4, 1e-4)
"""(m, rad): the weights of the first fit when a noise is not declared."""


def pose_errors(
    X_measured: np.ndarray, X_predicted: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """((N,) position errors |p_pred - p_meas| in m, (N,) angle errors
    |Log(R_meas^T R_pred)| in rad) of (N, 4, 4) measured and predicted poses."""
    Xm, Xp = np.asarray(X_measured), np.asarray(X_predicted)
    e_p = np.linalg.norm(Xp[:, :3, 3] - Xm[:, :3, 3], axis=1)
    R = np.swapaxes(Xm[:, :3, :3], -1, -2) @ Xp[:, :3, :3]
    return e_p, np.linalg.norm(so3_log_many(R), axis=1)


def measured_poses(data: PoseMeasurements) -> np.ndarray:
    """(N, 4, 4) the measured X_IM of the readings, m."""
    X = np.zeros((data.n_rows, 4, 4))
    X[:, :3, :3], X[:, :3, 3], X[:, 3, 3] = data.R_IM, data.p_IM, 1.0
    return X


class PoseLM:
    """Levenberg-Marquardt calibration from 6-DoF pose readings (see the
    module docstring).

    Args:
      model: the nominal robot (rigid joints).
      params: ``auto``, ``base``, ``offsets``, ``full`` or a list of names.
      noise_p: m, std of each position coordinate; None: estimated.
      noise_r: rad, std of each orientation component; None: estimated.
      loss, f_scale: scipy ``least_squares`` loss and its scale (in noise
        units: 3 = three standard deviations).
      folds, seed, repeats: the ``auto`` selection's K-fold CV.
      rtol: identifiability threshold.
      xtol, ftol, gtol, max_nfev: the solver's.
      max_steps: most stepwise additions of ``auto``; None = no limit but
        the 1 % gain rule (6-DoF readings see up to 4 R + 2 P - 6 parameters).

    The attributes are set by ``fit``.

    Attributes:
      names_, deltas_ (rad or m), std_: the error parameters.
      X_IB_, X_FM_: (4, 4) the fitted instrument and marker poses, m.
      X_IB_std_, X_FM_std_: (6,) std of [rotation (rad), translation (m)].
      sigma_p_, sigma_r_: the noises used (declared or estimated), m, rad.
      model_: the calibrated RobotModel with its ``calibration`` record.
      residual_rms_p_, residual_rms_r_: training RMS position (m) and angle
        (rad) errors; residual_rms_p_nominal_, residual_rms_r_nominal_: the
        nominal model's (X_IB and X_FM fitted).
      identifiability_, selection_ (``auto`` only), sanity_, result_,
      fit_time_ (s).

    >>> from rmdrake.model.loading import load_robot
    >>> from rmdrake.calibration.poses.simulate import simulate_poses
    >>> nominal = load_robot("rv3sb")
    >>> sim = simulate_poses(nominal, poses=20, noise_p=0.0, noise_r=0.0, seed=1)
    >>> est = PoseLM(nominal, params="offsets", noise_p=2e-5, noise_r=5e-5)
    >>> est = est.fit(sim.data)  # the nominal robot measured: deltas near zero
    >>> bool(abs(est.deltas_).max() < 1e-9), est.residual_rms_p_ < 1e-9
    (True, True)
    """

    method = "lm"
    sanity_bounds: CalibrationBounds | None = None

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "auto",
        noise_p: float | None = None,
        noise_r: float | None = None,
        loss: str = "linear",
        f_scale: float = 3.0,
        folds: int = 5,
        seed: int = 0,
        repeats: int = 1,
        rtol: float = 1e-6,
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
        max_nfev: int | None = None,
        max_steps: int | None = None,
        progress: bool = False,
    ) -> None:
        self.model = model
        self.params = params
        self.noise_p = noise_p
        self.noise_r = noise_r
        self.loss = loss
        self.f_scale = f_scale
        self.folds = folds
        self.seed = seed
        self.repeats = repeats
        self.rtol = rtol
        self.xtol = xtol
        self.ftol = ftol
        self.gtol = gtol
        self.max_nfev = max_nfev
        self.max_steps = max_steps
        self.progress = progress

    # -- the pieces of fit -------------------------------------------------------
    def _problem(
        self,
        data: PoseMeasurements,
        names: Sequence[str],
        X_IB: np.ndarray,
        X_FM: np.ndarray,
        scales: tuple[float, float],
    ) -> PoseProblem:
        m = self.model
        return PoseProblem(
            m.table,
            data,
            error_parameter_indices(m, names),
            X_IB[:3, :3],
            X_FM[:3, :3],
            sigma_p=scales[0],
            sigma_r=scales[1],
            sigma=m.sigma,
        )

    def _fit_from(
        self,
        data: PoseMeasurements,
        names: Sequence[str],
        X_IB: np.ndarray,
        X_FM: np.ndarray,
        scales: tuple[float, float],
        deltas: np.ndarray | None = None,
    ) -> tuple[PoseProblem, Any]:
        problem = self._problem(data, names, X_IB, X_FM, scales)
        d = np.zeros(len(names)) if deltas is None else deltas
        result = solve_lm(problem, problem.pack(d, X_IB[:3, 3], X_FM[:3, 3]), self)
        return problem, result

    def _scales(
        self, problem: PoseProblem, x: np.ndarray, fallback: tuple[float, float]
    ) -> tuple[float, float]:
        """The declared noises, the undeclared ones estimated from the
        residuals at x (RSS of the block over its share of the dof)."""
        e_p, e_r = problem.errors(x)
        dof_share = max(1.0 - problem.n_unknowns / (6 * e_p.shape[0]), 1e-3)
        est_p = float(np.sqrt(np.mean(e_p**2) / dof_share)) or fallback[0]
        est_r = float(np.sqrt(np.mean(e_r**2) / dof_share)) or fallback[1]
        return (
            self.noise_p if self.noise_p is not None else max(est_p, 1e-12),
            self.noise_r if self.noise_r is not None else max(est_r, 1e-12),
        )

    def _start(self, data: PoseMeasurements) -> tuple:
        """(X_IB, X_FM) of the nominal model's best fit, the noises (declared,
        or estimated from it) and its RMS position (m) and angle (rad).
        Shared by the candidates of ``auto`` (the same training sets recur in
        every candidate's cross-validation): memoised in ``_starts`` on the
        data's content when the estimator has one."""
        cache = getattr(self, "_starts", None)
        key = (data.q.tobytes(), data.p_IM.tobytes(), data.r_IM.tobytes())
        if cache is not None and key in cache:
            return cache[key]
        model = self.model
        X_IB, X_FM = initial_alignment(model.table, data, sigma=model.sigma)
        scales = (
            self.noise_p if self.noise_p is not None else _START_NOISE[0],
            self.noise_r if self.noise_r is not None else _START_NOISE[1],
        )
        problem, result = self._fit_from(data, [], X_IB, X_FM, scales)
        _, X_IB, X_FM = problem.unpack(result.x)
        e_p, e_r = problem.errors(result.x)
        scales = self._scales(problem, result.x, scales)
        rms = (
            float(np.sqrt(np.mean(np.sum(e_p**2, 1)))),
            float(np.sqrt(np.mean(np.sum(e_r**2, 1)))),
        )
        out = (X_IB, X_FM, scales, rms)
        if cache is not None:
            cache[key] = out
        return out

    def _noise_scales(
        self, data: PoseMeasurements, start: tuple, scales: tuple[float, float]
    ) -> tuple[float, float]:
        """The declared noises; an undeclared one estimated from the residuals
        of the identifiable ``full`` set (the richest model: the nominal's
        residuals hold its kinematic errors too), re-weighted until the
        estimates change by less than 1 % (at most 10 fits)."""
        if self.noise_p is not None and self.noise_r is not None:
            return scales
        X_IB, X_FM = start
        names = analyse_pose_identifiability(
            self.model,
            data,
            error_parameter_names(self.model, "full"),
            rtol=self.rtol,
            start=start,
            sigma_p=scales[0],
            sigma_r=scales[1],
        ).identifiable
        if 6 * data.n_rows < len(names) + 12 + 5:
            return scales  # too few readings: the nominal fit's estimates
        deltas = None
        for _ in range(10):
            problem, result = self._fit_from(data, names, X_IB, X_FM, scales, deltas)
            deltas, X_IB, X_FM = problem.unpack(result.x)
            new = self._scales(problem, result.x, scales)
            if np.allclose(new, scales, rtol=1e-2, atol=0):
                return new
            scales = new
        return scales

    def _with(self, names: Sequence[str], scales: tuple[float, float]) -> PoseLM:
        """A candidate of ``auto``: this estimator's options, explicit names,
        the noises fixed, the memoised starts shared."""
        est = PoseLM(
            self.model,
            params=list(names),
            noise_p=scales[0],
            noise_r=scales[1],
            loss=self.loss,
            f_scale=self.f_scale,
            rtol=self.rtol,
            xtol=self.xtol,
            ftol=self.ftol,
            gtol=self.gtol,
            max_nfev=self.max_nfev,
        )
        est._starts = getattr(self, "_starts", None)
        return est

    def _candidates(self) -> tuple[list[str], bool]:
        """(candidate names, preset): a preset keeps its identifiable subset."""
        model, p = self.model, self.params
        if not isinstance(p, str):
            return list(p), False
        if p in ("base", "offsets", "full"):
            return {
                "base": [],
                "offsets": joint_offset_names(model),
                "full": error_parameter_names(model, "full"),
            }[p], True
        return resolve_parameters(model, p), False

    def _names(
        self, data: PoseMeasurements, start: tuple, scales: tuple[float, float]
    ) -> list[str]:
        if isinstance(self.params, str) and self.params == "auto":
            from rmdrake.calibration.poses.selection import select_parameters

            self._starts: dict | None = {}  # the candidates' shared starts
            self.selection_ = select_parameters(
                lambda names: self._with(names, scales),
                data,
                scales,
                folds=self.folds,
                seed=self.seed,
                repeats=self.repeats,
                max_steps=self.max_steps,
                progress=self.progress,
            )
            self._starts = None
            names, preset = list(self.selection_.chosen), True
        else:
            names, preset = self._candidates()
        if not names:
            self.identifiability_ = IdentifiabilityReport(
                names=[],
                identifiable=[],
                dropped={},
                rank=0,
                n_plate_unknowns=12,
                nuisance="instrument pose and marker pose",
                condition_number=float("nan"),
                residuals={},
                combinations=[],
                rtol=float(self.rtol),
            )
            return []
        report = analyse_pose_identifiability(
            self.model,
            data,
            names,
            rtol=self.rtol,
            start=start,
            sigma_p=scales[0],
            sigma_r=scales[1],
        )
        self.identifiability_ = report
        if not preset and report.dropped:
            name, why = next(iter(report.dropped.items()))
            raise ValueError(
                f"{len(report.dropped)} parameter(s) not identifiable from pose "
                f"readings ({', '.join(report.dropped)}): {name} is {why}; drop them "
                "or use the preset full"
            )
        names = report.identifiable
        if 6 * data.n_rows < len(names) + 12 + 5:
            need = int(np.ceil((len(names) + 17) / 6))
            raise ValueError(
                f"{data.n_rows} poses cannot identify {len(names)} parameters, X_IB "
                f"and X_FM ({len(names) + 12} unknowns and 5 dof to check them): "
                f"measure at least {need} poses or name fewer parameters"
            )
        return names

    def fit(self, data: PoseMeasurements) -> PoseLM:
        """Calibrates from the measured poses; returns self."""
        t0 = time.perf_counter()
        if self.loss not in CALIBRATION_LOSSES or not 0 < self.f_scale <= 1e3:
            raise ValueError(
                f"loss, f_scale: expected one of {', '.join(CALIBRATION_LOSSES)} and "
                f"a scale in (0, 1000] noise units, found {self.loss!r}, "
                f"{self.f_scale:g}"
            )
        check_pose_measurements(data, self.model)
        X_IB, X_FM, scales, self._nominal_rms = self._start(data)
        scales = self._noise_scales(data, (X_IB, X_FM), scales)
        names = self._names(data, (X_IB, X_FM), scales)
        problem, result = self._fit_from(data, names, X_IB, X_FM, scales)
        self._finish(data, names, problem, result, t0)
        return self

    def _finish(
        self,
        data: PoseMeasurements,
        names: list[str],
        problem: PoseProblem,
        result: Any,
        t0: float,
    ) -> None:
        x, k = result.x, len(names)
        deltas, self.X_IB_, self.X_FM_ = problem.unpack(x)
        self.names_, self.deltas_ = list(names), deltas.copy()
        self.sigma_p_, self.sigma_r_ = problem.sigma_p, problem.sigma_r
        self.result_ = result
        if getattr(self, "_starts", None) is not None:
            return  # a candidate of ``auto``, fitted only to predict held-out poses
        self.data_ = data
        self._problem_, self._x = problem, x
        std = least_squares_std(problem.jacobian(x), result.fun)
        self.std_ = std[:k]
        self.X_IB_std_, self.X_FM_std_ = std[k : k + 6], std[k + 6 :]
        e_p, e_r = problem.errors(x)
        self.residuals_p_, self.residuals_r_ = e_p, e_r
        self.residual_rms_p_ = float(np.sqrt(np.mean(np.sum(e_p**2, 1))))
        self.residual_rms_r_ = float(np.sqrt(np.mean(np.sum(e_r**2, 1))))
        self.residual_rms_p_nominal_, self.residual_rms_r_nominal_ = self._nominal_rms
        self.sanity_ = self.check()
        self.fit_time_ = time.perf_counter() - t0
        self.model_ = dataclasses.replace(
            apply_deltas(self.model, names, self.deltas_), calibration=self.record()
        )

    # -- the public interface after fit -------------------------------------------
    def predict(self, data: PoseMeasurements) -> np.ndarray:
        """(N, 4, 4) predicted readings X_IM (m, in I) of the rows of ``data``
        by the calibrated model, X_IB and X_FM (after fit)."""
        m = apply_deltas(self.model, self.names_, self.deltas_)
        return predict_poses(m.table, data.q, self.X_IB_, self.X_FM_, sigma=m.sigma)

    def pose_errors(self, data: PoseMeasurements) -> tuple[np.ndarray, np.ndarray]:
        """((N,) position errors in m, (N,) angle errors in rad) of the
        calibrated prediction of the rows of ``data`` against their readings."""
        return pose_errors(measured_poses(data), self.predict(data))

    def check(
        self,
        noise: tuple[float, float] | None = None,
        bounds: CalibrationBounds | None = None,
    ) -> SanityReport:
        """The sanity checks of the fit against declared noises (sigma_p m,
        sigma_r rad; None: this estimator's, estimated when undeclared) and
        ``bounds``; the fit's own ``sanity_`` is this with the defaults."""
        problem, source = self._problem_, self._noise_source()
        declared = self.noise_p is not None or self.noise_r is not None
        if noise is not None:
            problem = PoseProblem(
                problem.table,
                self.data_,
                problem.indices,
                problem.R0_IB,
                problem.R0_FM,
                sigma_p=noise[0],
                sigma_r=noise[1],
                sigma=problem.sigma,
            )
            declared, source = True, "declared"
        return check_pose_calibration(
            problem,
            self._x,
            self.names_,
            declared=declared,
            source=source,
            bounds=bounds or self.sanity_bounds,
        )

    def _noise_source(self) -> str:
        """``declared``, ``estimated`` or which of the two noises is which."""
        p, r = self.noise_p is not None, self.noise_r is not None
        if p == r:
            return "declared" if p else "estimated"
        return (
            "position declared, angle estimated"
            if p
            else ("angle declared, position estimated")
        )

    def record(self) -> dict[str, Any]:
        """The ``calibration`` record of the fit (no wall time: the same data
        and options give the same record)."""
        report = self.identifiability_

        def pose(X: np.ndarray) -> dict[str, list[float]]:
            return {
                "xyz": X[:3, 3].tolist(),
                "rpy": rpy_from_rotation(X[None, :3, :3])[0].tolist(),
            }

        def spread(s: np.ndarray) -> dict[str, list[float]]:
            return {"rotation": s[:3].tolist(), "xyz": s[3:].tolist()}

        record: dict[str, Any] = {
            "kind": "pose kinematic calibration (6-DoF tracker or camera)",
            "method": self.method,
            "parameters": {
                n: {"delta": float(d), "std": float(s)}
                for n, d, s in zip(self.names_, self.deltas_, self.std_, strict=True)
            },
            "units": "deltas and std in rad (dalpha, dtheta, dbeta) or m (dd, dr); "
            "X_IB and X_FM xyz in m, rpy in rad (Drake RollPitchYaw); position "
            "residuals in m, angle residuals in rad",
            "X_IB": pose(self.X_IB_),
            "X_IB_std": spread(self.X_IB_std_),
            "X_FM": pose(self.X_FM_),
            "X_FM_std": spread(self.X_FM_std_),
            "noise": {
                "position": self.sigma_p_,
                "angle": self.sigma_r_,
                "source": self._noise_source(),
            },
            "residual_rms_position": self.residual_rms_p_,
            "residual_rms_angle": self.residual_rms_r_,
            "residual_rms_position_nominal": self.residual_rms_p_nominal_,
            "residual_rms_angle_nominal": self.residual_rms_r_nominal_,
            "rank": report.rank,
            "condition_number": report.condition_number,
            "dropped": dict(report.dropped),
            "data": {"poses": self.data_.n_rows},
            "base_model": self.model.name,
            "options": {"params": self._params_text(), "loss": self.loss},
        }
        if self.loss != "linear":
            record["options"]["f_scale"] = self.f_scale
        if hasattr(self, "selection_"):
            record["selection"] = self.selection_.record()
        return record

    def _params_text(self) -> str:
        p = self.params
        return p if isinstance(p, str) else ",".join(p)

    def summary(self) -> str:
        """Human-readable result (after fit)."""
        report = self.identifiability_
        lines = []
        if hasattr(self, "selection_"):
            lines += self.selection_.summary_lines()
        lines += [
            f"method {self.method} on poses: {len(self.names_)} parameters, rank "
            f"{report.rank}, condition number {report.condition_number:.3g}, "
            f"{self.fit_time_:.3f} s",
            f"training position error: RMS {self.residual_rms_p_nominal_ * 1e3:.4g} mm "
            f"(nominal, X_IB and X_FM fitted) -> {self.residual_rms_p_ * 1e3:.4g} mm",
            f"training angle error: RMS {self.residual_rms_r_nominal_ * 1e3:.4g} mrad "
            f"-> {self.residual_rms_r_ * 1e3:.4g} mrad",
            *delta_lines(self.names_, self.deltas_, self.std_),
        ]
        for name, X in (("instrument X_IB", self.X_IB_), ("marker X_FM", self.X_FM_)):
            xyz = ", ".join(f"{v:.4f}" for v in X[:3, 3])
            rpy = ", ".join(f"{v:.4f}" for v in rpy_from_rotation(X[None, :3, :3])[0])
            lines.append(f"{name}: xyz ({xyz}) m, rpy ({rpy}) rad")
        lines.append(self.sanity_.summary())
        return "\n".join(lines)
