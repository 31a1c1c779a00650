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

``params="auto"`` (:class:`PlaneLM` and :class:`VolumeDEPlaneLM`; the DE alone
refuses it) chooses the parameter set by K-fold cross-validation over the
plates and the one-standard-error rule
(:func:`~rmdrake.calibration.plates.selection.select_plate_parameters`): every
candidate is fitted by LM from the nominal on the training plates only
(one elastic pass, at most :data:`CANDIDATE_MAX_NFEV` evaluations, no standard
deviations or sanity checks; with ``compliance`` every candidate carries the
compliances while the MDH set is chosen); the choice is ``selection_`` and the
calibration record's ``selection``, and ``summary()`` lists its candidates.
``de+lm`` makes the choice first, then runs its DE and LM on the chosen set.

With ``compliance=True`` (or ``c<j>`` names) the joint compliances join the
unknowns (elastostatic calibration, :mod:`.elastostatic`): :class:`PlaneLM`
fits them in outer passes that update the joint torques; the DE of
:class:`VolumeDEPlaneLM` searches the geometric parameters only (its start) and
:class:`VolumeDE` alone refuses them.

Every estimator first checks the readings and the identifiability of its
parameters, and reports standard deviations and a calibration record after its
fit, as :class:`~rmdrake.calibration.plates.calibrator.PlaneCalibrator` describes.
Error parameters are rad (``dalpha``, ``dtheta``, ``dbeta``) or m (``dd``,
``dr``).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from rmdrake.calibration.config import (
    CALIBRATION_METHODS,
    CalibrationConfig,
    PlaneLMConfig,
    PointLMConfig,
    VolumeDEConfig,
    VolumeDEPlaneLMConfig,
    de_start_budget,
)
from rmdrake.calibration.elastostatic import MAX_PASSES, ComplianceWarning
from rmdrake.calibration.lm import (
    CALIBRATION_LOSSES,
    check_loss,
    solve_lm,
)
from rmdrake.calibration.parameters import parameter_bounds, resolve_parameters
from rmdrake.calibration.plates.calibrator import PlaneCalibrator
from rmdrake.calibration.plates.cost import PlaneProblem, VolumeCost
from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.plates.selection import (
    PlateSelection,
    select_plate_parameters,
)
from rmdrake.model.error_parameters import apply_deltas, is_compliance_name
from rmdrake.model.robot import RobotModel
from rmdrake.optimize import differential_evolution

__all__ = [
    "CALIBRATION_LOSSES",
    "PlaneLM",
    "VolumeDE",
    "VolumeDEPlaneLM",
    "make_calibrator",
    "parameter_bounds",
    "resolve_parameters",
]

CANDIDATE_MAX_NFEV = 100
"""Most residual evaluations of one candidate fit of ``auto``'s choice when
``max_nfev`` is not given; a candidate whose fit on a training fold stops
there is not fitted (its CV is infinite: not chosen). A well-posed fit of the
RV-3SB converges in at most 11 (60 readings, errors of 1 mrad and 0.5 mm on
the full set); on readings the model cannot explain (three wrong plate ids)
fits ran to scipy's 100 x unknowns (3200) and the choice to 30 s."""


