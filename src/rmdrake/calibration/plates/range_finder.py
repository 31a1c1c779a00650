"""The range finder on the robot's tool and its validity rule, written once.

Frames: B = robot base (the world W of rmdrake's plants), E = tool frame (the
range finder's origin, its beam along z_E), P = plate frame (origin at the plate
centre, z_P = the plate normal on the side the sensor looks from).

A reading is the distance t (m) from p_BE along z_BE to the plate plane
{p : z_BP . (p - p_BP) = 0}, so the measured point is ``p_BM = p_BE + t z_BE``.
It is valid when all of these hold:

* the beam meets the plane ahead of the sensor (|z_BE . z_BP| >= 1e-12, t >= 0);
* ``span[0] <= t <= span[1]``;
* the incidence, the angle between z_BE and -z_BP, is at most
  ``max_incidence``;
* p_BM lies on the plate: |x_P|, |y_P| of p_BM within half of ``plate_size``.

The simulator (:mod:`rmdrake.calibration.plates.simulate`) and the Drake system
(:class:`rmdrake.systems.sensors.RangeFinder`) both apply :func:`beam_readings`.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from rmdrake.arrays import as_finite_array

__all__ = [
    "BeamReadings",
    "RangeFinderSpec",
    "beam_readings",
    "ray_plane_distance",
]


@dataclasses.dataclass(frozen=True)
class RangeFinderSpec:
    """A range finder on the tool and the plate it reads.

    Attributes:
      span: (min, max) valid reading, m; 0 <= min < max (default 5..80 mm).
      max_incidence: largest angle between the beam z_E and the plate's inward
        normal -z_P, rad, in (0, pi/2] (default 35 deg).
      plate_size: (2,) plate edge lengths along x_P and y_P, m, positive
        (default 0.3 m x 0.3 m).

    Raises:
      ValueError: a value outside these ranges, naming it.

    Example:

    >>> from rmdrake.calibration import RangeFinderSpec
    >>> spec = RangeFinderSpec(span=(0.01, 0.1))
    >>> spec.span, spec.plate_size
    ((0.01, 0.1), (0.3, 0.3))
    """

    span: tuple[float, float] = (0.005, 0.080)
    max_incidence: float = float(np.deg2rad(35.0))
    plate_size: tuple[float, float] = (0.3, 0.3)

    def __post_init__(self) -> None:
        span = as_finite_array(self.span, "span", (2,))
        size = as_finite_array(self.plate_size, "plate_size", (2,))
        incidence = float(as_finite_array(self.max_incidence, "max_incidence", ()))
        if not 0 <= span[0] < span[1]:
            raise ValueError(f"span: expected 0 <= min < max m, found {self.span}")
        if not 0 < incidence <= np.pi / 2:
            raise ValueError(
                f"max_incidence: expected 0 < angle <= pi/2 rad, found {incidence}"
            )
        if not np.all(size > 0):
            raise ValueError(f"plate_size: expected positive m, found {size}")
        object.__setattr__(self, "span", (float(span[0]), float(span[1])))
        object.__setattr__(self, "max_incidence", incidence)
        object.__setattr__(self, "plate_size", (float(size[0]), float(size[1])))

    def as_vector(self) -> np.ndarray:
        """(5,) [span_min, span_max, max_incidence, plate_x, plate_y] (m, rad)."""
        return np.array([*self.span, self.max_incidence, *self.plate_size])

    @classmethod
    def from_vector(cls, vector: np.ndarray) -> RangeFinderSpec:
        """The spec of a vector laid out as :meth:`as_vector` (checked)."""
        v = as_finite_array(vector, "range finder vector", (5,))
        return cls((v[0], v[1]), v[2], (v[3], v[4]))


class BeamReadings(NamedTuple):
    """Output of :func:`beam_readings`, one entry per tool pose.

    Attributes:
      distance: (N,) t, m, whether valid or not; NaN where the beam is parallel
        to the plane or the plane is behind the sensor.
      incidence: (N,) angle between z_BE and -z_BP, rad.
      valid: (N,) bool, the validity rule of the module docstring.

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import BeamReadings, beam_readings
    >>> X_BP = np.eye(4)
    >>> X_BE = np.eye(4); X_BE[:3, :3] = np.diag([1.0, -1, -1]); X_BE[2, 3] = 0.05
    >>> readings = beam_readings(X_BE[None], X_BP)
    >>> isinstance(readings, BeamReadings), readings.distance.round(4)
    (True, array([0.05]))
    """

    distance: np.ndarray
    incidence: np.ndarray
    valid: np.ndarray


def ray_plane_distance(
    X_BE: np.ndarray, normal: np.ndarray, offset: float | np.ndarray
) -> np.ndarray:
    """Distance t along z_E from p_BE to the plane {p : normal . p = offset}.

    Args:
      X_BE: (N, 4, 4) tool poses.
      normal: (3,) or (N, 3) unit plane normals in B.
      offset: scalar or (N,) plane offsets, m.

    Returns:
      (N,) t in m; NaN where the beam is parallel to the plane (|cos| < 1e-12)
      or the plane is behind the sensor (t < 0).

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import ray_plane_distance
    >>> X_BE = np.eye(4); X_BE[:3, :3] = np.diag([1.0, -1, -1]); X_BE[2, 3] = 0.05
    >>> ray_plane_distance(X_BE[None], np.array([0.0, 0, 1]), 0.0).round(4)
    array([0.05])
    """
    normal = np.broadcast_to(normal, (X_BE.shape[0], 3))
    z = X_BE[:, :3, 2]
    p = X_BE[:, :3, 3]
    cos = np.einsum("ij,ij->i", normal, z)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (offset - np.einsum("ij,ij->i", normal, p)) / cos
    t[~np.isfinite(t) | (np.abs(cos) < 1e-12) | (t < 0)] = np.nan
    return t


def beam_readings(
    X_BE: np.ndarray, X_BP: np.ndarray, spec: RangeFinderSpec | None = None
) -> BeamReadings:
    """Readings, incidences and validity of N tool poses on one plate.

    Args:
      X_BE: (N, 4, 4) tool poses in B (m).
      X_BP: (4, 4) plate pose in B (m).
      spec: the range finder and plate; default ``RangeFinderSpec()``.

    Returns:
      :class:`BeamReadings` (distance m, incidence rad, valid), each (N,).

    Example:

    >>> import numpy as np
    >>> from rmdrake.calibration import beam_readings
    >>> X_BE = np.eye(4); X_BE[:3, :3] = np.diag([1.0, -1, -1]); X_BE[2, 3] = 0.05
    >>> beam_readings(X_BE[None], np.eye(4)).distance.round(4)
    array([0.05])
    """
    spec = RangeFinderSpec() if spec is None else spec
    X_BE = np.asarray(X_BE, dtype=np.float64)
    X_BP = np.asarray(X_BP, dtype=np.float64)
    if X_BE.ndim != 3 or X_BE.shape[1:] != (4, 4):
        raise ValueError(f"X_BE: expected shape (N, 4, 4), found {X_BE.shape}")
    if X_BP.shape != (4, 4):
        raise ValueError(f"X_BP: expected shape (4, 4), found {X_BP.shape}")
    normal, p_BP = X_BP[:3, 2], X_BP[:3, 3]
    t = ray_plane_distance(X_BE, normal, float(normal @ p_BP))
    cos = -X_BE[:, :3, 2] @ normal
    incidence = np.arccos(np.clip(cos, -1.0, 1.0))
    hit = X_BE[:, :3, 3] + np.nan_to_num(t)[:, None] * X_BE[:, :3, 2]
    local = (hit - p_BP) @ X_BP[:3, :2]
    valid = (
        np.isfinite(t)
        & (t >= spec.span[0])
        & (t <= spec.span[1])
        & (incidence <= spec.max_incidence)
        & (np.abs(local[:, 0]) <= spec.plate_size[0] / 2)
        & (np.abs(local[:, 1]) <= spec.plate_size[1] / 2)
    )
    return BeamReadings(t, incidence, valid)
