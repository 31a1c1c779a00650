"""``rmdrake calibrate``: measurements in, a calibrated robot YAML out. The
measurements' kind (:mod:`rmdrake.calibration.registry`) is read from the
file's header; the kind reads the file, builds its estimator and its
cross-validation, and the fit's sanity checks (:mod:`rmdrake.calibration.
sanity`) refuse an implausible result with
:class:`~rmdrake.errors.ImplausibleResultError`, writing nothing, unless
forced."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from rmdrake.calibration.config import CalibrationConfig
from rmdrake.calibration.elastostatic import require_payloads
from rmdrake.calibration.kind import MeasurementKind
from rmdrake.calibration.registry import kind_of_file
from rmdrake.model.loading import Robot, as_robot_model
from rmdrake.pipelines.checked import Echo, write_checked

__all__ = ["calibrate_file"]


def calibrate_file(
    robot: Robot,
    measurements: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: CalibrationConfig | None = None,
    echo: Echo = print,
    distances: Sequence[tuple[int, int, float]] = (),
    kind: MeasurementKind | None = None,
) -> Path:
    """Calibrates ``robot`` from a plane-, point- or socket-measurement CSV
    (told apart by the header,
    :func:`rmdrake.calibration.registry.kind_of_file`); writes the
    calibrated robot YAML (its ``calibration`` record names the file).

    Args:
      config: the calibration (None = ``CalibrationConfig()``: ``de+lm`` on
        plates, ``lm`` on points and sockets, with ``auto`` parameters: chosen
        by cross-validation over the plates, poses or placements). The kind
        builds the estimator
        (:meth:`~rmdrake.calibration.kind.MeasurementKind.calibrator`; a
        plate's summary lists the automatic choice's candidates) and the
        cross-validation the config asks for
        (:meth:`~rmdrake.calibration.kind.MeasurementKind.cross_validate`:
        a :class:`~rmdrake.calibration.config.PointLMConfig`'s ``folds`` or
        ``holdout`` report the 3-D point error over K folds of the poses or
        one held-out fraction of them; a
        :class:`~rmdrake.calibration.config.SocketLMConfig`'s ``folds``
        ``placements`` the leave-one-placement-out consistency and
        distortion; nested when ``params`` is ``auto``), recorded as the
        record's ``cross_validation``. ``noise`` (m; None: estimated from the
        data) replaces the estimated noise in the sanity checks; ``force``
        writes the result even when its sanity checks fail: the reasons are
        then printed as warnings and recorded as the ``warnings`` list of the
        YAML's ``calibration`` record. With ``compliance`` (elastostatic
        calibration, :mod:`rmdrake.calibration.elastostatic`; the robot needs
        ``dynamics``; readings under two or more payloads make the
        compliances visible, and readings all at one payload are refused:
        :func:`~rmdrake.calibration.elastostatic.require_payloads`) the YAML
        gets ``compliance: {stiffness}`` of the identified joints (N m/rad)
        and the record their ``compliance``.
      echo: where the summary lines go.
      distances: sockets only: known distances ``(a, b, metres)`` added to
        those of the distance file beside the CSV
        (:func:`~rmdrake.calibration.sockets.data.read_socket_measurements`).
      kind: the measurements' kind when the caller has read it already; None
        = read from the header.

    Raises:
      ValueError: the config's method does not calibrate this kind of
        measurements (a :class:`~rmdrake.calibration.config.PointLMConfig` on
        plane measurements, a plate method on point measurements), or the
        measurements or options are invalid (one line).
      ImplausibleResultError: the sanity checks failed and not ``force``
        (nothing written; ``reasons`` one line per failed check, ``result``
        the calibrated RobotModel).

    Example:

    >>> from rmdrake import load_robot, write_point_measurements
    >>> from rmdrake.calibration import CalibrationConfig, PointLMConfig
    >>> from rmdrake.calibration import simulate_points
    >>> from rmdrake.pipelines import calibrate_file
    >>> robot = load_robot("rv3sb")
    >>> data = simulate_points(robot, poses=20, noise=2e-5, seed=1).data
    >>> csv = write_point_measurements("points.csv", data)
    >>> lm = PointLMConfig()
    >>> config = CalibrationConfig(params="offsets", noise=2e-5, calibrator=lm)
    >>> quiet = lambda line: None
    >>> out = calibrate_file(robot, csv, "cal.yaml", config=config, echo=quiet)
    >>> out.name, out.exists()
    ('cal.yaml', True)
    """
    config = CalibrationConfig() if config is None else config
    model = as_robot_model(robot)
    kind = kind_of_file(measurements) if kind is None else kind
    # progress: the choice of parameters can take a minute
    est = kind.calibrator(config, model, progress=True)  # refuses another method
    data = kind.read(measurements, model.n_joints, distances=distances)
    if config.compliance and hasattr(data, "payload_masses"):
        require_payloads(data.payload_masses)  # before the fit: one line
    est.fit(data)
    sanity = est.sanity_  # its checks ran in the fit, against config.noise
    record = dict(est.model_.calibration)
    record["data"] = {**record["data"], "file": str(measurements)}
    if sanity.warnings:
        record["sanity_warnings"] = list(sanity.warnings)
    echo(kind.describe(model, data, measurements))
    echo(est.summary())
    cv = kind.cross_validate(config, model, data, est)
    if cv is not None:
        record["cross_validation"] = cv.record
        for line in cv.lines:
            echo(line)
    echo(sanity.summary())
    for warning in sanity.warnings:
        echo(f"warning: {warning}")
    return write_checked(
        est.model_, record, list(sanity.reasons), out, force=config.force, echo=echo
    )
