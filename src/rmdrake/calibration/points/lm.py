"""Kinematic calibration from measured tool points (laser tracker, motion
capture): :class:`PointLM`.

The estimator follows the scikit-learn contract of the plate estimators
(``__init__`` stores options, ``fit(data)`` checks the data and returns self,
results end in ``_``). Unknowns: the error parameters (``dalpha<j>`` ..
``dbeta<j>``, rad or m), the instrument pose X_IB (pose of the base B in the
instrument frame I: a rotation increment and a translation) and each marker's
position p_EM in the tool frame E (:class:`~rmdrake.calibration.points.problem.
PointProblem`). Steps:

1. checks: :func:`~rmdrake.calibration.points.checks.check_point_measurements`;
   the parameter set (``params``: a preset of
   :data:`~rmdrake.calibration.parameters.POINT_PRESETS` or names) against
   :func:`~rmdrake.calibration.points.identifiability.analyse_point_identifiability`
   (presets keep their identifiable subset; named parameters must all be
   identifiable); enough points for the unknowns;
2. ``auto``: the parameter set chosen by K-fold cross-validation over the
   poses and the one-standard-error rule
   (:func:`~rmdrake.calibration.points.selection.select_parameters`; its
   candidate fits share their starts and skip the std and sanity checks);
3. start with no prior: :func:`~rmdrake.calibration.points.problem.
   initial_alignment` on the nominal model, then Levenberg-Marquardt with the
   base and markers only (the nominal model's best fit, whose residual is
   ``residual_rms_nominal_``), then with every unknown (MINPACK ``lm``;
   ``trf`` with a robust loss);
4. standard deviations sqrt(diag(sigma^2 (J^T J)^-1)) of every unknown
   (:func:`~rmdrake.calibration.lm.least_squares_std`), a
   ``calibration`` record on ``model_`` and the sanity report ``sanity_``
   (:func:`~rmdrake.calibration.points.checks.check_point_calibration`).

Elastostatic calibration (``compliance=True`` or ``c<j>`` names): the joint
compliances c_j follow the MDH parameters in ``names_`` and ``deltas_``, fitted
in the outer passes of :class:`~rmdrake.calibration.elastostatic.JointLoads`
as the plane calibration does (unidentifiable ones dropped with a
:class:`~rmdrake.calibration.elastostatic.ComplianceWarning`); ``auto``'s
candidates carry the compliances (one pass each) while it chooses the MDH set.

Residual figures are 3-D point errors |p_I,measured - p_I,predicted| in m:
``residual_rms_`` is sqrt(mean over points of |e|^2), ``residual_max_`` the
largest.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.calibration.config import CalibrationConfig, PointLMConfig
from rmdrake.calibration.elastostatic import (
    MAX_PASSES,
    ComplianceWarning,
    JointLoads,
    check_identified,
    elastic_record,
    with_compliances,
)
from rmdrake.calibration.lm import (
    check_loss,
    delta_lines,
    least_squares_std,
    solve_lm,
)
from rmdrake.calibration.parameters import (
    POINT_PRESETS,
    joint_offset_names,
    resolve_parameters,
)
from rmdrake.calibration.points.checks import (
    check_point_calibration,
    check_point_measurements,
)
from rmdrake.calibration.points.data import PointMeasurements
from rmdrake.calibration.points.identifiability import analyse_point_identifiability
from rmdrake.calibration.points.problem import (
    PointProblem,
    initial_alignment,
    predict_points,
)
from rmdrake.calibration.sanity import CalibrationBounds, SanityReport
from rmdrake.dynamics.compliance import link_angles
from rmdrake.kinematics.forward import robot_reach
from rmdrake.kinematics.rotations import rpy_from_rotation
from rmdrake.limits import check_memory
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_names,
    is_compliance_name,
)
from rmdrake.model.error_parameters import error_parameter_indices as _indices
from rmdrake.model.robot import RobotModel

__all__ = ["PointLM", "make_point_calibrator", "point_errors"]


def point_errors(measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """(N,) 3-D point errors |measured - predicted|, m."""
    return np.linalg.norm(np.asarray(measured) - np.asarray(predicted), axis=1)


def _candidates(model: RobotModel, params: str | Sequence[str]) -> list[str]:
    if not isinstance(params, str) and len(params) == 0:
        return []  # the nominal kinematics: instrument pose and markers only
    if isinstance(params, str) and params in ("base", "offsets", "full"):
        return {
            "base": [],
            "offsets": joint_offset_names(model),
            "full": error_parameter_names(model, "full"),
        }[params]
    if isinstance(params, str) and params not in POINT_PRESETS and "," not in params:
        if not params.startswith(("d", "c")):
            raise ValueError(
                f"unknown parameter preset '{params}' for point data: expected "
                f"{', '.join(POINT_PRESETS)} or a comma-separated list of names"
            )
    return resolve_parameters(model, params)


class PointLM:
    """Levenberg-Marquardt calibration from measured tool points (see the
    module docstring).

    Args:
      model: the nominal robot.
      params: ``auto`` (chosen by cross-validation), ``base``, ``offsets``,
        ``full`` (identifiable subsets) or a list of names (compliances
        ``c<j>`` allowed).
      compliance: add every joint's compliance ``c<j>`` to the parameters
        (elastostatic; the robot needs ``dynamics``, the points payloads).
      loss, f_scale: least squares (``linear``) or a robust loss of scipy
        (``huber``, ``soft_l1``, ``cauchy``, ``arctan``) with its scale, m.
      folds, seed, repeats: the cross-validation of ``auto`` (K folds over the
        poses, ``repeats`` seeded splits from ``seed``, pooled).
      rtol: identifiability threshold (:mod:`.identifiability`).
      xtol, ftol, gtol, max_nfev: passed to least_squares.
      noise: the declared standard deviation per coordinate for the sanity
        checks of the fit, m (None: estimated from the residuals).

    The attributes are set by ``fit``.

    Attributes:
      names_, deltas_, std_: the error parameters, values and standard
        deviations (rad or m).
      R_IB_, p_IB_, X_IB_std_: the instrument pose (pose of B in I; m) and the
        std of its rotation increment (rad, about I's axes) and translation
        (m), (6,).
      markers_, markers_std_: (M, 3) markers in E (m), ascending marker id.
      marker_ids_: (M,) the marker ids.
      model_: the calibrated RobotModel with its ``calibration`` record.
      residuals_: (N, 3) measured minus predicted, m.
      residual_rms_, residual_max_, residual_rms_nominal_: 3-D point errors, m.
      identifiability_, selection_ (``auto`` only), sanity_, result_,
      fit_time_ (s), elastic_passes_ (outer passes; 1 when rigid).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PointLM, simulate_points
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=12, seed=0).data
    >>> lm = PointLM(robot, params="offsets").fit(data)
    >>> lm.names_, lm.R_IB_.shape
    (['dtheta2', 'dtheta3', 'dtheta4', 'dtheta5'], (3, 3))
    """

    method = "lm"
    sanity_bounds: CalibrationBounds | None = None

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "auto",
        compliance: bool = False,
        loss: str = "linear",
        f_scale: float = 1e-4,
        folds: int = 5,
        seed: int = 0,
        repeats: int = 1,
        rtol: float = 1e-6,
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
        max_nfev: int | None = None,
        progress: bool = False,
        noise: float | None = None,
    ) -> None:
        self.model = model
        self.noise = noise
        self.params = params
        self.progress = progress
        self.compliance = compliance
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

    def _check(self, data: PointMeasurements) -> None:
        m = self.model
        check_point_measurements(
            data,
            n_joints=m.n_joints,
            lower=m.limits.lower,
            upper=m.limits.upper,
            sigma=m.sigma,
            reach=robot_reach(m),
        )
        # the LM's dense Jacobian: 3 rows a point, a column per unknown (at
        # most 5 MDH errors a row, the instrument pose, 3 per marker), and the
        # solver's copies of it
        columns = 5 * (m.n_joints + 1) + 6 + 3 * int(data.marker_ids.size)
        check_memory(
            3.0 * 3 * data.n_rows * columns,
            f"{data.n_rows} points x {columns} unknowns (the LM's Jacobian)",
            "fewer poses or markers",
        )

    def _names(self, data: PointMeasurements, start: tuple) -> list[str]:
        """The parameter set (sets ``identifiability_``); ``start``: the
        initial alignment."""
        model = self.model
        if isinstance(self.params, str) and self.params == "auto":
            from rmdrake.calibration.points.selection import select_parameters

            self._starts: dict | None = {}  # the candidates' shared starts
            with warnings.catch_warnings():  # said once, for the chosen set
                warnings.simplefilter("ignore", ComplianceWarning)
                self.selection_ = select_parameters(
                    self._with,
                    data,
                    folds=self.folds,
                    seed=self.seed,
                    repeats=self.repeats,
                    progress=self.progress,
                )
            self._starts = None
            names = list(self.selection_.chosen)
        else:
            names = _candidates(model, self.params)
        names = with_compliances(model, names, self.compliance)
        preset = isinstance(self.params, str) and self.params in POINT_PRESETS
        report = analyse_point_identifiability(
            model, data, names, rtol=self.rtol, start=start
        )
        check_identified(
            model,
            data,
            report,
            names,
            strict=not preset,
            stacklevel=3,
            what="points",
        )
        self.identifiability_ = report
        names = report.identifiable
        M = int(data.marker_ids.size)
        unknowns = len(names) + 6 + 3 * M
        if 3 * data.n_rows < unknowns + 5:
            per_pose = 3 * data.n_rows / data.pose_ids.size
            need = int(np.ceil((unknowns + 5) / per_pose))
            raise ValueError(
                f"{data.pose_ids.size} poses ({data.n_rows} points) cannot identify "
                f"{len(names)} parameters, the instrument pose and {M} markers "
                f"({unknowns} unknowns and 5 dof to check them): measure at least "
                f"{need} poses or name fewer parameters"
            )
        return names

    def _with(self, names: Sequence[str]) -> PointLM:
        """This estimator's options with an explicit parameter list (during
        ``auto``'s selection: a candidate sharing the memoised starts)."""
        est = PointLM(
            self.model,
            params=list(names),
            compliance=self.compliance,
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

    def _solve(self, problem: PointProblem, x0: np.ndarray) -> Any:
        return solve_lm(problem, x0, self)

    def _start(self, data: PointMeasurements) -> tuple:
        """The initial alignment (R0, p0, markers) on the nominal model, the
        nominal model's best fit (R1, p1, markers: base and markers only) and
        its residual RMS (m). Shared by the candidates of ``auto`` (the same
        training sets recur in every candidate's cross-validation): memoised in
        ``_starts`` on the data's content when the estimator has one."""
        cache = getattr(self, "_starts", None)
        key = (data.pose.tobytes(), data.marker.tobytes(), data.q.tobytes())
        key += (data.p_I.tobytes(), self.loss, self.f_scale)
        if cache is not None and key in cache:
            return cache[key]
        model = self.model
        # An elastic nominal bends under the payloads: its link angles.
        bent = link_angles(model, data.q, data.payload_masses)
        bent = dataclasses.replace(data, q=bent)
        R0, p0, m0 = initial_alignment(model.table, bent, sigma=model.sigma)
        base = PointProblem(model.table, bent, np.zeros(0, int), R0, sigma=model.sigma)
        fit0 = self._solve(base, base.pack([], p0, m0))
        rms = float(np.sqrt(np.mean(np.sum(fit0.fun.reshape(-1, 3) ** 2, axis=1))))
        out = ((R0, p0, m0), base.unpack(fit0.x)[1:], rms)
        if cache is not None:
            cache[key] = out
        return out

    def fit(self, data: PointMeasurements) -> PointLM:
        """Calibrates from the measured points; returns self."""
        t0 = time.perf_counter()
        check_loss(self.loss, self.f_scale)
        self._check(data)
        model = self.model
        start, (R1, p1, m1), self.residual_rms_nominal_ = self._start(data)
        names = self._names(data, start)
        loads = self._loads = JointLoads(model, data, names)
        idx = _indices(model, loads.geometric)
        pose, last = [R1, p1, m1], []

        def fit_once(torques: np.ndarray | None, params: np.ndarray) -> tuple:
            R, p, markers = pose
            options = loads.problem_options(torques)
            problem = PointProblem(
                model.table, data, idx, R, sigma=model.sigma, **options
            )
            result = self._solve(problem, problem.pack(params, p, markers))
            pose[:] = problem.unpack(result.x)[1:]
            last[:] = [problem]
            return result, result.x[: len(names)]

        x0 = loads.nominal()
        most = 1 if getattr(self, "_starts", None) is not None else MAX_PASSES
        self.result_, _, self.elastic_passes_ = loads.passes(fit_once, x0, most)
        self._finish(data, names, last[0], self.result_.x, t0)
        return self

    def _finish(
        self,
        data: PointMeasurements,
        names: list[str],
        problem: PointProblem,
        x: np.ndarray,
        t0: float,
    ) -> None:
        k = len(names)
        deltas, R, p, markers = problem.unpack(x)
        r = problem.residuals(x)
        self.names_ = names
        self.deltas_ = deltas.copy()
        self.R_IB_, self.p_IB_ = R, p.copy()
        self.markers_ = markers.copy()
        self.marker_ids_ = data.marker_ids
        if getattr(self, "_starts", None) is not None:
            # a candidate of ``auto``, fitted only to predict held-out points
            self.model_ = apply_deltas(self.model, names, self.deltas_)
            return
        std = least_squares_std(problem.jacobian(x), r)
        self.std_ = std[:k]
        self.X_IB_std_ = std[k : k + 6]
        self.markers_std_ = std[k + 6 :].reshape(-1, 3)
        self.residuals_ = r.reshape(-1, 3)
        e = np.linalg.norm(self.residuals_, axis=1)
        self.residual_rms_ = float(np.sqrt(np.mean(e**2)))
        self.residual_max_ = float(e.max())
        self.data_ = data
        self._problem, self._x = problem, x
        self.sanity_ = self.check()
        self.fit_time_ = time.perf_counter() - t0
        self.model_ = dataclasses.replace(
            apply_deltas(self.model, names, self.deltas_), calibration=self.record()
        )

    def record(self) -> dict[str, Any]:
        """The ``calibration`` record of the fit (no wall time: the same data
        and options give the same record)."""
        report, data = self.identifiability_, self.data_
        rpy = rpy_from_rotation(self.R_IB_[None])[0]
        record: dict[str, Any] = {
            "kind": "point kinematic calibration (laser tracker, motion capture)",
            "method": self.method,
            "parameters": {
                n: {"delta": float(d), "std": float(s)}
                for n, d, s in zip(self.names_, self.deltas_, self.std_, strict=True)
                if not is_compliance_name(n)
            },
            "units": "deltas and std in rad (dalpha, dtheta, dbeta) or m (dd, dr); "
            "X_IB xyz and markers in m, rpy in rad (Drake RollPitchYaw); residuals "
            "are 3-D point errors in m",
            "X_IB": {"xyz": self.p_IB_.tolist(), "rpy": rpy.tolist()},
            "X_IB_std": {
                "xyz": self.X_IB_std_[3:].tolist(),
                "rotation": self.X_IB_std_[:3].tolist(),
            },
            "markers": self.markers_.tolist(),
            "markers_std": self.markers_std_.tolist(),
            "marker_ids": [int(i) for i in self.marker_ids_],
            "residual_rms": self.residual_rms_,
            "residual_max": self.residual_max_,
            "residual_rms_nominal": self.residual_rms_nominal_,
            "rank": report.rank,
            "condition_number": report.condition_number,
            "dropped": dict(report.dropped),
            "data": {
                "points": data.n_rows,
                "poses": int(data.pose_ids.size),
                "markers": int(data.marker_ids.size),
            },
            "base_model": self.model.name,
            "options": {"params": self._params_text(), "loss": self.loss},
        }
        record.update(
            elastic_record(
                self.names_,
                self.deltas_,
                self.std_,
                self.elastic_passes_,
                self._loads.payload,
            )
        )
        if self.compliance:
            record["options"]["compliance"] = True
        if self.loss != "linear":
            record["options"]["f_scale"] = self.f_scale
        if hasattr(self, "selection_"):
            record["selection"] = self.selection_.record()
        return record

    def _params_text(self) -> str:
        p = self.params
        return p if isinstance(p, str) else ",".join(p)

    def predict(self, data: PointMeasurements) -> np.ndarray:
        """(N, 3) predicted instrument readings of the rows of ``data`` (m, in
        I) by the calibrated model (its joints bent under each row's payload
        when elastic), pose X_IB and markers (after fit).

        Raises:
          ValueError: a marker id the fit did not see.
        """
        pos = np.searchsorted(self.marker_ids_, data.marker)
        pos = np.minimum(pos, self.marker_ids_.size - 1)
        unseen = np.flatnonzero(self.marker_ids_[pos] != data.marker)
        if unseen.size:
            raise ValueError(
                f"marker {data.marker[unseen[0]]} was not in the calibration data"
            )
        m = self.model_
        q = link_angles(m, data.q, data.payload_masses)  # bent under the payload
        return predict_points(
            m.table, q, self.markers_[pos], self.R_IB_, self.p_IB_, sigma=m.sigma
        )

    def check(
        self, noise: float | None = None, bounds: CalibrationBounds | None = None
    ) -> SanityReport:
        """The sanity checks of the fit against a declared noise per
        coordinate (m; None: this estimator's ``noise``, and when that is None
        too, estimated) and ``bounds``; the fit's own ``sanity_`` is this with
        the defaults."""
        return check_point_calibration(
            self.data_,
            self._problem,
            self._x,
            self.names_,
            noise=self.noise if noise is None else noise,
            bounds=bounds or self.sanity_bounds,
        )

    def summary(self) -> str:
        """Human-readable result (after fit)."""
        report = self.identifiability_
        lines = []
        if hasattr(self, "selection_"):
            lines += self.selection_.summary_lines()
        lines += [
            f"method {self.method} on points: {len(self.names_)} parameters, rank "
            f"{report.rank}, condition number {report.condition_number:.3g}, "
            f"{self.fit_time_:.3f} s",
            f"training 3-D point error: RMS {self.residual_rms_nominal_ * 1e3:.4g} mm"
            f" (nominal, base and markers fitted) -> {self.residual_rms_ * 1e3:.4g} "
            f"mm, max {self.residual_max_ * 1e3:.4g} mm",
            *delta_lines(self.names_, self.deltas_, self.std_),
        ]
        xyz = ", ".join(f"{v:.4f}" for v in self.p_IB_)
        lines.append(f"instrument: X_IB xyz ({xyz}) m")
        for i, mk in zip(self.marker_ids_, self.markers_, strict=True):
            lines.append(
                f"marker {i}: ({', '.join(f'{v * 1e3:.2f}' for v in mk)}) mm in E"
            )
        return "\n".join(lines)


def make_point_calibrator(config: CalibrationConfig, model: RobotModel) -> PointLM:
    """The :class:`PointLM` of a config: its ``params`` (None = ``auto``),
    ``compliance``, ``loss``, ``f_scale``, ``rtol`` and ``noise``, and its
    :class:`~rmdrake.calibration.config.PointLMConfig` (None = the defaults):
    ``seed``, ``selection_folds`` (PointLM's ``folds``), ``repeats`` and
    ``max_nfev``. The config's reported cross-validation (``folds``,
    ``holdout``) is the caller's
    (:func:`~rmdrake.calibration.points.selection.cross_validate`).

    Raises:
      ValueError: a plate method's config (one line naming it).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import CalibrationConfig, PointLMConfig
    >>> from rmdrake.calibration import make_point_calibrator
    >>> config = CalibrationConfig(params="offsets", calibrator=PointLMConfig())
    >>> make_point_calibrator(config, load_robot("rv3sb")).params
    'offsets'
    """
    method = config.calibrator
    if method is None:
        method = PointLMConfig()
    if not isinstance(method, PointLMConfig):
        raise ValueError(
            f"{type(method).__name__} (method '{method.method}') calibrates plane "
            "measurements; point measurements are calibrated by PointLMConfig"
        )
    return PointLM(
        model,
        params="auto" if config.params is None else config.params,
        compliance=config.compliance,
        loss=config.loss,
        f_scale=config.f_scale,
        folds=method.selection_folds,
        seed=method.seed,
        repeats=method.repeats,
        rtol=config.rtol,
        max_nfev=method.max_nfev,
        noise=config.noise,
    )
