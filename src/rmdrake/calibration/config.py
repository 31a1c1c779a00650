"""The kinematic calibration's settings: one typed config for every way in
(``rmdrake calibrate``, :func:`rmdrake.pipelines.calibrate.calibrate_file`,
:func:`~rmdrake.calibration.plates.estimators.make_calibrator`,
:func:`~rmdrake.calibration.points.lm.make_point_calibrator`, the studies that
calibrate).

:class:`CalibrationConfig` holds what every method shares (the parameters, the
LM loss, the identifiability threshold, the declared reading noise, whether an
implausible result is written); its ``calibrator`` is a tagged choice of one
method's own options (``CalibratorConfig``):

* :class:`VolumeDEPlaneLMConfig` (method ``de+lm``, plates): the paper's DE as
  the start of LM (after ``auto``'s choice of the parameters, the default);
  its DE options are a :class:`VolumeDEConfig` with a smaller budget;
* :class:`PlaneLMConfig` (``lm``, plates): LM on point-to-plane distances;
* :class:`VolumeDEConfig` (``de``, plates): the paper's DE on tetrahedron
  volumes;
* :class:`PointLMConfig` (``lm`` on measured tool points);
* None: the measurements' default, ``VolumeDEPlaneLMConfig()`` on plane
  measurements and ``PointLMConfig()`` on point measurements.

Each alternative names its method in the class attribute ``method``. Every
class is a keyword-only dataclass with defaults, so Drake's YAML functions read
and write it (``yaml_load_typed(schema=CalibrationConfig, data=text)``): a
missing key keeps its default, an unknown key fails to load, an alternative is
chosen by its class name as tag (``calibrator: !VolumeDEConfig {maxiter:
200}``) and an untagged mapping is the first alternative
(:class:`VolumeDEPlaneLMConfig`). Values are checked by the estimators when
they fit (an unknown loss, a parameter name, a fold count).

Units: SI. Lengths in m, angles in rad, compliances in rad/(N m) (m/N on a
slide); noise levels are standard deviations.

No ``from __future__ import annotations``: Drake's loader reads the field types
at run time.
"""

import dataclasses
from typing import Any, ClassVar

__all__ = [
    "CALIBRATION_METHODS",
    "DEFAULT_DISTANCE_NOISE",
    "MAX_DISTANCE_NOISE",
    "CalibrationConfig",
    "CalibratorConfig",
    "PlaneLMConfig",
    "PlateCalibratorConfig",
    "PointLMConfig",
    "SocketLMConfig",
    "VolumeDEConfig",
    "VolumeDEPlaneLMConfig",
    "de_start_budget",
    "plate_calibrator_config",
    "with_de_options",
]


DEFAULT_DISTANCE_NOISE = 1e-5
"""Standard deviation of a known socket distance, m (a machined or well
printed plate): :class:`SocketLMConfig`'s default."""

MAX_DISTANCE_NOISE = 1e-2
"""m: the largest standard deviation of a known socket distance
(:class:`SocketLMConfig`'s ``distance_noise``): a distance known no better
than 10 mm fixes no length scale; a larger figure is one in mm."""


@dataclasses.dataclass(kw_only=True)
class VolumeDEConfig:
    """Method ``de``: the paper's Differential Evolution on the tetrahedron
    volumes of the plate readings
    (:class:`~rmdrake.calibration.plates.estimators.VolumeDE`). Plane
    measurements only; it fits no compliance.

    Attributes:
      seed: seed of the DE (the same seed gives the same result).
      popsize: population per parameter.
      maxiter: generations.
      tol: the DE's relative convergence tolerance on the population's cost
        spread (scipy's ``tol``).
      max_per_plate: fixed point quadruples per plate in the volume cost; None
        = all C(m, 4) of a plate's m readings.
      length_bound: half-width of the search box on the length parameters
        (``dd``, ``dr``), m.
      angle_bound: half-width of the search box on the angle parameters
        (``dalpha``, ``dtheta``, ``dbeta``), rad.
      progress: show a progress bar of the generations (on stderr).

    Example:

    >>> from rmdrake.calibration import VolumeDEConfig
    >>> VolumeDEConfig(maxiter=50, popsize=10).maxiter
    50
    """

    method: ClassVar[str] = "de"

    seed: int = 0
    popsize: int = 15
    maxiter: int = 1000
    tol: float = 1e-4
    max_per_plate: int | None = 100
    length_bound: float = 3e-3
    angle_bound: float = 3e-3
    progress: bool = False