class PlaneLM(PlaneCalibrator):
    """Levenberg-Marquardt on signed point-to-plane distances.

    Unknowns: the error parameters and, per plate, its unit normal (two angles
    about the initial normal) and offset (:class:`PlaneProblem`). Initial plates:
    SVD plane fits of the points predicted by the starting model. Residuals,
    analytic Jacobian from :func:`rmdrake.kinematics.forward.point_jacobian`, solved by
    :func:`scipy.optimize.least_squares` (MINPACK ``lm`` for the plain squared
    loss; ``trf`` for a robust loss).

    Args:
      model: the nominal robot.
      params: ``paper``, ``full`` (identifiable subset chosen automatically),
        ``auto`` (chosen by cross-validation over the plates, see the module
        docstring) or a list of names (compliances ``c<j>`` allowed).
      compliance: add every joint's compliance ``c<j>`` (elastostatic).
      x0: starting values of the names (k,), rad or m (compliances in
        rad/(N m)), or of the MDH names only (the compliances then start at the
        nominal's); default zero deltas (the nominal). Not with ``auto``.
      loss: ``linear`` (least squares) or a robust loss of scipy
        (``huber``, ``soft_l1``, ``cauchy``, ``arctan``) against outliers.
      f_scale: residual scale of the robust loss, m (e.g. 3 x the noise).
      xtol, ftol, gtol, max_nfev: passed to least_squares.
      rtol: identifiability threshold (see :mod:`.identifiability`).
      noise: the readings' declared standard deviation for the sanity checks
        of the fit, m (None: estimated from the residuals).
      folds, seed: ``auto``'s cross-validation: K = min(folds, plates) folds
        of the plates shuffled by ``seed``.
      progress: ``auto``: show the candidate sets scored (on stderr).

    The attributes are set by ``fit``.

    Attributes:
      names_, deltas_, std_: the identified parameters, values and standard
        deviations (rad or m).
      selection_: ``auto`` only: the
        :class:`~rmdrake.calibration.plates.selection.PlateSelection`.
      model_: the calibrated RobotModel with its ``calibration`` record.
      normals_, offsets_: the fitted plates (unit normals in B, offsets in m).
      residuals_, residual_rms_, residual_rms_nominal_: m.
      identifiability_: the :class:`IdentifiabilityReport`.
      elastic_passes_: outer passes of an elastic fit (1 when rigid).
      sanity_: the :class:`~rmdrake.calibration.sanity.SanityReport` of the
        fit (its ``reasons`` empty when plausible).
      result_: scipy's OptimizeResult. fit_time_: s.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import PlaneLM, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=8, seed=0).data
    >>> lm = PlaneLM(robot, params="paper").fit(data)
    >>> len(lm.names_), bool(lm.residual_rms_ < lm.residual_rms_nominal_)
    (17, True)
    """

    method = "lm"
    _candidate = False
    """True on a candidate fit of ``auto``'s choice (:meth:`_with`)."""

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        compliance: bool = False,
        x0: np.ndarray | None = None,
        loss: str = "linear",
        f_scale: float = 1e-5,
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
        max_nfev: int | None = None,
        rtol: float = 1e-6,
        folds: int = 5,
        seed: int = 0,
        progress: bool = False,
        noise: float | None = None,
    ) -> None:
        super().__init__(
            model, params=params, compliance=compliance, rtol=rtol, noise=noise
        )
        self.x0 = x0
        self.loss = loss
        self.f_scale = f_scale
        self.xtol = xtol
        self.ftol = ftol
        self.gtol = gtol
        self.max_nfev = max_nfev
        self.folds = folds
        self.seed = seed
        self.progress = progress

    def _with(self, names: Sequence[str]) -> PlaneLM:
        """This estimator's LM options with an explicit parameter list: a
        candidate of ``auto``'s choice (no data checks, one elastic pass, at
        most :data:`CANDIDATE_MAX_NFEV` evaluations unless ``max_nfev`` is
        set, a ValueError when it stops there, only ``deltas_`` and
        ``model_`` after its fit)."""
        est = PlaneLM(
            self.model,
            params=list(names),
            compliance=self.compliance,
            loss=self.loss,
            f_scale=self.f_scale,
            xtol=self.xtol,
            ftol=self.ftol,
            gtol=self.gtol,
            max_nfev=self.max_nfev or CANDIDATE_MAX_NFEV,
            rtol=self.rtol,
        )
        est._candidate = True
        return est

    def select(self, data: PlaneMeasurements) -> PlateSelection:
        """The automatic choice on readings already checked
        (:meth:`check_data`): :func:`~rmdrake.calibration.plates.selection.
        select_plate_parameters` of LM fits with this estimator's options."""
        with warnings.catch_warnings():  # said once, for the chosen set
            warnings.simplefilter("ignore", ComplianceWarning)
            return select_plate_parameters(
                self._with,
                data,
                folds=self.folds,
                seed=self.seed,
                rtol=self.rtol,
                progress=self.progress,
            )

    def fit(self, data: PlaneMeasurements) -> PlaneLM:
        """Calibrates from the readings; returns self."""
        t0 = time.perf_counter()
        check_loss(self.loss, self.f_scale)
        candidate = self._candidate
        auto = self._is_auto()
        if auto:
            if self.x0 is not None:
                raise ValueError(
                    "x0: params 'auto' chooses the parameters from the data; name "
                    "them to give their start"
                )
            self.check_data(data)
            self.selection_ = self.select(data)
        names, idx = self._setup(data, check=not (auto or candidate))
        loads = self._loads
        start = self._start(names, loads)
        x0 = start if self.x0 is None else np.asarray(self.x0, float)
        if x0.shape == (idx.size,) and idx.size != len(names):
            x0 = np.concatenate([x0, start[idx.size :]])
        if x0.shape != (len(names),):
            raise ValueError(f"x0: expected {len(names)} deltas, found {x0.shape}")
        last: list[PlaneProblem] = []

        def fit_once(torques, params):
            normals0, offsets0 = self._plates_at(data, idx, params, torques)
            problem = self._problem(data, idx, normals0, torques)
            result = solve_lm(problem, problem.pack(params, offsets0), self)
            last[:] = [problem]
            return result, result.x[: len(names)]

        most = 1 if candidate else MAX_PASSES
        result, _, self.elastic_passes_ = loads.passes(fit_once, x0, most)
        deltas, normals, offsets = last[0].unpack(result.x)
        if candidate:  # fitted only to score held-out plates
            if result.status == 0:  # stopped at max_nfev: not a model to choose
                raise ValueError(
                    f"candidate {','.join(names)}: no convergence in "
                    f"{result.nfev} evaluations"
                )
            self.deltas_ = deltas.copy()
            self.model_ = apply_deltas(self.model, names, self.deltas_)
            return self
        robust = self.loss != "linear"
        self.result_ = result
        options: dict[str, Any] = {"loss": self.loss}
        if robust:
            options["f_scale"] = self.f_scale
        planes = (normals, offsets)
        self._finish(data, names, idx, deltas.copy(), t0, planes, options)
        return self


