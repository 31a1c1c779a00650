"""The compensation study's printed text: the ISO 9283 table's header lines up
with its rows, and a missed target gives the measured value and the figures
behind it, never a bare "not met" (a smoke run cannot meet the full study's
targets)."""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.studies.compensation import VARIANTS, CompensationStudyResult
from rmdrake.studies.tracking import TRACKING_VARIANTS, TrackingResult


def _static(full_mean: float) -> CompensationStudyResult:
    rng = np.random.default_rng(0)

    def per_variant(shape: tuple[int, ...]) -> dict[str, np.ndarray]:
        return {v: rng.uniform(1e-5, 2e-3, shape) for v in VARIANTS}

    mean = per_variant((2,))
    mean["full"][:] = full_mean
    mean["oracle"][:] = 0.0
    return CompensationStudyResult(
        seeds=[0, 1],
        cube_points=np.zeros((5, 3)),
        cube_R_BE=np.eye(3),
        AP=per_variant((2, 5)),
        RP=per_variant((2, 5)),
        mean_error=mean,
        max_error=per_variant((2,)),
        held_out_errors=per_variant((10,)),
        settle_error=per_variant((2,)),
        model_before=np.full(2, 1.6e-3),
        model_after=np.full(2, 2.2e-5),
        model_max_after=np.full(2, 4.6e-5),
        calibration_readings=np.array([40, 40]),
        wall_time=np.ones(2),
    )


def test_iso9283_table_header_lines_up_with_the_rows():
    lines = _static(1.85e-5).table().splitlines()
    groups, header, *rows = lines[1:7]
    assert header.split()[:3] == ["variant", "P1", "P2"]
    assert [r.split()[0] for r in rows] == ["nominal", "kinematic", "full", "oracle"]
    assert {len(r) for r in rows} == {len(header)}  # every column right-aligned
    for name in ("P5", "mean", "max"):
        end = header.rindex(name) + len(name)  # the last P5: RP's
        assert all(r[end - 1].isdigit() and r[end : end + 1] in ("", " ") for r in rows)
    ap, rp, held_out = (groups.index(g) for g in ("AP", "RP", "held-out"))
    assert ap < header.index("P1") < rp < header.rindex("P1") < held_out
    assert "targets: full compensation mean 0.0185 mm <= 0.0300 mm: met" in lines[-1]


def test_a_missed_static_target_says_by_how_much_and_why():
    line = _static(4.1e-5).table().splitlines()[-1]
    assert "not met" not in line
    assert "full compensation mean 0.0410 mm (target <= 0.0300 mm;" in line
    assert "calibrated model alone is 0.0220 mm off" in line


def test_a_missed_tracking_target_gives_the_measured_rms():
    V = len(TRACKING_VARIANTS)
    rms = np.full((1, 1, 2, V), 1e-3)
    soft = rms[0, 0, 1]  # bandwidth 10 rad/s, the softer
    soft[TRACKING_VARIANTS.index("nominal")] = 4.0653e-3
    soft[TRACKING_VARIANTS.index("full")] = 3.07e-5
    soft[TRACKING_VARIANTS.index("oracle")] = 3.0e-6
    result = TrackingResult(
        seed=0,
        paths=["circle"],
        speeds=[0.9],
        bandwidths=[40.0, 10.0],
        duration=np.array([[3.41]]),
        peak_tool_speed=np.ones((1, 1)),
        tool_rms=rms,
        tool_max=2 * rms,
        joint_rms=rms,
    )
    line = result.table().splitlines()[-1]
    assert "not met" not in line
    assert line.startswith("  targets: nominal / full = 132 >= 10: met; ")
    # The floor: the oracle, or the full compensation at the stiffest gains
    # (the calibrated kinematics' own error on the path), whichever is larger.
    stiff = rms[0, 0, 0]
    stiff[TRACKING_VARIANTS.index("full")] = 1.0e-5
    line = result.table().splitlines()[-1]
    assert (
        "full / floor (0.0100 mm) = 3.07 (target <= 2; RMS full compensation "
        "0.0307 mm; floor 0.0100 mm = max(oracle 0.0030 mm, full compensation at "
        "40 rad/s 0.0100 mm" in line
    )
    stiff[TRACKING_VARIANTS.index("full")] = 2.18e-5
    line = result.table().splitlines()[-1]
    assert line.endswith("full / floor (0.0218 mm) = 1.41 <= 2: met")
    # One bandwidth: no floor measured, the oracle alone.
    one = dataclasses.replace(
        result, bandwidths=[10.0], tool_rms=rms[:, :, 1:], tool_max=rms[:, :, 1:]
    )
    line = one.table().splitlines()[-1]
    assert (
        "full / oracle = 10.2 (target <= 2; RMS full compensation 0.0307 mm, " in line
    )
    assert "oracle 0.0030 mm: the oracle has the true models" in line