def de_start_budget() -> VolumeDEConfig:
    """The DE options of ``de+lm`` by default: :class:`VolumeDEConfig` with a
    smaller budget (population 10 per parameter, 100 generations, 30
    quadruples per plate), since that DE only has to land in LM's basin of
    attraction.

    Example:

    >>> from rmdrake.calibration import de_start_budget
    >>> type(de_start_budget()).__name__
    'VolumeDEConfig'
    """
    return VolumeDEConfig(popsize=10, maxiter=100, max_per_plate=30)


@dataclasses.dataclass(kw_only=True)
class VolumeDEPlaneLMConfig:
    """Method ``de+lm`` (the plates' default): the paper's DE on volumes as a
    global start, then LM on point-to-plane distances from its result
    (:class:`~rmdrake.calibration.plates.estimators.VolumeDEPlaneLM`). The LM
    takes the common options of :class:`CalibrationConfig` (``loss``,
    ``f_scale``); the DE searches the geometric parameters only. With
    ``params`` ``auto`` (the default) the set is chosen first by LM fits
    cross-validated over the plates, the split seeded by the DE's ``seed``;
    the DE and the LM then fit the chosen set.

    Attributes:
      de: the DE's options (default :func:`de_start_budget`).
      selection_folds: K of ``auto``'s K-fold cross-validation over the plates
        (K = min(selection_folds, plates)).

    Example:

    >>> from rmdrake.calibration import VolumeDEConfig, VolumeDEPlaneLMConfig
    >>> VolumeDEPlaneLMConfig(de=VolumeDEConfig(maxiter=50)).de.maxiter
    50
    """

    method: ClassVar[str] = "de+lm"

    de: VolumeDEConfig = dataclasses.field(default_factory=de_start_budget)
    selection_folds: int = 5


@dataclasses.dataclass(kw_only=True)
class PlaneLMConfig:
    """Method ``lm`` on plane measurements: Levenberg-Marquardt on the signed
    point-to-plane distances, each plate's pose an unknown too
    (:class:`~rmdrake.calibration.plates.estimators.PlaneLM`), with the common
    options of :class:`CalibrationConfig` (``loss``, ``f_scale``).

    Attributes:
      max_nfev: most residual evaluations of the least-squares solve; None =
        scipy's default.
      seed: seeds ``auto``'s split of the plates.
      selection_folds: K of ``auto``'s K-fold cross-validation over the plates
        (K = min(selection_folds, plates)).

    Example:

    >>> from rmdrake.calibration import CalibrationConfig, PlaneLMConfig
    >>> CalibrationConfig(calibrator=PlaneLMConfig(seed=1)).calibrator.selection_folds
    5
    """

    method: ClassVar[str] = "lm"

    max_nfev: int | None = None
    seed: int = 0
    selection_folds: int = 5


