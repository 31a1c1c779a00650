"""What every plane-constraint estimator does before and after its fit.

Before (:meth:`PlaneCalibrator._setup`): the readings are checked
(:func:`~rmdrake.calibration.plates.checks.check_plane_measurements`) and the
identifiability analysis runs at the nominal model
(:func:`~rmdrake.calibration.plates.identifiability.analyse_identifiability`): with the
``full`` preset it keeps the identifiable subset and records what it dropped and
why; with ``paper`` or an explicit list, a rank-deficient set (or fewer readings
than unknowns) is an error that names the parameters to drop. ``auto`` (the
estimators with an LM) is the set chosen by cross-validation over the plates
(:mod:`rmdrake.calibration.plates.selection`, recorded as ``selection_``),
kept as a preset (its identifiable subset).

After (:meth:`PlaneCalibrator._finish`): error parameters are rad (``dalpha``,
``dtheta``, ``dbeta``) or m (``dd``, ``dr``) and add to the robot's MDH table
(:func:`rmdrake.model.error_parameters.apply_deltas`). Standard deviations are
``sqrt(diag(sigma^2 (J^T J)^-1))`` with J the Jacobian of all unknowns (plates
included) at the solution and sigma^2 the residual sum of squares over the
degrees of freedom N - k - 3P (with a robust loss this is the same first-order
formula at the robust solution, an approximation); a parameter in a direction
the Jacobian does not fix at the solution gets an infinite std. The calibrated
model carries a ``calibration`` record of the method, values, statistics and
options, and ``sanity_`` the
:func:`~rmdrake.calibration.plates.sanity.check_calibration` report of the fit
(computed, never raised here: the caller decides).

Elastostatic calibration (``compliance=True`` or ``c<j>`` names,
:mod:`~rmdrake.calibration.elastostatic`): the joint compliances c_j (rad/(N m),
m/N on a slide) follow the MDH error parameters in ``names_`` and ``deltas_``
(their values, not deltas); compliances the readings cannot identify are
dropped with a :class:`~rmdrake.calibration.elastostatic.ComplianceWarning`
(MDH parameters keep the rules above). The calibrated model gets the stiffness
1 / c_j of each identified joint (a value <= 0: rigid), and the record a
``compliance`` section (compliance, std, stiffness in N m/rad and its relative
std per joint) and the outer passes (``elastic``).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.calibration.elastostatic import (
    JointLoads,
    check_identified,
    elastic_record,
    with_compliances,
)
from rmdrake.calibration.lm import delta_lines, least_squares_std
from rmdrake.calibration.parameters import resolve_parameters
from rmdrake.calibration.plates.checks import check_plane_measurements
from rmdrake.calibration.plates.cost import PlaneProblem, fit_planes
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.identifiability import analyse_identifiability
from rmdrake.calibration.plates.sanity import check_calibration
from rmdrake.calibration.sanity import CalibrationBounds, SanityReport
from rmdrake.kinematics.forward import robot_reach, tool_points
from rmdrake.model.error_parameters import (
    apply_deltas,
    error_parameter_indices,
    is_compliance_name,
    split_error_parameters,
)
from rmdrake.model.robot import RobotModel

__all__ = ["PlaneCalibrator"]


class PlaneCalibrator:
    """Base of the plane-constraint estimators: the checks before a fit and the
    result bookkeeping after it (see the module docstring).

    Subclasses set ``method`` and implement ``fit(data)``, calling
    :meth:`_setup` first and :meth:`_finish` with their deltas.

    Args:
      model: the nominal robot.
      params: ``paper``, ``full`` (identifiable subset chosen automatically),
        ``auto`` (estimators with an LM: chosen by cross-validation, the
        subclass sets ``selection_`` before :meth:`_setup`) or a list of names
        (:func:`~rmdrake.calibration.parameters.resolve_parameters`;
        compliances ``c<j>`` allowed).
      compliance: add the compliance ``c<j>`` of every joint to ``params``
        (elastostatic calibration; the robot needs ``dynamics``).
      rtol: identifiability threshold (see :mod:`.identifiability`).
      noise: the readings' declared standard deviation, m, for the sanity
        checks of the fit (``sanity_``); None: estimated from the residuals.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneCalibrator, PlaneLM
    >>> issubclass(PlaneLM, PlaneCalibrator), PlaneLM(load_robot("rv3sb")).method
    (True, 'lm')
    """

    method = ""
    sanity_bounds: CalibrationBounds | None = None
    """The bounds of the checks after a fit (None: the defaults)."""

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        compliance: bool = False,
        rtol: float = 1e-6,
        noise: float | None = None,
    ) -> None:
        self.model = model
        self.params = params
        self.compliance = compliance
        self.rtol = rtol
        self.noise = noise

    def _is_auto(self) -> bool:
        return isinstance(self.params, str) and self.params == "auto"

    def _names(self) -> list[str]:
        """The candidate names: MDH parameters first, then compliances."""
        if self._is_auto():
            names = list(self.selection_.chosen)
        else:
            names = resolve_parameters(self.model, self.params)
        return with_compliances(self.model, names, self.compliance)

    def check_data(self, data: PlaneMeasurements) -> list[str]:
        """Checks the readings for this robot
        (:func:`~rmdrake.calibration.plates.checks.check_plane_measurements`;
        readings above twice the reach + 1 m are refused); returns the
        warnings' messages.

        Raises:
          ValueError: one line naming the problem.
        """
        model = self.model
        return check_plane_measurements(
            data,
            n_joints=model.n_joints,
            lower=model.limits.lower,
            upper=model.limits.upper,
            sigma=model.sigma,
            max_distance=2 * robot_reach(model) + 1.0,
        )

    def _setup(
        self, data: PlaneMeasurements, *, check: bool = True
    ) -> tuple[list[str], np.ndarray]:
        """Checks the data (unless ``check`` is False: already checked) and the
        parameter set; sets ``identifiability_`` and ``names_``; returns the
        names and their flat MDH indices."""
        model = self.model
        if check:
            self.check_data(data)
        names = self._names()
        P = int(data.plate_ids.size)
        preset = isinstance(self.params, str) and self.params in ("full", "auto")
        if not preset and data.n_readings <= len(names) + 3 * P:
            raise ValueError(
                f"{data.n_readings} readings cannot identify {len(names)} parameters "
                f"and {P} plates ({len(names) + 3 * P} unknowns): take more "
                f"readings per plate or name fewer parameters"
            )
        report = analyse_identifiability(model, data, names, rtol=self.rtol)
        check_identified(model, data, report, names, strict=not preset, stacklevel=3)
        if preset:
            names = report.identifiable
        else:
            names = [n for n in names if n not in report.dropped]
        self.identifiability_ = report
        self.names_ = names
        self._loads = JointLoads(model, data, names)
        geometric, _ = split_error_parameters(model, names)
        return names, error_parameter_indices(model, geometric)

    @staticmethod
    def _start(names: list[str], loads: JointLoads) -> np.ndarray:
        """The nominal's values of ``names``: zero deltas, its compliances."""
        return loads.nominal()

    def _problem(
        self,
        data: PlaneMeasurements,
        idx: np.ndarray,
        normals: np.ndarray,
        torques: np.ndarray | None,
    ) -> PlaneProblem:
        """The plane problem of this calibration's names with ``torques`` held."""
        return PlaneProblem(
            self.model.table,
            data,
            idx,
            normals,
            sigma=self.model.sigma,
            **self._loads.problem_options(torques),
        )

    def _plates_at(
        self,
        data: PlaneMeasurements,
        idx: np.ndarray,
        params: np.ndarray,
        torques: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """SVD plate fits of the points predicted by ``params`` (k,)."""
        table = self.model.table.ravel().copy()
        table[idx] += params[: idx.size]
        q = self._loads.link_angles(params, torques)
        pts = tool_points(
            table.reshape(-1, 5), q, data.distance, sigma=self.model.sigma
        )
        return fit_planes(pts, data.plate_index, int(data.plate_ids.size))

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
        """Sets the results of ``deltas`` (k,) rad or m: plates (SVD fits at the
        deltas unless ``planes`` = (normals, offsets) is given), residuals (m),
        standard deviations, ``fit_time_`` since ``t0`` (s) and ``model_`` with
        its calibration record (``options`` added when given; no wall time, so
        the same data and options give the same record)."""
        model = self.model
        P = int(data.plate_ids.size)
        pi = data.plate_index
        loads = self._loads
        start = self._start(names, loads)
        q0 = loads.link_angles(start, loads.torques(start))
        nominal = tool_points(model.table, q0, data.distance, sigma=model.sigma)
        n0, h0 = fit_planes(nominal, pi, P)
        self.residual_rms_nominal_ = float(
            np.sqrt(np.mean((np.sum(n0[pi] * nominal, axis=1) - h0[pi]) ** 2))
        )
        torques = getattr(loads, "final_torques", None)
        if torques is None:
            torques = loads.torques(deltas)
        self._torques = torques
        if planes is None:
            planes = self._plates_at(data, idx, deltas, torques)
        normals, offsets = planes
        problem = self._problem(data, idx, normals, torques)
        x = problem.pack(deltas, offsets)
        r = problem.residuals(x)
        J = problem.jacobian(x)
        std = least_squares_std(J, r)[: len(names)]
        self.deltas_ = np.asarray(deltas, dtype=np.float64).copy()
        self.std_ = std
        self.normals_ = normals
        self.offsets_ = offsets
        self.residuals_ = r
        self.residual_rms_ = float(np.sqrt(np.mean(r**2)))
        self.data_ = data
        self.sanity_ = self.check()
        self.fit_time_ = time.perf_counter() - t0
        report = self.identifiability_
        is_c = np.array([is_compliance_name(n) for n in names], dtype=bool)
        record: dict[str, Any] = {
            "kind": "plane-constraint kinematic calibration (Wang et al. 2016)",
            "method": self.method,
            "parameters": {
                n: {"delta": float(d), "std": float(s)}
                for n, d, s, c in zip(names, self.deltas_, std, is_c, strict=True)
                if not c
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
        }
        passes = int(getattr(self, "elastic_passes_", 1))
        record.update(elastic_record(names, self.deltas_, std, passes, loads.payload))
        if options:
            record["options"] = options
        if hasattr(self, "selection_"):
            record["selection"] = self.selection_.record()
        self.model_ = dataclasses.replace(
            apply_deltas(model, names, self.deltas_), calibration=record
        )

    def check(
        self, noise: float | None = None, bounds: CalibrationBounds | None = None
    ) -> SanityReport:
        """The sanity checks of the fit
        (:func:`~rmdrake.calibration.plates.sanity.check_calibration`) against a
        declared reading noise (m; None: this estimator's ``noise``, and when
        that is None too, estimated from the data) and ``bounds`` (None: this
        estimator's ``sanity_bounds``). The fit's own ``sanity_`` is this
        with the defaults."""
        geometric, _ = split_error_parameters(self.model, self.names_)
        idx = error_parameter_indices(self.model, geometric)
        problem = self._problem(self.data_, idx, self.normals_, self._torques)
        return check_calibration(
            self.data_,
            problem,
            problem.pack(self.deltas_, self.offsets_),
            self.names_,
            noise=self.noise if noise is None else noise,
            bounds=bounds or self.sanity_bounds,
        )

    def summary(self) -> str:
        """Human-readable result table (after fit); with ``auto`` the
        candidates of the choice first."""
        lines = []
        if hasattr(self, "selection_"):
            lines += self.selection_.summary_lines()
        lines += [
            f"method {self.method}: {len(self.names_)} parameters, rank "
            f"{self.identifiability_.rank}, condition number "
            f"{self.identifiability_.condition_number:.3g}, {self.fit_time_:.3f} s",
            f"residual RMS {self.residual_rms_nominal_ * 1e6:.2f} um (nominal) -> "
            f"{self.residual_rms_ * 1e6:.2f} um",
            *delta_lines(self.names_, self.deltas_, self.std_),
        ]
        for n, why in self.identifiability_.dropped.items():
            lines.append(f"  dropped {n}: {why}")
        for n in getattr(self, "at_bounds_", []):
            lines.append(
                f"  warning: the DE ended at a bound of {n}; widen the bounds if "
                f"the errors may be larger"
            )
        return "\n".join(lines)
