"""Plane-constraint kinematic calibration estimators.

Three estimators with the scikit-learn contract (``__init__`` stores options,
``fit(data)`` validates the data and returns self, results end in ``_``):

* :class:`VolumeDE`, the paper's method (Wang et al. 2016, eq. 1 and 5):
  Differential Evolution over the error parameters minimising the sum of
  |tetrahedron volumes| of fixed point quadruples per plate.
* :class:`PlaneLM`: Levenberg-Marquardt on the signed point-to-plane distances,
  each plate's normal and offset as extra unknowns, analytic Jacobian; optional
  robust loss (then scipy's trust-region reflective method).
* :class:`VolumeDEPlaneLM` (``de+lm``): the paper's DE as a global start, then
  :class:`PlaneLM`.

Every estimator first runs the identifiability analysis at the nominal model
(:func:`~rmdrake.calibration.identifiability.analyse_identifiability`): with the
``full`` preset it keeps the identifiable subset and records what it dropped and
why; with ``paper`` or an explicit list, a rank-deficient set is an error that
names the parameters to drop.

Error parameters are rad (``dalpha``, ``dtheta``, ``dbeta``) or m (``dd``,
``dr``); they add to the robot's MDH table (:func:`rmdrake.robot.apply_deltas`).
Standard deviations are ``sqrt(diag(sigma^2 (J^T J)^-1))`` with J the Jacobian of
all unknowns (plates included) at the solution and sigma^2 the residual sum of
squares over the degrees of freedom N - k - 3P (with a robust loss this is the
same first-order formula at the robust solution, an approximation).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.optimize

from rmdrake.calibration.cost import PlaneProblem, VolumeCost, fit_planes
from rmdrake.calibration.identifiability import (
    analyse_identifiability,
)
from rmdrake.calibration.readings import check_plane_measurements
from rmdrake.io import PlaneMeasurements
from rmdrake.kinematics import tool_points
from rmdrake.optimize import differential_evolution
from rmdrake.robot import (
    RobotModel,
    apply_deltas,
    error_parameter_indices,
    error_parameter_names,
)

__all__ = [
    "METHODS",
    "PlaneLM",
    "VolumeDE",
    "VolumeDEPlaneLM",
    "make_calibrator",
    "parameter_bounds",
    "resolve_parameters",
]

METHODS = ("de", "lm", "de+lm")
_LOSSES = ("linear", "huber", "soft_l1", "cauchy", "arctan")


def resolve_parameters(model: RobotModel, params: str | Sequence[str]) -> list[str]:
    """Error parameter names of a preset (``paper``, ``full``), of a
    comma-separated string or of a list of names.

    Raises:
      ValueError: unknown preset or parameter name (naming it).
    """
    if isinstance(params, str):
        if params in ("paper", "full"):
            return error_parameter_names(model, params)
        if "," not in params and not params.startswith("d"):
            raise ValueError(
                f"unknown parameter preset '{params}': expected 'paper', 'full' or "
                f"a comma-separated list of names such as dalpha2,dd3"
            )
        params = [p.strip() for p in params.split(",") if p.strip()]
    names = list(params)
    if not names:
        raise ValueError("error parameters: none given")
    error_parameter_indices(model, names)  # raises naming an unknown name
    return names


def parameter_bounds(
    names: Sequence[str], length: float = 3e-3, angle: float = 3e-3
) -> np.ndarray:
    """(k, 2) symmetric bounds: +-``length`` m for ``dd``/``dr`` parameters,
    +-``angle`` rad for ``dalpha``/``dtheta``/``dbeta``."""
    half = np.array([length if n[:2] in ("dd", "dr") else angle for n in names])
    return np.stack([-half, half], axis=1)


class _PlaneCalibrator:
    """Shared validation, identifiability and result bookkeeping."""

    method = ""

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        rtol: float = 1e-6,
    ) -> None:
        self.model = model
        self.params = params
        self.rtol = rtol

    # -- helpers --------------------------------------------------------------------
    def _setup(self, data: PlaneMeasurements) -> tuple[list[str], np.ndarray]:
        model = self.model
        check_plane_measurements(
            data,
            n_joints=model.n_joints,
            lower=model.limits.lower,
            upper=model.limits.upper,
        )
        names = resolve_parameters(model, self.params)
        P = int(data.plate_ids.size)
        if self.params != "full" and data.n_readings <= len(names) + 3 * P:
            raise ValueError(
                f"{data.n_readings} readings cannot identify {len(names)} parameters "
                f"and {P} plates ({len(names) + 3 * P} unknowns): take more "
                f"readings per plate or name fewer parameters"
            )
        report = analyse_identifiability(model, data, names, rtol=self.rtol)
        if self.params != "full" and not report.full_rank:
            drop = ", ".join(
                f"{n} ({why.split(' (')[0]})" for n, why in report.dropped.items()
            )
            raise ValueError(
                f"error parameters not identifiable from these readings (rank "
                f"{report.rank} of {len(names)}): drop {drop}"
            )
        if self.params == "full":
            names = report.identifiable
        self.identifiability_ = report
        self.names_ = names
        return names, error_parameter_indices(model, names)

    def _finish(
        self,
        data: PlaneMeasurements,
        names: list[str],
        idx: np.ndarray,
        deltas: np.ndarray,
        t0: float,
        planes: tuple[np.ndarray, np.ndarray] | None = None,
        options: dict[str, Any] | None = None,
    ) -> None:
        model = self.model
        P = int(data.plate_ids.size)
        pi = data.plate_index
        nominal = tool_points(model.table, data.q, data.distance)
        n0, h0 = fit_planes(nominal, pi, P)
        self.residual_rms_nominal_ = float(
            np.sqrt(np.mean((np.sum(n0[pi] * nominal, axis=1) - h0[pi]) ** 2))
        )
        if planes is None:
            table = model.table.ravel().copy()
            table[idx] += deltas
            pts = tool_points(table.reshape(-1, 5), data.q, data.distance)
            planes = fit_planes(pts, pi, P)
        normals, offsets = planes
        problem = PlaneProblem(model.table, data, idx, normals)
        x = problem.pack(deltas, offsets)
        r = problem.residuals(x)
        J = problem.jacobian(x)
        dof = r.size - J.shape[1]
        std = np.full(len(names), np.nan)
        if dof > 0:
            sigma2 = float(r @ r) / dof
            norms = np.linalg.norm(J, axis=0)
            norms[norms == 0] = 1.0
            Js = J / norms
            cov_s = np.linalg.pinv(Js.T @ Js)
            std = np.sqrt(np.maximum(np.diag(cov_s)[: len(names)], 0) * sigma2)
            std /= norms[: len(names)]
        self.deltas_ = np.asarray(deltas, dtype=np.float64).copy()
        self.std_ = std
        self.normals_ = normals
        self.offsets_ = offsets
        self.residuals_ = r
        self.residual_rms_ = float(np.sqrt(np.mean(r**2)))
        self.fit_time_ = time.perf_counter() - t0
        report = self.identifiability_
        record: dict[str, Any] = {
            "kind": "plane-constraint kinematic calibration (Wang et al. 2016)",
            "method": self.method,
            "parameters": {
                n: {"delta": float(d), "std": float(s)}
                for n, d, s in zip(names, self.deltas_, std, strict=True)
            },
            "units": "deltas and std in rad (dalpha, dtheta, dbeta) or m (dd, dr); "
            "residuals in m",
            "residual_rms": self.residual_rms_,
            "residual_rms_nominal": self.residual_rms_nominal_,
            "rank": report.rank,
            "condition_number": report.condition_number,
            "dropped": dict(report.dropped),
            "data": {"readings": data.n_readings, "plates": P},
            "base_model": model.name,
            "time_s": self.fit_time_,
        }
        if options:
            record["options"] = options
        self.model_ = dataclasses.replace(
            apply_deltas(model, names, self.deltas_), calibration=record
        )

    def summary(self) -> str:
        """Human-readable result table (after fit)."""
        lines = [
            f"method {self.method}: {len(self.names_)} parameters, rank "
            f"{self.identifiability_.rank}, condition number "
            f"{self.identifiability_.condition_number:.3g}, {self.fit_time_:.3f} s",
            f"residual RMS {self.residual_rms_nominal_ * 1e6:.2f} um (nominal) -> "
            f"{self.residual_rms_ * 1e6:.2f} um",
            f"{'parameter':>10} {'delta':>12} {'std':>10}  unit",
        ]
        for n, d, s in zip(self.names_, self.deltas_, self.std_, strict=True):
            if n[:2] in ("dd", "dr"):
                lines.append(f"{n:>10} {d * 1e3:12.5f} {s * 1e3:10.5f}  mm")
            else:
                lines.append(
                    f"{n:>10} {np.rad2deg(d):12.6f} {np.rad2deg(s):10.6f}  deg"
                )
        for n, why in self.identifiability_.dropped.items():
            lines.append(f"  dropped {n}: {why}")
        for n in getattr(self, "at_bounds_", []):
            lines.append(
                f"  warning: the DE ended at a bound of {n}; widen the bounds if "
                f"the errors may be larger"
            )
        return "\n".join(lines)


class PlaneLM(_PlaneCalibrator):
    """Levenberg-Marquardt on signed point-to-plane distances.

    Unknowns: the error parameters and, per plate, its unit normal (two angles
    about the initial normal) and offset (:class:`PlaneProblem`). Initial plates:
    SVD plane fits of the points predicted by the starting model. Residuals,
    analytic Jacobian from :func:`rmdrake.kinematics.point_jacobian`, solved by
    :func:`scipy.optimize.least_squares` (MINPACK ``lm`` for the plain squared
    loss; ``trf`` for a robust loss).

    Args:
      model: the nominal robot.
      params: ``paper``, ``full`` (identifiable subset chosen automatically) or
        a list of names.
      x0: starting deltas (k,), rad or m; default zero (the nominal).
      loss: ``linear`` (least squares) or a robust loss of scipy
        (``huber``, ``soft_l1``, ``cauchy``, ``arctan``) against outliers.
      f_scale: residual scale of the robust loss, m (e.g. 3 x the noise).
      xtol, ftol, gtol, max_nfev: passed to least_squares.
      rtol: identifiability threshold (see :mod:`.identifiability`).

    Attributes (after fit):
      names_, deltas_, std_: the identified parameters, values and standard
        deviations (rad or m).
      model_: the calibrated RobotModel with its ``calibration`` record.
      normals_, offsets_: the fitted plates (unit normals in B, offsets in m).
      residuals_, residual_rms_, residual_rms_nominal_: m.
      identifiability_: the :class:`IdentifiabilityReport`.
      result_: scipy's OptimizeResult. fit_time_: s.
    """

    method = "lm"

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        x0: np.ndarray | None = None,
        loss: str = "linear",
        f_scale: float = 1e-5,
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
        max_nfev: int | None = None,
        rtol: float = 1e-6,
    ) -> None:
        super().__init__(model, params=params, rtol=rtol)
        self.x0 = x0
        self.loss = loss
        self.f_scale = f_scale
        self.xtol = xtol
        self.ftol = ftol
        self.gtol = gtol
        self.max_nfev = max_nfev

    def fit(self, data: PlaneMeasurements) -> PlaneLM:
        """Calibrates from the readings; returns self."""
        t0 = time.perf_counter()
        if self.loss not in _LOSSES:
            raise ValueError(
                f"unknown loss '{self.loss}': expected one of {', '.join(_LOSSES)}"
            )
        names, idx = self._setup(data)
        x0 = np.zeros(len(names)) if self.x0 is None else np.asarray(self.x0, float)
        if x0.shape != (len(names),):
            raise ValueError(f"x0: expected {len(names)} deltas, found {x0.shape}")
        self._solve(data, names, idx, x0, t0)
        return self

    def _solve(self, data, names, idx, x0, t0, options_extra=None) -> None:
        P = int(data.plate_ids.size)
        table = self.model.table.ravel().copy()
        table[idx] += x0
        pts = tool_points(table.reshape(-1, 5), data.q, data.distance)
        normals0, offsets0 = fit_planes(pts, data.plate_index, P)
        problem = PlaneProblem(self.model.table, data, idx, normals0)
        robust = self.loss != "linear"
        result = scipy.optimize.least_squares(
            problem.residuals,
            problem.pack(x0, offsets0),
            jac=problem.jacobian,
            method="trf" if robust else "lm",
            loss=self.loss,
            f_scale=self.f_scale,
            x_scale="jac",
            xtol=self.xtol,
            ftol=self.ftol,
            gtol=self.gtol,
            max_nfev=self.max_nfev,
        )
        deltas, normals, offsets = problem.unpack(result.x)
        self.result_ = result
        options = {"loss": self.loss}
        if robust:
            options["f_scale"] = self.f_scale
        options.update(options_extra or {})
        self._finish(
            data,
            names,
            idx,
            deltas.copy(),
            t0,
            planes=(normals, offsets),
            options=options,
        )


class VolumeDE(_PlaneCalibrator):
    """The paper's method: Differential Evolution on the tetrahedron volumes.

    Minimises eq. 5, sum over plates and quadruples of |V_t| (m^3), over the
    error parameters inside ``bounds``, with :func:`rmdrake.optimize.
    differential_evolution` (the whole population in one vectorised cost call,
    seeded, the nominal placed in the first population). The quadruples are
    fixed: all 4-subsets of each plate's readings, or ``max_per_plate`` of them
    (:func:`~rmdrake.calibration.cost.plate_quadruples`).

    Args:
      model, params, rtol: as :class:`PlaneLM`.
      bounds: (k, 2) bounds, or None for +-``length_bound`` m and
        +-``angle_bound`` rad (:func:`parameter_bounds`).
      popsize, maxiter, tol, mutation, recombination: DE options (scipy's).
      seed: seed of the DE.
      max_per_plate: quadruples per plate (None: all C(m, 4); the default 100
        keeps a generation of 255 candidates x 500 volumes cheap).
      progress: show a progress bar.

    Attributes (after fit): as :class:`PlaneLM` (std_ evaluated at the DE
    solution with SVD-fitted plates), plus ``cost_`` and ``cost_nominal_`` (m^3)
    and ``result_`` (the DE's OptimizeResult).
    """

    method = "de"

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        bounds: np.ndarray | None = None,
        length_bound: float = 3e-3,
        angle_bound: float = 3e-3,
        popsize: int = 15,
        maxiter: int = 1000,
        tol: float = 1e-4,
        mutation: float | tuple[float, float] = (0.5, 1.0),
        recombination: float = 0.9,
        seed: int = 0,
        max_per_plate: int | None = 100,
        progress: bool = False,
        rtol: float = 1e-6,
    ) -> None:
        super().__init__(model, params=params, rtol=rtol)
        self.bounds = bounds
        self.length_bound = length_bound
        self.angle_bound = angle_bound
        self.popsize = popsize
        self.maxiter = maxiter
        self.tol = tol
        self.mutation = mutation
        self.recombination = recombination
        self.seed = seed
        self.max_per_plate = max_per_plate
        self.progress = progress

    def _options(self) -> dict[str, Any]:
        return {
            "seed": int(self.seed),
            "popsize": int(self.popsize),
            "maxiter": int(self.maxiter),
            "tol": float(self.tol),
            "max_per_plate": self.max_per_plate,
        }

    def _run_de(self, data, names, idx) -> np.ndarray:
        bounds = (
            parameter_bounds(names, self.length_bound, self.angle_bound)
            if self.bounds is None
            else np.asarray(self.bounds, dtype=np.float64)
        )
        if bounds.shape != (len(names), 2):
            raise ValueError(
                f"bounds: expected shape ({len(names)}, 2), found {bounds.shape}"
            )
        cost = VolumeCost(self.model.table, data, idx, max_per_plate=self.max_per_plate)
        result = differential_evolution(
            cost,
            bounds,
            seed=self.seed,
            popsize=self.popsize,
            maxiter=self.maxiter,
            tol=self.tol,
            mutation=self.mutation,
            recombination=self.recombination,
            x0=np.clip(np.zeros(len(names)), bounds[:, 0], bounds[:, 1]),
            progress=self.progress,
            desc=f"DE on volumes ({len(names)} parameters)",
        )
        self.cost_ = float(result.fun)
        self.cost_nominal_ = float(cost(np.zeros(len(names))))
        self.de_result_ = result
        span = bounds[:, 1] - bounds[:, 0]
        at_bound = (np.abs(result.x - bounds[:, 0]) < 1e-3 * span) | (
            np.abs(result.x - bounds[:, 1]) < 1e-3 * span
        )
        self.at_bounds_ = [n for n, b in zip(names, at_bound, strict=True) if b]
        return result.x

    def fit(self, data: PlaneMeasurements) -> VolumeDE:
        """Calibrates from the readings; returns self."""
        t0 = time.perf_counter()
        names, idx = self._setup(data)
        x = self._run_de(data, names, idx)
        self.result_ = self.de_result_
        self._finish(data, names, idx, x, t0, options=self._options())
        return self


class VolumeDEPlaneLM(VolumeDE):
    """``de+lm``: the paper's DE on volumes as a global start, then
    :class:`PlaneLM` from its result.

    Args: those of :class:`VolumeDE`, with a smaller budget by default
    (``popsize`` 10, ``maxiter`` 100, ``max_per_plate`` 30: the DE only has to
    land in LM's basin of attraction), and ``loss``, ``f_scale`` of
    :class:`PlaneLM`.

    Attributes (after fit): as :class:`PlaneLM`, plus ``de_deltas_`` (the DE
    result), ``cost_``, ``cost_nominal_``, ``de_result_`` and ``de_time_`` (s).
    """

    method = "de+lm"

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        bounds: np.ndarray | None = None,
        length_bound: float = 3e-3,
        angle_bound: float = 3e-3,
        popsize: int = 10,
        maxiter: int = 100,
        tol: float = 1e-4,
        mutation: float | tuple[float, float] = (0.5, 1.0),
        recombination: float = 0.9,
        seed: int = 0,
        max_per_plate: int | None = 30,
        progress: bool = False,
        loss: str = "linear",
        f_scale: float = 1e-5,
        rtol: float = 1e-6,
    ) -> None:
        super().__init__(
            model,
            params=params,
            bounds=bounds,
            length_bound=length_bound,
            angle_bound=angle_bound,
            popsize=popsize,
            maxiter=maxiter,
            tol=tol,
            mutation=mutation,
            recombination=recombination,
            seed=seed,
            max_per_plate=max_per_plate,
            progress=progress,
            rtol=rtol,
        )
        self.loss = loss
        self.f_scale = f_scale

    def fit(self, data: PlaneMeasurements) -> VolumeDEPlaneLM:
        """Calibrates from the readings; returns self."""
        t0 = time.perf_counter()
        if self.loss not in _LOSSES:
            raise ValueError(
                f"unknown loss '{self.loss}': expected one of {', '.join(_LOSSES)}"
            )
        names, idx = self._setup(data)
        self.de_deltas_ = self._run_de(data, names, idx)
        self.de_time_ = time.perf_counter() - t0
        lm = PlaneLM(self.model, params=names, loss=self.loss, f_scale=self.f_scale)
        lm.identifiability_ = self.identifiability_
        lm.names_ = names
        lm.method = self.method
        lm._solve(data, names, idx, self.de_deltas_, t0, self._options())
        self.result_ = lm.result_
        for key in (
            "deltas_",
            "std_",
            "normals_",
            "offsets_",
            "residuals_",
            "residual_rms_",
            "residual_rms_nominal_",
            "fit_time_",
            "model_",
        ):
            setattr(self, key, getattr(lm, key))
        return self


def make_calibrator(
    method: str, model: RobotModel, **options: Any
) -> PlaneLM | VolumeDE | VolumeDEPlaneLM:
    """The estimator of ``method`` (``de``, ``lm`` or ``de+lm``) with options.

    Raises:
      ValueError: unknown method.
    """
    classes = {"de": VolumeDE, "lm": PlaneLM, "de+lm": VolumeDEPlaneLM}
    if method not in classes:
        raise ValueError(
            f"unknown method '{method}': expected one of {', '.join(METHODS)}"
        )
    return classes[method](model, **options)