@dataclasses.dataclass(kw_only=True)
class PointLMConfig:
    """Method ``lm`` on point measurements (laser tracker, motion capture):
    Levenberg-Marquardt on the 3-D tool points, the instrument pose and the
    markers unknowns too (:class:`~rmdrake.calibration.points.lm.PointLM`),
    with the common options of :class:`CalibrationConfig`.

    Cross-validation splits the poses, never the points of one pose. Two uses:
    ``params`` ``auto`` chooses the parameter set by ``selection_folds``-fold
    cross-validation (``repeats`` seeded splits, pooled); ``folds`` or
    ``holdout`` (at most one) also report the cross-validated 3-D point error
    of the whole calibration (:func:`rmdrake.pipelines.calibrate.
    calibrate_file`; nested, the automatic choice rerun inside each training
    set, when ``params`` is ``auto``).

    Attributes:
      seed: seeds every pose split (the selection's and the reported one).
      selection_folds: K of the automatic choice's K-fold cross-validation.
      repeats: seeded K-fold splits of the automatic choice, pooled.
      folds: report the error over K folds of the poses; None = not.
      holdout: report the error over one held-out fraction of the poses (0 <
        fraction < 1); None = not.
      max_nfev: most residual evaluations of each least-squares solve; None =
        scipy's default.

    Example:

    >>> from rmdrake.calibration import PointLMConfig
    >>> PointLMConfig(holdout=0.25).holdout
    0.25
    """

    method: ClassVar[str] = "lm"

    seed: int = 0
    selection_folds: int = 5
    repeats: int = 1
    folds: int | None = None
    holdout: float | None = None
    max_nfev: int | None = None


@dataclasses.dataclass(kw_only=True)
class SocketLMConfig:
    """Method ``lm`` on socket measurements (a ball seated in fixed sockets):
    Levenberg-Marquardt on the predicted ball positions, one unknown point per
    socket (:class:`~rmdrake.calibration.sockets.lm.SocketLM`), with the
    common options of :class:`CalibrationConfig` (``noise``: the seating
    repeatability per coordinate, m).

    Cross-validation holds out whole placements (the sockets joined by known
    distances), never rows of one socket: ``params`` ``auto`` chooses by it,
    and ``folds`` ``placements`` also reports the held-out consistency and
    distortion of the whole calibration (nested when ``params`` is ``auto``).

    Attributes:
      distance_noise: std of a known distance between sockets, m.
      drop_outliers: drop configurations far from their socket and refit,
        instead of refusing the fit.
      folds: ``placements`` to report leave-one-placement-out figures; None =
        not.
      max_nfev: most residual evaluations of each least-squares solve.

    Example:

    >>> from rmdrake.calibration import SocketLMConfig
    >>> SocketLMConfig(distance_noise=5e-6, drop_outliers=True).drop_outliers
    True
    """

    method: ClassVar[str] = "lm"

    distance_noise: float = DEFAULT_DISTANCE_NOISE
    drop_outliers: bool = False
    folds: str | None = None
    max_nfev: int | None = None


PlateCalibratorConfig = VolumeDEPlaneLMConfig | PlaneLMConfig | VolumeDEConfig
"""The methods of plane measurements; the first is their default."""

CalibratorConfig = (
    VolumeDEPlaneLMConfig
    | PlaneLMConfig
    | VolumeDEConfig
    | PointLMConfig
    | SocketLMConfig
)
"""Every method's config; the first is the YAML default of an untagged
mapping."""


