"""Joint sensor effects for the simulated robot: encoder quantisation and
torque-sensor noise.

Both act on measurements only. :meth:`EncoderQuantizer.AddToBuilder` and
:func:`AddTorqueSensorNoise` wire them into a user's DiagramBuilder (as
:func:`rmdrake.systems.station.MakeStation` does). The range finder on the tool
is in ``sensors.py``.
"""

from __future__ import annotations

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import Adder, Gain, RandomSource

from rmdrake.arrays import as_finite_array

__all__ = ["AddTorqueSensorNoise", "EncoderQuantizer"]


class EncoderQuantizer(LeafSystem):
    """Joint encoders with a finite resolution: q_meas = res * round(q / res).

    .. pydrake_system::

        name: EncoderQuantizer
        input_ports:
        - q
        output_ports:
        - q_measured

    ::

             ┌──────────────────┐
        q ──►│ EncoderQuantizer │──► q_measured
             └──────────────────┘

    Input and output: n joint positions in rad (m for a prismatic joint).
    Parameter in the Context: ``resolution`` (n, rad or m per count; 0 passes
    the position through unchanged).
    The quantisation error is uniform in [-res/2, res/2] (std res / sqrt(12)).

    Example:

    >>> import numpy as np
    >>> from rmdrake.systems import EncoderQuantizer
    >>> encoder = EncoderQuantizer(resolution=np.array([0.01, 0.01]))
    >>> context = encoder.CreateDefaultContext()
    >>> _ = encoder.get_input_port().FixValue(context, [0.1234, -0.0567])
    >>> encoder.get_output_port().Eval(context).round(6).tolist()
    [0.12, -0.06]
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

    @staticmethod
    def AddToBuilder(
        builder: DiagramBuilder,
        input_port: OutputPort,
        *,
        resolution: np.ndarray,
        name: str = "encoder",
    ) -> EncoderQuantizer:
        """Adds an encoder named ``name`` reading ``input_port`` (n joint angles,
        rad) to ``builder``; returns it (its output port is ``q_measured``).

        ``resolution``: (n,) rad or m per count, 0 for an exact joint.
        """
        encoder = builder.AddNamedSystem(name, EncoderQuantizer(resolution=resolution))
        builder.Connect(input_port, encoder.get_input_port())
        return encoder

    def SetResolution(self, context: Context, resolution: np.ndarray) -> None:
        """Sets the (n,) resolution in rad or m per count in ``context``."""
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
            f"encoder resolution: expected >= 0 rad or m, found {res[j]} for "
            f"joint {j + 1}"
        )


def AddTorqueSensorNoise(
    builder: DiagramBuilder,
    torque: OutputPort,
    *,
    std: np.ndarray,
    sample_period: float,
    name: str = "torque_sensor",
) -> OutputPort:
    """Adds Gaussian noise to the torque signal ``torque``; returns the noisy port.

    ``torque + std * w`` with w a Drake ``RandomSource`` of independent standard
    normal samples, held for ``sample_period`` s (set it to the log period for
    independent noise on every logged sample). Systems added: ``{name}_noise``
    (RandomSource), ``{name}_std`` (Gain) and ``name`` (Adder, whose output is
    returned). The noise is drawn from the Context's random state: seed it with
    ``diagram.SetRandomContext(context, RandomGenerator(seed))``, otherwise
    every context gets Drake's default draw.

    Args:
      builder: the DiagramBuilder.
      torque: output port of the exact joint efforts (n, N m or N).
      std: (n,) standard deviation per joint, N m or N (>= 0).
      sample_period: s, > 0.
      name: name of the Adder; the other names derive from it.
    """
    sigma = as_finite_array(std, "torque noise", (torque.size(),))
    if np.any(sigma < 0):
        j = int(np.flatnonzero(sigma < 0)[0])
        raise ValueError(
            f"torque noise: expected >= 0 N m or N, found {sigma[j]} for joint {j + 1}"
        )
    n = torque.size()
    noise = builder.AddNamedSystem(
        f"{name}_noise",
        RandomSource(RandomDistribution.kGaussian, n, sample_period),
    )
    scale = builder.AddNamedSystem(f"{name}_std", Gain(sigma))
    builder.Connect(noise.get_output_port(), scale.get_input_port())
    noisy = builder.AddNamedSystem(name, Adder(2, n))
    builder.Connect(torque, noisy.get_input_port(0))
    builder.Connect(scale.get_output_port(), noisy.get_input_port(1))
    return noisy.get_output_port()