class VolumeDE(PlaneCalibrator):
    """The paper's method: Differential Evolution on the tetrahedron volumes.

    Minimises eq. 5, sum over plates and quadruples of |V_t| (m^3), over the
    error parameters inside ``bounds``, with :func:`rmdrake.optimize.
    differential_evolution` (the whole population in one vectorised cost call,
    seeded, the nominal placed in the first population). The quadruples are
    fixed: all 4-subsets of each plate's readings, or ``max_per_plate`` of them
    (:func:`~rmdrake.calibration.plates.cost.plate_quadruples`).

    Args:
      model, params, rtol, noise: as :class:`PlaneLM`.
      bounds: (k, 2) bounds, or None for +-``length_bound`` m and
        +-``angle_bound`` rad (:func:`parameter_bounds`).
      popsize, maxiter, tol, mutation, recombination: DE options (scipy's).
      seed: seed of the DE.
      max_per_plate: quadruples per plate (None: all C(m, 4); the default 100
        keeps a generation of 255 candidates x 500 volumes cheap).
      progress: show a progress bar.

    Attributes (after fit): as :class:`PlaneLM` (std_ evaluated at the DE
    solution with SVD-fitted plates), plus ``cost_`` and ``cost_nominal_``
    (m^3), ``result_`` = ``de_result_`` (the DE's OptimizeResult) and
    ``at_bounds_`` (the parameters the DE left within 0.1 % of the bounds'
    width from a bound).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import VolumeDE, simulate_plates
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_plates(robot, plates=4, per_plate=6, seed=0).data
    >>> de = VolumeDE(robot, params=["dtheta2", "dtheta3"], maxiter=5, popsize=5)
    >>> de = de.fit(data)
    >>> de.method, de.deltas_.shape
    ('de', (2,))
    """

    method = "de"

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        compliance: bool = False,
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
        noise: float | None = None,
    ) -> None:
        super().__init__(
            model, params=params, compliance=compliance, rtol=rtol, noise=noise
        )
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
        c = [n for n in names if is_compliance_name(n)]
        if c:
            raise ValueError(
                f"method de: the compliances {', '.join(c)} need the least-squares "
                "fit (method lm or de+lm)"
            )
        loads = self._loads
        if loads.active:  # a nominal with elastic joints: its link angles
            start = self._start(names, loads)
            q = loads.link_angles(start, loads.torques(start))
            data = dataclasses.replace(data, q=q)
        bounds = (
            parameter_bounds(names, self.length_bound, self.angle_bound)
            if self.bounds is None
            else np.asarray(self.bounds, dtype=np.float64)
        )
        if bounds.shape != (len(names), 2):
            raise ValueError(
                f"bounds: expected shape ({len(names)}, 2), found {bounds.shape}"
            )
        cost = VolumeCost(
            self.model.table,
            data,
            idx,
            max_per_plate=self.max_per_plate,
            sigma=self.model.sigma,
        )
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
        """Calibrates from the readings; returns self.

        Raises:
          ValueError: ``params`` ``auto`` (its choice cross-validates LM fits:
            method lm or de+lm), bad readings or parameters (one line).
        """
        t0 = time.perf_counter()
        if self._is_auto():
            raise ValueError(
                "params 'auto' is chosen by cross-validating LM fits: use method "
                "lm or de+lm (method de takes paper, full or names)"
            )
        names, idx = self._setup(data)
        x = self._run_de(data, names, idx)
        self.result_ = self.de_result_
        self._finish(data, names, idx, x, t0, options=self._options())
        return self


