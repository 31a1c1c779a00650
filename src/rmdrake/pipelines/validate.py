"""``rmdrake validate``: held-out torque figures of identified robots on a log.

:func:`validate_file` reads one or several robots and one or several joint
logs, prepares each log exactly as ``identify`` does
(:func:`rmdrake.dynamics.log_samples.prepare_logs`, then
:func:`rmdrake.dynamics.data.stack_samples`: logs never meet), predicts
each robot's joint efforts from its ``dynamics`` and friction
(:func:`rmdrake.dynamics.validation.torque_errors`), prints per joint the RMS
error and the relative RMS error (error RMS / measured RMS) side by side, one
column per robot, and optionally draws the paper's Fig. 7 (measured vs predicted
effort per joint, one predicted line per robot). Each robot's prediction is
then judged by the rule ``identify`` uses
(:func:`rmdrake.dynamics.sanity.check_prediction`, the log checked first by
:func:`rmdrake.dynamics.sanity.check_log`): the figures and the plot
are always written; a robot the log refutes raises
:class:`~rmdrake.errors.ImplausibleResultError` (exit 3) unless forced.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rmdrake.dynamics.data import stack_samples
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.sanity import check_log, check_prediction
from rmdrake.dynamics.validation import TorqueErrors, check_models, torque_errors
from rmdrake.errors import ImplausibleResultError
from rmdrake.kinematics.clearance import ClearanceChecker
from rmdrake.model.loading import load_robot
from rmdrake.model.robot import RobotModel
from rmdrake.model.scene import Cell
from rmdrake.report.plots import plot_torque_comparison
from rmdrake.systems.visualization import save_robot_poses_html

__all__ = ["robot_labels", "validate_file"]

Echo = Callable[[str], None]
Robot = RobotModel | str | os.PathLike
"""A robot: a loaded model, a shipped name, a robot YAML or a URDF path."""


def robot_labels(robots: Sequence[Robot]) -> list[str]:
    """One distinct column label per robot: the file name (a model's name for a
    loaded model), the path as given where two file names coincide, and a
    ``#k`` suffix for a robot given twice.

    Example:

    >>> from rmdrake.pipelines import robot_labels
    >>> robot_labels(["rv3sb", "arm/identified.yaml", "rv3sb"])
    ['rv3sb', 'identified.yaml', 'rv3sb#2']
    """
    names = [r.name if isinstance(r, RobotModel) else Path(r).name for r in robots]
    full = [r.name if isinstance(r, RobotModel) else str(r) for r in robots]
    labels = [f if names.count(s) > 1 else s for s, f in zip(names, full, strict=True)]
    seen: dict[str, int] = {}
    out = []
    for label in labels:
        seen[label] = seen.get(label, 0) + 1
        out.append(label if seen[label] == 1 else f"{label}#{seen[label]}")
    return out


def validate_file(
    robots: Sequence[Robot],
    log_path: str | os.PathLike | Sequence[str | os.PathLike],
    *,
    plot: str | os.PathLike | None = None,
    html: str | os.PathLike | None = None,
    cell: Cell | None = None,
    coulomb_width: float = 0.0,
    force: bool = False,
    echo: Echo = print,
    **preparation: Any,
) -> TorqueErrors:
    """Validates each robot's dynamics on a joint log; prints the figures.

    Args:
      robots: one or more robots with ``dynamics``, all with the log's joint
        count.
      log_path: joint-space log, CSV or NPZ
        (:func:`rmdrake.dynamics.joint_log.read_joint_log`),
        or a list of them (each prepared on its own, then stacked).
      plot: if given, the PNG of measured vs predicted efforts per joint.
      html: if given, a Meshcat page of the first robot replaying the logged
        motion (at most :data:`MAX_FRAMES` frames), with ``cell`` drawn.
      cell: the robot's cell: the motion's nearest approach to it (capsules on
        the MDH segments, :class:`~rmdrake.kinematics.clearance.ClearanceChecker`)
        is printed; a motion that enters the cell is printed as its
        penetration, with a ``warning:`` line naming the first link inside
        and the time it enters. A warning, not a refusal (the exit code is
        unchanged): the log is what the robot did, validate judges its
        torques, and the capsules are a conservative stand-in for the links
        (an overlap under the capsule radius may be the capsule's alone).
      coulomb_width: rad/s (m/s on a prismatic joint); the Coulomb term is
        fc tanh(qd / width) (0: sign), as in ``identify``.
      preparation: options of :func:`~rmdrake.dynamics.data.prepare_samples`
        (rate, cutoff, derivative_cutoff, decimate, time_window, idle_speed),
        as in ``identify``.
      force: print the refusals of the sanity checks as warnings and return.

    Returns:
      The figures, one row per robot in the given order.

    A log of motor currents is turned into torques with the robots' drive
    gains (those without gains share them); robots with different gains are
    refused on such a log.

    Raises:
      ValueError: a robot without dynamics, robots of different joint counts
        or types, a log whose joint count differs, robots with different drive
        gains on a currents log (nothing written).
      ImplausibleResultError: a robot's prediction or the log fails the
        sanity checks and not ``force`` (after the figures and the plot).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from rmdrake import JointLog, load_robot, random_fourier_trajectory
    >>> from rmdrake import standard_parameters, write_joint_log
    >>> from rmdrake.dynamics import torques
    >>> robot = load_robot("rv3sb")
    >>> t, q, qd, qdd = random_fourier_trajectory(robot, seed=0).sample(rate=50.0)
    >>> tau = torques(robot, q, qd, qdd, standard_parameters(robot))
    >>> tmp = tempfile.TemporaryDirectory()
    >>> log = write_joint_log(Path(tmp.name, "log.csv"), JointLog(t, q, tau, qd, qdd))
    >>> from rmdrake.pipelines import validate_file
    >>> lines = []
    >>> errors = validate_file(["rv3sb"], log, echo=lines.append)
    >>> errors.labels, bool(errors.relative.max() < 1e-6)
    (('rv3sb',), True)
    >>> tmp.cleanup()
    """
    labels = robot_labels(robots)
    models = {
        label: r if isinstance(r, RobotModel) else load_robot(r)
        for label, r in zip(labels, robots, strict=True)
    }
    n = check_models(models)
    paths = [log_path] if isinstance(log_path, (str, os.PathLike)) else log_path
    with_gains = {
        k: m.drive_gain for k, m in models.items() if m.drive_gain is not None
    }
    gains = next(iter(with_gains.values()), None)
    transmission = next(
        (m.transmission for m in models.values() if m.transmission is not None), None
    )  # a motor-side log: mapped by the (first) robot's transmission
    logs, parts = prepare_logs(
        list(paths), n, gains=gains, transmission=transmission, **preparation
    )
    differ = [k for k, g in with_gains.items() if not np.array_equal(g, gains)]
    if differ and any(log.current is not None for log in logs):
        first = next(iter(with_gains))
        raise ValueError(
            f"robots '{first}' and '{differ[0]}' carry different drive gains: a "
            "currents log becomes a different measured torque for each; validate "
            "them one at a time"
        )
    samples = stack_samples(parts)
    errors = torque_errors(models, samples, coulomb_width=coulomb_width)
    law = f"tanh(qd / {coulomb_width:g})" if coulomb_width > 0 else "sign(qd)"
    echo(
        f"log {', '.join(map(str, paths))}: {samples.n_samples} samples at "
        f"{samples.rate:g} Hz, "
        "prepared as identify prepares it"
    )
    for note in samples.notes:
        echo(f"  {note}")
    echo(
        "torque prediction error per joint: RMS of predicted - measured, and "
        f"relative = RMS / measured RMS (Coulomb term fc {law}):"
    )
    for line in errors.table():
        echo(line)
    if plot is not None:
        predicted = dict(zip(errors.labels, errors.predicted, strict=True))
        path = plot_torque_comparison(
            samples.t,
            samples.tau,
            predicted,
            plot,
            title="Predicted vs measured joint efforts on "
            + ", ".join(Path(p).name for p in paths),
            sigma=models[labels[0]].sigma,
        )
        echo(f"wrote {path}")
    if cell is not None or html is not None:
        _show_motion(models[labels[0]], samples.t, samples.q, html, cell, echo)
    first = models[labels[0]]
    reasons = check_log(samples, first, first.limits.effort)
    for label, predicted in zip(errors.labels, errors.predicted, strict=True):
        sanity = check_prediction(
            predicted, samples.tau, t=samples.t, rate=samples.rate
        )
        echo(f"{label}: {sanity.summary()}")
        for warning in sanity.warnings:
            echo(f"warning: {label}: {warning}")
        reasons += [f"{label}: {r}" for r in sanity.reasons]
    if reasons and not force:
        raise ImplausibleResultError(
            reasons, errors, headline="the log contradicts the prediction"
        )
    for reason in reasons:
        echo(f"warning: implausible (forced): {reason}")
    return errors


MAX_FRAMES = 400
"""Frames of a ``validate --html`` page (the log is subsampled evenly)."""


def _show_motion(
    model: RobotModel,
    t: np.ndarray,
    q: np.ndarray,
    html: str | os.PathLike | None,
    cell: Cell | None,
    echo: Echo,
) -> None:
    """Prints the logged motion's nearest approach to ``cell`` (m; entering
    it: the penetration and a warning naming the link and the time) and writes
    its Meshcat page ``html``, both on at most MAX_FRAMES evenly spaced
    samples (t in s, q (M, n) in rad or m)."""
    keep = np.unique(np.linspace(0, len(t) - 1, min(len(t), MAX_FRAMES)).astype(int))
    if cell is not None:
        checker = ClearanceChecker(model=model, cell=cell)
        d_cell, _ = checker.distances(q[keep])
        k = int(np.argmin(d_cell))
        checked = (
            f"{len(keep)} samples checked, capsules of radius "
            f"{1e3 * checker.radius:.0f} mm on the MDH segments"
        )
        if d_cell[k] >= 0:
            echo(
                f"cell '{cell.name}': the logged motion comes within "
                f"{1e3 * d_cell[k]:.1f} mm of it at t = {t[keep][k]:.2f} s "
                f"({checked})"
            )
        else:
            first = int(np.flatnonzero(d_cell < 0)[0])
            _, link = checker.nearest_link(q[keep][first])
            echo(
                f"cell '{cell.name}': the logged motion enters it: penetration "
                f"{-1e3 * d_cell[k]:.1f} mm at t = {t[keep][k]:.2f} s ({checked})"
            )
            echo(
                f"warning: link '{link}' enters the cell '{cell.name}' at t = "
                f"{t[keep][first]:.2f} s (penetration up to {-1e3 * d_cell[k]:.1f} "
                f"mm, at t = {t[keep][k]:.2f} s): check the cell's YAML or the "
                "motion"
            )
    if html is not None:
        step = float(np.median(np.diff(t[keep]))) if len(keep) > 1 else 1.0
        path = save_robot_poses_html(
            model, q[keep], html, seconds_per_pose=step, cell=cell
        )
        echo(f"wrote {path} ({len(keep)} frames of the logged motion)")
