"""A socket plan for ``rmdrake plan``: ``placements`` of a plate with two
sockets x 2 x ``per_socket`` seated configurations (noise in m per
coordinate, random configurations only), calibrated by LM with one unknown
point per socket (:class:`~rmdrake.calibration.sockets.lm.SocketLM`, the
subset of the drawn parameters the sockets identify well).

Example::

    SocketPlan(placements=4, per_socket=25).describe()
    # '200 configurations (4 placements x 2 sockets x 25)'
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from rmdrake.calibration.config import CalibrationConfig, SocketLMConfig
from rmdrake.calibration.kind import plan_count, reach_span
from rmdrake.model.robot import RobotModel

__all__ = ["SocketPlan"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class SocketPlan:
    """Placements of a two-socket plate and configurations per socket
    (counts >= 1).

    Raises:
      ValueError: a count that is not an integer >= 1, or over the
        simulator's bounds
        (:func:`~rmdrake.calibration.sockets.simulate.check_socket_counts`),
        one line.
    """

    kind: ClassVar[str] = "sockets"

    placements: int = 4
    per_socket: int = 25

    def __post_init__(self) -> None:
        plan_count(self.placements, "placements")
        plan_count(self.per_socket, "per_socket")
        from rmdrake.calibration.sockets.simulate import check_socket_counts

        check_socket_counts(self.placements, self.per_socket)

    @property
    def readings(self) -> int:
        """Configurations in all: placements x 2 x per_socket."""
        return 2 * self.placements * self.per_socket

    @property
    def per_reading(self) -> int:
        """One ball position per configuration."""
        return 1

    def sized(self, readings: int) -> SocketPlan:
        """``readings`` configurations in all on the same placements.

        Raises:
          ValueError: not a multiple of the sockets (one line).
        """
        sockets = 2 * self.placements
        if readings % sockets:
            raise ValueError(
                f"readings {readings}: not a multiple of the {sockets} sockets "
                "(readings = placements x 2 x per-socket)"
            )
        return dataclasses.replace(self, per_socket=readings // sockets)

    def describe(self) -> str:
        """``200 configurations (4 placements x 2 sockets x 25)``."""
        return (
            f"{self.readings} configurations ({self.placements} placements x 2 "
            f"sockets x {self.per_socket})"
        )

    def record(self) -> dict[str, Any]:
        """``{"placements": P}``."""
        return {"placements": self.placements}

    def summary(self) -> dict[str, Any]:
        """The size fields of ``summary.yaml``: the configurations as
        ``poses`` and ``markers`` null, as the sockets' summaries have been
        written from the start (readers rely on those two keys)."""
        return {"poses": self.readings, "markers": None}

    def check(self, poses_from: str) -> None:
        """Refuses D-optimal poses (one line): sockets seat random
        configurations only."""
        if poses_from != "random":
            raise ValueError(
                "poses_from: a sockets plan seats random configurations only"
            )

    def noise_span(self, robot: RobotModel) -> tuple[float, str]:
        """The robot's reach, m."""
        return reach_span(robot)

    def simulate(
        self,
        robot: RobotModel,
        noise: float,
        seed: int,
        poses_from: str,
        nominal: RobotModel,
    ) -> Any:
        """:func:`~rmdrake.calibration.sockets.simulate.simulate_sockets` of
        the true ``robot`` (random configurations)."""
        from rmdrake.calibration.sockets.simulate import simulate_sockets

        return simulate_sockets(
            robot,
            placements=self.placements,
            per_socket=self.per_socket,
            noise=noise,
            seed=seed,
        )

    def calibrator(
        self,
        nominal: RobotModel,
        sim: Any,
        names: list[str],
        params: str,
        noise: float | None,
    ) -> Any:
        """LM of the drawn names the sockets identify well
        (:data:`~rmdrake.calibration.sockets.lm.WEAK_RTOL`), at the nominal.

        Raises:
          ValueError: none of them identifiable (one line).
        """
        from rmdrake.calibration.sockets.lm import (
            WEAK_RTOL,
            SocketLM,
            analyse_socket_identifiability,
            make_socket_calibrator,
        )

        probe = SocketLM(nominal, noise=noise)
        report = analyse_socket_identifiability(
            nominal, sim.data, names, rtol=WEAK_RTOL, weight=probe.distance_weight
        )
        if not report.identifiable:
            raise ValueError(f"no parameter of {params} is identifiable")
        config = CalibrationConfig(
            params=",".join(report.identifiable),
            noise=noise,
            calibrator=SocketLMConfig(),
        )
        return make_socket_calibrator(config, nominal)

    def tool_points(self, est: Any, sim: Any) -> dict[str, Any]:
        """The ball's centre, the tool point: no keyword."""
        return {}

    def too_few(self, unknowns: int, dof: int) -> str | None:
        """None: the identifiable subset depends on the readings."""
        return None
