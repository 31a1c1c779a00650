"""Writing a fitted model only when its checks pass: the one rule of every
command that fits (calibrate, identify). Scripts call the pipelines as the
command line does and get the same refusal."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rmdrake.errors import ImplausibleResultError

__all__ = ["Echo", "write_checked"]

Echo = Callable[[str], None]
"""Where a pipeline's summary lines go (``print`` on the command line)."""


def write_checked(
    model: Any,
    record: dict[str, Any],
    reasons: list[str],
    out: str | os.PathLike,
    *,
    force: bool,
    echo: Echo,
    headline: str = "",
) -> Path:
    """Saves ``model`` with its ``calibration`` ``record``; if ``reasons`` (the
    failed sanity checks) raises ImplausibleResultError (with ``headline``,
    what was decided) unless ``force``, when they are echoed as warnings and
    recorded as ``record["warnings"]``."""
    if reasons and not force:
        rejected = dataclasses.replace(model, calibration=record)
        raise ImplausibleResultError(reasons, rejected, headline=headline)
    if reasons:
        record = {**record, "warnings": list(reasons)}
        for reason in reasons:
            echo(f"warning: implausible result written (forced): {reason}")
    return dataclasses.replace(model, calibration=record).save(out)