@dataclasses.dataclass(kw_only=True)
class CalibrationConfig:
    """One kinematic calibration: the options every method shares, and the
    method with its own options.

    Attributes:
      params: the error parameters fitted. Plates: ``auto`` (chosen by
        cross-validation over the plates, methods ``lm`` and ``de+lm``:
        :mod:`rmdrake.calibration.plates.selection`), ``paper`` (the 17 of
        Wang et al. 2016, Table 1), ``full`` (the identifiable subset, chosen)
        or comma-separated names; points: ``auto`` (chosen by
        cross-validation), ``base`` (none: instrument pose and markers only),
        ``offsets``, ``full`` or names. None = ``auto``, except ``paper`` for
        the plates' method ``de`` (its DE alone cannot cross-validate).
      compliance: also fit every joint's compliance ``c<j>`` (elastostatic
        calibration; the robot needs ``dynamics``, and readings under several
        payloads make the compliances visible); not with method ``de``.
      loss: the least-squares loss of every LM (``lm``, ``de+lm``'s LM, the
        points' LM; the DE alone has none): ``linear``, or a robust loss of
        scipy against outliers (``huber``, ``soft_l1``, ``cauchy``,
        ``arctan``).
      f_scale: residual scale of a robust loss, m (e.g. 3 x the noise).
      rtol: identifiability threshold (dimensionless): a parameter is kept
        when its unit-scaled column of the identification Jacobian keeps a
        residual norm above ``rtol`` after removing what the plates (or
        instrument pose and markers) and the parameters kept before it explain
        (:mod:`rmdrake.calibration.identifiability`).
      noise: the readings' declared standard deviation, m, for the sanity
        checks of the result; None = estimated from the fit's residuals.
      force: write the result even when its sanity checks fail (the reasons
        are then recorded with it; :func:`rmdrake.pipelines.calibrate.
        calibrate_file`).
      calibrator: the method and its options (``CalibratorConfig``); None = the
        measurements' default (``de+lm`` on plates, ``lm`` on points, default
        options).

    Example:

    >>> from rmdrake.calibration import CalibrationConfig, PointLMConfig
    >>> config = CalibrationConfig(params="offsets", calibrator=PointLMConfig(folds=4))
    >>> config.params, type(config.calibrator).__name__, config.calibrator.folds
    ('offsets', 'PointLMConfig', 4)
    """

    params: str | None = None
    compliance: bool = False
    loss: str = "linear"
    f_scale: float = 1e-5
    rtol: float = 1e-6
    noise: float | None = None
    force: bool = False
    calibrator: CalibratorConfig | None = None


_PLATE_METHODS = (VolumeDEConfig, PlaneLMConfig, VolumeDEPlaneLMConfig)
CALIBRATION_METHODS: tuple[str, ...] = tuple(k.method for k in _PLATE_METHODS)
"""The plate methods (:func:`plate_calibrator_config`,
:func:`rmdrake.calibration.plates.estimators.make_calibrator`): the paper's DE
on volumes, LM on point-to-plane distances, and DE as LM's start."""


def plate_calibrator_config(method: str) -> PlateCalibratorConfig:
    """The default config of plate method ``method`` (``de``, ``lm`` or
    ``de+lm``, :data:`~rmdrake.calibration.config.CALIBRATION_METHODS`).

    Raises:
      ValueError: an unknown method (one line listing the known ones).

    Example:

    >>> from rmdrake.calibration import plate_calibrator_config
    >>> [type(plate_calibrator_config(m)).__name__ for m in ("lm", "de", "de+lm")]
    ['PlaneLMConfig', 'VolumeDEConfig', 'VolumeDEPlaneLMConfig']
    """
    for kind in _PLATE_METHODS:
        if kind.method == method:
            return kind()
    raise ValueError(
        f"unknown method '{method}': expected one of {', '.join(CALIBRATION_METHODS)}"
    )


def with_de_options(calibrator: CalibratorConfig, **options: Any) -> CalibratorConfig:
    """``calibrator`` with ``options`` (fields of :class:`VolumeDEConfig`)
    replaced in its DE: its own fields for ``de``, those of its ``de`` for
    ``de+lm``; a method without a DE (``lm``) is returned unchanged.

    Raises:
      TypeError: a name that is not a :class:`VolumeDEConfig` field.

    Example:

    >>> from rmdrake.calibration import VolumeDEConfig, with_de_options
    >>> with_de_options(VolumeDEConfig(), maxiter=20, seed=3).maxiter
    20
    """
    if isinstance(calibrator, VolumeDEConfig):
        return dataclasses.replace(calibrator, **options)
    if isinstance(calibrator, VolumeDEPlaneLMConfig):
        return dataclasses.replace(
            calibrator, de=dataclasses.replace(calibrator.de, **options)
        )
    known = {f.name for f in dataclasses.fields(VolumeDEConfig)}
    unknown = sorted(set(options) - known)
    if unknown:
        raise TypeError(f"not DE options: {', '.join(unknown)}")
    return calibrator
