"""Joint sensor effects for the simulated robot: encoder quantisation.

(Torque-sensor noise is Drake's own ``RandomSource`` + ``Gain`` + ``Adder``, wired
by :func:`rmdrake.systems.station.MakeStation`. The range finder on the tool is in
``sensors.py``.)
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from rmdrake.arrays import as_finite_array

__all__ = ["EncoderQuantizer"]


class EncoderQuantizer(LeafSystem):
    """Joint encoders with a finite resolution: q_meas = res * round(q / res).

    .. pydrake_system::

        name: EncoderQuantizer
        input_ports:
        - q
        output_ports:
        - q_measured

    ::

             ┌─────────────────┐
        q ──►│ EncoderQuantizer │──► q_measured
             └─────────────────┘

    Input and output: n joint angles in rad. Parameter in the Context:
    ``resolution`` (n, rad per count; 0 passes the angle through unchanged).
    The quantisation error is uniform in [-res/2, res/2] (std res / sqrt(12)).
    """

    def __init__(self, *, resolution: np.ndarray) -> None:
        super().__init__()
        res = as_finite_array(resolution, "encoder resolution", (None,))
        _check(res)
        n = res.shape[0]
        self._n = n
        self._res = self.DeclareNumericParameter(BasicVector(res))
        self._q = self.DeclareVectorInputPort("q", n)
        self.DeclareVectorOutputPort(
            "q_measured",
            n,
            self._calc,
            {self.input_port_ticket(self._q.get_index()),
             self.all_parameters_ticket()},
        )  # fmt: skip

    def SetResolution(self, context: Context, resolution: np.ndarray) -> None:
        """Sets the (n,) resolution in rad per count in ``context``."""
        res = as_finite_array(resolution, "encoder resolution", (self._n,))
        _check(res)
        context.get_mutable_numeric_parameter(self._res).SetFromVector(res)

    def _calc(self, context: Context, output: BasicVector) -> None:
        q = self._q.Eval(context)
        res = context.get_numeric_parameter(self._res).value()
        safe = np.where(res > 0, res, 1.0)
        # + 0.0 turns the -0.0 of rounding small negative angles into 0.0.
        output.SetFromVector(np.where(res > 0, safe * np.round(q / safe) + 0.0, q))


def _check(res: np.ndarray) -> None:
    if np.any(res < 0):
        j = int(np.flatnonzero(res < 0)[0])
        raise ValueError(
            f"encoder resolution: expected >= 0 rad, found {res[j]} for joint {j + 1}"
        )
