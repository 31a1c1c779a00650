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

__all__ = ["ImplausibleResultError", "describe_error", "one_line"]


class ImplausibleResultError(RuntimeError):
    """A fitted result that the data or physical bounds contradict.

    Attributes:
      reasons: one line per failed check (what, by how much, the bound).
      result: the rejected result (e.g. the calibrated RobotModel), kept so a
        caller that asked to force it can still write it, with the reasons
        recorded beside it.
      headline: what was decided, one line (e.g. ``identification of robot
        'kuka-lwr' not written: the log contradicts it``); empty: the single
        reason is the message.

    The message (``str(error)``) is the headline, then one line per reason
    indented by two spaces; a single reason without headline is one line::

        identification of robot 'kuka-lwr' not written: the log contradicts it
          sign: joint 2's torque negated leaves 0.11x the residual (under 0.75x)
          time base: ...
    """

    def __init__(
        self, reasons: list[str], result: object = None, headline: str = ""
    ) -> None:
        self.reasons = list(reasons)
        self.result = result
        if not headline and len(self.reasons) > 1:
            headline = f"the result contradicts its data ({len(self.reasons)} reasons)"
        self.headline = headline
        lines = [one_line(r) for r in self.reasons] or ["implausible result"]
        if headline:
            lines = [one_line(headline), *(f"  {r}" for r in lines)]
        super().__init__("\n".join(lines))


def one_line(text: str) -> str:
    """Whitespace (newlines included) collapsed: the message fits one line."""
    return " ".join(text.split())


def describe_error(error: BaseException) -> str:
    """The message of an expected error: naming the file of an OSError, saying
    "out of memory" for a MemoryError, else the error's text (or its type)."""
    if isinstance(error, OSError) and (error.filename2 or error.filename):
        name = error.filename2 or error.filename
        return f"{name}: {error.strerror or type(error).__name__}"
    if isinstance(error, MemoryError):
        return f"out of memory: {error or 'the input asks for more than is free'}"
    return str(error) or type(error).__name__