class VolumeDEPlaneLM(PlaneCalibrator):
    """``de+lm``: the paper's DE on volumes as a global start, then
    :class:`PlaneLM` from its result.

    Fits a :class:`VolumeDE` with ``de_options``, then a :class:`PlaneLM` with
    ``x0`` = the DE's deltas, both with this estimator's ``params`` and ``rtol``.
    With ``params="auto"`` the set is chosen first (:meth:`PlaneLM.select`:
    LM fits from the nominal, cross-validated over the plates, the DE's
    ``seed`` seeding the split), then the DE and the LM fit the chosen names:
    the DE only gives the LM its start, so it takes no part in the choice.

    Args:
      model, params, rtol, noise: as :class:`PlaneLM` (``params`` ``auto``
        too).
      loss, f_scale: the LM's loss, as :class:`PlaneLM`.
      folds: ``auto``'s K-fold split over the plates (K = min(folds, plates)).
      de_options: keyword options of :class:`VolumeDE` (``bounds``,
        ``length_bound``, ``angle_bound``, ``popsize``, ``maxiter``, ``tol``,
        ``mutation``, ``recombination``, ``seed``, ``max_per_plate``,
        ``progress``), with a smaller budget by default (``popsize`` 10,
        ``maxiter`` 100, ``max_per_plate`` 30: the DE only has to land in LM's
        basin of attraction).

    Attributes (after fit): as :class:`PlaneLM` (the LM's results; the
    ``calibration`` record names method ``de+lm`` and both option sets, time
    in s from the start of the DE), plus ``de_`` and ``lm_`` (the fitted
    estimators), ``de_deltas_`` (the DE result), ``cost_``, ``cost_nominal_``,
    ``de_result_``, ``at_bounds_`` of the DE and ``de_time_`` (s), and with
    ``auto`` ``selection_`` (the DE's time then includes the choice's).

    Raises:
      TypeError: an unknown DE option (at construction).

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import VolumeDEPlaneLM
    >>> VolumeDEPlaneLM(load_robot("rv3sb"), maxiter=50).method
    'de+lm'
    """

    method = "de+lm"
    _DE_BUDGET: dict[str, Any] = {
        name: getattr(de_start_budget(), name)
        for name in ("popsize", "maxiter", "max_per_plate")
    }

    def __init__(
        self,
        model: RobotModel,
        *,
        params: str | Sequence[str] = "paper",
        compliance: bool = False,
        loss: str = "linear",
        f_scale: float = 1e-5,
        rtol: float = 1e-6,
        folds: int = 5,
        noise: float | None = None,
        **de_options: Any,
    ) -> None:
        super().__init__(
            model, params=params, compliance=compliance, rtol=rtol, noise=noise
        )
        self.loss = loss
        self.f_scale = f_scale
        self.folds = folds
        self.de_options = {**self._DE_BUDGET, **de_options}
        self._volume_de()  # an unknown option fails here, not after a fit

    def _volume_de(self, params: str | Sequence[str] | None = None) -> VolumeDE:
        """The DE of ``params`` (default this estimator's; before the choice
        ``auto`` builds one of ``paper`` only to check the DE options)."""
        params = self.params if params is None else params
        if isinstance(params, str) and params == "auto":
            params = "paper"
        if not isinstance(params, str) or params not in ("paper", "full"):
            names = resolve_parameters(self.model, params)
            params = [n for n in names if not is_compliance_name(n)]
        return VolumeDE(self.model, params=params, rtol=self.rtol, **self.de_options)

    def fit(self, data: PlaneMeasurements) -> VolumeDEPlaneLM:
        """Calibrates from the readings; returns self."""
        t0 = time.perf_counter()
        check_loss(self.loss, self.f_scale)
        params = self.params
        if self._is_auto():
            self.check_data(data)
            self.selection_ = self._plane_lm("auto").select(data)
            params = list(self.selection_.chosen)
        de = self._volume_de(params).fit(data)
        self.de_time_ = time.perf_counter() - t0
        lm = self._plane_lm(params, x0=de.deltas_).fit(data)
        self.de_, self.lm_ = de, lm
        self.de_deltas_, self.de_result_ = de.deltas_, de.de_result_
        self.cost_, self.cost_nominal_ = de.cost_, de.cost_nominal_
        self.at_bounds_ = de.at_bounds_
        self.names_, self.identifiability_ = lm.names_, lm.identifiability_
        self.elastic_passes_, self._loads = lm.elastic_passes_, lm._loads
        self._torques = lm._torques
        self.deltas_, self.std_, self.result_ = lm.deltas_, lm.std_, lm.result_
        self.normals_, self.offsets_ = lm.normals_, lm.offsets_
        self.residuals_, self.residual_rms_ = lm.residuals_, lm.residual_rms_
        self.residual_rms_nominal_ = lm.residual_rms_nominal_
        self.data_, self.sanity_ = lm.data_, lm.sanity_
        self.fit_time_ = time.perf_counter() - t0
        record = dict(lm.model_.calibration)
        record["method"] = self.method
        record["options"] = {**record["options"], **de.model_.calibration["options"]}
        if self._is_auto():
            record["selection"] = self.selection_.record()
        self.model_ = dataclasses.replace(lm.model_, calibration=record)
        return self

    def _plane_lm(
        self, params: str | Sequence[str], x0: np.ndarray | None = None
    ) -> PlaneLM:
        """The LM stage of ``params`` from ``x0``; its ``auto`` split is seeded
        by the DE's ``seed`` and shows progress with the DE's ``progress``."""
        return PlaneLM(
            self.model,
            params=params,
            compliance=self.compliance,
            x0=x0,
            loss=self.loss,
            f_scale=self.f_scale,
            rtol=self.rtol,
            folds=self.folds,
            noise=self.noise,
            seed=int(self.de_options.get("seed", 0)),
            progress=bool(self.de_options.get("progress", False)),
        )


