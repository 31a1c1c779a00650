"""The validation table keeps its columns apart however wide a figure is."""

import numpy as np

from rmdrake.dynamics.validation import TorqueErrors


def test_wide_figures_stay_in_their_columns():
    rms = np.array([[3.819e-15, 1234567.0], [0.036946, 2.5]])
    measured = np.array([0.0369463, 123456789.123])
    errors = TorqueErrors(
        labels=("a", "b"),
        rms=rms,
        measured_rms=measured,
        relative=rms / measured,
        predicted=np.zeros((2, 3, 2)),
        sigma=np.zeros(2),
    )
    lines = errors.table()
    for line in lines[1:]:
        fields = line.split()
        # joint, unit "N m", measured, then per model "RMS (rel. %)"
        assert "0.0369463.819e-15" not in line
        assert len(fields) >= 2 + 2 * len(errors.labels)
    row = lines[1].split()
    assert float(row[3]) == float(f"{measured[0]:.5g}")
    assert float(row[4]) == float(f"{rms[0, 0]:.4g}")
