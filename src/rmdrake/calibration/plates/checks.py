"""What a calibration accepts from plane readings: hard errors and warnings.

The file reader (:func:`rmdrake.calibration.plates.data.read_plane_measurements`)
checks the format;
this module holds the calibration's policy on the content: enough plates and
readings per plate, plate ids that survive reading as numbers, distances >= 0
and in m, joints in rad, joints within the limits.
"""

from __future__ import annotations

import warnings

import numpy as np

from rmdrake.calibration.plates.data import PlaneMeasurements
from rmdrake.calibration.sanity import check_joint_values

__all__ = [
    "MAX_PLATE_ID",
    "MAX_PLATE_READINGS",
    "MeasurementWarning",
    "check_joint_values",
    "check_plane_measurements",
]

MAX_PLATE_ID = 2**53
"""Largest |plate id|: ids are read as float64 numbers, exact up to 2^53; beyond
it two ids can become one (1e19 and 2e19 both saturate to -2^63 in int64)."""


MAX_PLATE_READINGS = 20_000
"""The most plate readings simulated or calibrated: hundreds of times a
calibration's (the paper takes 60); 20 000 take about 15 s to simulate and 20 s
to calibrate on the RV-3SB, 200 000 minutes (1000 x 1000 simulated readings ran
silent for many minutes)."""


class MeasurementWarning(UserWarning):
    """A plane-measurement file is usable but suspicious (e.g. joints outside
    the robot's limits)."""


def check_plane_measurements(
    data: PlaneMeasurements,
    *,
    n_joints: int | None = None,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    sigma: np.ndarray | None = None,
    min_plates: int = 4,
    min_per_plate: int = 4,
    max_distance: float | None = None,
    source: str = "measurements",
) -> list[str]:
    """Checks plane measurements for use in a calibration.

    Errors (ValueError, one line starting with ``source``): joint count differs
    from ``n_joints``; a plate id beyond +-:data:`MAX_PLATE_ID`; a negative
    reading; a reading above ``max_distance`` m (the calibrator passes twice the
    robot's reach plus 1 m: no plane-constraint set-up puts the plate farther
    from the tool than the robot is large, so such readings are in mm); joint
    values in the wrong unit (:func:`check_joint_values`); fewer than
    ``min_per_plate`` readings on a plate; fewer than ``min_plates`` plates;
    over :data:`MAX_PLATE_READINGS` readings.

    Warnings (returned as messages and issued as :class:`MeasurementWarning`):
    joint values outside [lower, upper] (rad, or m where ``sigma`` is 1).
    """
    if n_joints is not None and data.n_joints != n_joints:
        raise ValueError(
            f"{source}: {data.n_joints} joint columns, but the robot has {n_joints} "
            f"joints (expected columns plane,q1..q{n_joints},distance)"
        )
    if data.n_readings == 0:
        raise ValueError(f"{source}: no readings")
    if data.n_readings > MAX_PLATE_READINGS:
        raise ValueError(
            f"{source}: {data.n_readings} readings, over the cap of "
            f"{MAX_PLATE_READINGS} a plate calibration takes (tens per plate "
            "suffice; 20000 take about 20 s): thin the readings"
        )
    big = np.flatnonzero((data.plane >= MAX_PLATE_ID) | (data.plane <= -MAX_PLATE_ID))
    if big.size:
        k = int(big[0])
        raise ValueError(
            f"{source}: plate id {data.plane[k]} at reading {k + 1} is beyond "
            f"+-2^53: ids are read as numbers and ids that large (e.g. 1e19) lose "
            f"digits, so two plates could merge; number the plates 0, 1, 2, ..."
        )
    neg = np.flatnonzero(data.distance < 0)
    if neg.size:
        k = int(neg[0])
        raise ValueError(
            f"{source}: negative range reading {data.distance[k]:g} m at reading "
            f"{k + 1} (plate {data.plane[k]}); readings are distances >= 0 in m"
        )
    if max_distance is not None and np.max(data.distance) > max_distance:
        k = int(np.argmax(data.distance))
        raise ValueError(
            f"{source}: range reading {data.distance[k]:g} m at reading {k + 1} is "
            f"longer than {max_distance:.3g} m (twice the robot's reach plus 1 m): "
            f"readings are distances in m, not mm"
        )
    messages = check_joint_values(
        data.q, lower, upper, sigma, source=source, row="reading"
    )
    ids, counts = np.unique(data.plane, return_counts=True)
    few = np.flatnonzero(counts < min_per_plate)
    if few.size:
        bad = ", ".join(f"plate {ids[i]} has {counts[i]}" for i in few)
        raise ValueError(
            f"{source}: fewer than {min_per_plate} readings on a plate ({bad})"
        )
    if ids.size < min_plates:
        raise ValueError(
            f"{source}: {ids.size} plate location(s), at least {min_plates} needed "
            f"(put the plate at {min_plates} or more places)"
        )
    for m in messages:
        warnings.warn(m, MeasurementWarning, stacklevel=2)
    return messages