def make_calibrator(
    method: str | CalibrationConfig, model: RobotModel, **options: Any
) -> PlaneLM | VolumeDE | VolumeDEPlaneLM:
    """The plate estimator of a method name with its class's keyword
    arguments, or of a :class:`~rmdrake.calibration.config.CalibrationConfig`.

    Args:
      method: one of :data:`CALIBRATION_METHODS` (``options`` are then the
        keyword arguments of its class), or a config whose ``calibrator`` is a
        plate method (:class:`~rmdrake.calibration.config.PlaneLMConfig`,
        :class:`~rmdrake.calibration.config.VolumeDEConfig`,
        :class:`~rmdrake.calibration.config.VolumeDEPlaneLMConfig`; None =
        ``de+lm`` with its defaults) and no ``options``: its ``params`` (None =
        ``auto`` for ``lm`` and ``de+lm``, ``paper`` for ``de``), ``compliance``,
        ``rtol`` and ``noise`` go to every method, ``loss`` and ``f_scale`` to
        those with an LM, the DE options to those with a DE, ``selection_folds`` (and
        ``seed`` of :class:`~rmdrake.calibration.config.PlaneLMConfig`) to
        ``auto``'s cross-validation.
      model: the nominal robot.

    Raises:
      ValueError: an unknown method name, or a config of point measurements
        (:class:`~rmdrake.calibration.config.PointLMConfig`).
      TypeError: ``options`` given with a config; an option the class does not
        take.

    Example:

    >>> from rmdrake import load_robot
    >>> from rmdrake.calibration import CalibrationConfig, PlaneLMConfig
    >>> from rmdrake.calibration import make_calibrator
    >>> robot = load_robot("rv3sb")
    >>> type(make_calibrator("lm", robot)).__name__
    'PlaneLM'
    >>> config = CalibrationConfig(params="paper", calibrator=PlaneLMConfig())
    >>> type(make_calibrator(config, robot)).__name__
    'PlaneLM'
    """
    if isinstance(method, CalibrationConfig):
        if options:
            raise TypeError(
                "make_calibrator: a CalibrationConfig takes no keyword options, "
                f"found {', '.join(options)}"
            )
        return _from_config(method, model)
    classes = {"de": VolumeDE, "lm": PlaneLM, "de+lm": VolumeDEPlaneLM}
    if method not in CALIBRATION_METHODS:
        raise ValueError(
            f"unknown method '{method}': expected one of "
            f"{', '.join(CALIBRATION_METHODS)}"
        )
    return classes[method](model, **options)


