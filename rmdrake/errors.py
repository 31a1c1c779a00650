"""The exceptions rmdrake raises beyond Python's own.

Bad input (a malformed file, a value out of range) raises ``ValueError`` with a
one-line message naming the input; a missing file ``FileNotFoundError``. A
result that its own data contradicts (a calibration whose residual is far
above the measurement noise, a parameter beyond what any real robot could
have) raises :class:`ImplausibleResultError`: the computation ran, but writing
its result would put a wrong robot into a controller. The ``rmdrake`` command
maps the first two to exit code 2 and this one to exit code 3.
"""

from __future__ import annotations

__all__ = ["ImplausibleResultError"]


class ImplausibleResultError(RuntimeError):
    """A fitted result that the data or physical bounds contradict.

    Attributes:
      reasons: one line per failed check (what, by how much, the bound).
      result: the rejected result (e.g. the calibrated RobotModel), kept so a
        caller that asked to force it can still write it, with the reasons
        recorded beside it.
    """

    def __init__(self, reasons: list[str], result: object = None) -> None:
        self.reasons = list(reasons)
        self.result = result
        super().__init__("; ".join(self.reasons) or "implausible result")