def _de_options(de: VolumeDEConfig) -> dict[str, Any]:
    """The keyword arguments of :class:`VolumeDE` of ``de``."""
    return {
        "seed": de.seed,
        "popsize": de.popsize,
        "maxiter": de.maxiter,
        "tol": de.tol,
        "max_per_plate": de.max_per_plate,
        "length_bound": de.length_bound,
        "angle_bound": de.angle_bound,
        "progress": de.progress,
    }


def _from_config(
    config: CalibrationConfig, model: RobotModel
) -> PlaneLM | VolumeDE | VolumeDEPlaneLM:
    """:func:`make_calibrator` of a config."""
    calibrator = config.calibrator
    if calibrator is None:
        calibrator = VolumeDEPlaneLMConfig()
    default = "paper" if isinstance(calibrator, VolumeDEConfig) else "auto"
    common: dict[str, Any] = {
        "params": default if config.params is None else config.params,
        "compliance": config.compliance,
        "rtol": config.rtol,
        "noise": config.noise,
    }
    lm = {"loss": config.loss, "f_scale": config.f_scale}
    if isinstance(calibrator, PlaneLMConfig):
        return PlaneLM(
            model,
            **common,
            **lm,
            max_nfev=calibrator.max_nfev,
            folds=calibrator.selection_folds,
            seed=calibrator.seed,
        )
    if isinstance(calibrator, VolumeDEConfig):
        return VolumeDE(model, **common, **_de_options(calibrator))
    if isinstance(calibrator, VolumeDEPlaneLMConfig):
        return VolumeDEPlaneLM(
            model,
            **common,
            **lm,
            folds=calibrator.selection_folds,
            **_de_options(calibrator.de),
        )
    if isinstance(calibrator, PointLMConfig):
        raise ValueError(
            "PointLMConfig calibrates point measurements "
            "(rmdrake.calibration.points.lm.make_point_calibrator); the plate "
            "methods are VolumeDEPlaneLMConfig, PlaneLMConfig and VolumeDEConfig"
        )
    raise TypeError(
        f"calibrator: expected a plate method config, found {type(calibrator).__name__}"
    )
