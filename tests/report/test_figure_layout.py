"""Figures a reader can trust, checked without looking at pixels: the axis
limits hold every plotted point, no legend lies over a data point or inside
the axes, coinciding series stay distinguishable and say so, the title lies
inside the figure, and a log axis says where it draws values it cannot show."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Text

from rmdrake.model.loading import load_robot
from rmdrake.report import plots

LONG_TITLE = (
    "Fig. 3 (simulated): tool position error at 100 held-out poses of a robot "
    "with a rather long name, rv3sb_with_a_long_suffix, seed 0, and more words"
)


def _drawn(fig: Figure) -> Figure:
    FigureCanvasAgg(fig).draw()
    return fig


def _data_lines(fig: Figure) -> list[Line2D]:
    """The lines with data: not the axhline references (x in axes units)."""
    return [
        line
        for ax in fig.axes
        for line in ax.get_lines()
        if np.size(line.get_xdata()) and line.get_transform() == ax.transData
    ]


def _assert_limits_hold_every_point(fig: Figure) -> None:
    for line in _data_lines(fig):
        ax = line.axes
        x = np.asarray(line.get_xdata(), float)
        y = np.asarray(line.get_ydata(), float)
        (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
        assert np.all((x > x0) & (x < x1)), (line.get_label(), x, (x0, x1))
        assert np.all((y > y0) & (y < y1)), (line.get_label(), y, (y0, y1))


def _assert_legends_hide_no_data(fig: Figure) -> None:
    renderer = fig.canvas.get_renderer()
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes]
    legends = [lg for lg in legends if lg is not None]
    assert legends, "the figure has no legend"
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_title()
        for line in _data_lines(fig):
            xy = line.get_transform().transform(line.get_xydata())
            inside = (
                (xy[:, 0] >= box.x0)
                & (xy[:, 0] <= box.x1)
                & (xy[:, 1] >= box.y0)
                & (xy[:, 1] <= box.y1)
            )
            assert not inside.any(), line.get_label()


def _suptitle(fig: Figure) -> Text:
    (title,) = [
        t
        for t in fig.findobj(Text)
        if t.get_text() == fig.get_suptitle() and t.get_text()
    ]
    return title


def _assert_title_inside(fig: Figure) -> None:
    renderer = fig.canvas.get_renderer()
    box = _suptitle(fig).get_window_extent(renderer)
    page = fig.bbox
    assert page.x0 <= box.x0 and box.x1 <= page.x1, (box, page)
    assert page.y0 <= box.y0 and box.y1 <= page.y1, (box, page)


def _calibration_data() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    rng = np.random.default_rng(0)
    before = np.abs(rng.normal(1.6e-3, 5e-4, 100))
    before[37] = 9e-3  # an outlier a fixed axis would cut off
    lm = np.abs(rng.normal(3e-5, 1e-5, 100))
    de = np.abs(rng.normal(5e-3, 2e-3, 100))
    de[89] = 1.2e-2  # the tallest point, at the top right corner
    return before, {"DE on volumes": de, "LM": lm, "DE + LM": lm * (1 + 1e-9)}


def test_calibration_figure_limits_hold_every_point():
    before, after = _calibration_data()
    fig = _drawn(
        plots.calibration_errors_figure(
            before, after, title="t", reference={"paper": 1.6e-3, "after": 3e-4}
        )
    )
    _assert_limits_hold_every_point(fig)
    top, bottom = fig.axes[:2]
    assert top.get_ylim()[1] > 1e3 * before.max()
    assert bottom.get_ylim()[1] > 1e3 * after["DE on volumes"].max()


def test_calibration_figure_legend_covers_no_data():
    before, after = _calibration_data()
    fig = _drawn(plots.calibration_errors_figure(before, after, title=LONG_TITLE))
    _assert_legends_hide_no_data(fig)
    _assert_title_inside(fig)


def test_coinciding_series_are_both_visible_and_named():
    before, after = _calibration_data()
    fig = _drawn(plots.calibration_errors_figure(before, after, title="t"))
    lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
    lm = lines["LM"]
    (de_lm,) = [v for k, v in lines.items() if k.startswith("DE + LM")]
    assert "coincides with LM" in de_lm.get_label()
    assert "coincides" not in lm.get_label()
    assert (de_lm.get_marker(), de_lm.get_linestyle()) != (
        lm.get_marker(),
        lm.get_linestyle(),
    )
    assert de_lm.get_markersize() > lm.get_markersize()  # drawn round it
    assert de_lm.get_markerfacecolor() == "none"  # open: the other shows through
    legend_texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("coincides with LM" in t.replace("\n", " ") for t in legend_texts)


def test_distinct_series_keep_the_plain_style():
    a = np.linspace(1.0, 2.0, 10)
    styles = plots.series_styles({"a": a, "b": 1.1 * a}, unit="mm")
    assert styles["a"][0] == styles["b"][0]
    assert styles["b"][1] == "b"
    assert plots.coincide(a, a * (1 + 1e-4))
    assert not plots.coincide(a, a[:-1])


def test_static_accuracy_figure_legend_covers_no_data():
    """The compensation study's figure: 10 targets, a before series and three
    calibrated ones spanning 6 decades, the legend used to sit on them."""
    rng = np.random.default_rng(1)
    before = rng.uniform(0.6e-3, 2.4e-3, 10)
    after = {
        "kinematic correction": rng.uniform(1e-5, 3e-5, 10),
        "full compensation": rng.uniform(1e-5, 3e-5, 10),
        "oracle (true models)": rng.uniform(3e-11, 5e-10, 10),
    }
    title = "Static tool position error at 10 held-out targets\nrv3sb in Drake"
    fig = _drawn(
        plots.calibration_errors_figure(
            before, after, title=title, reference={"target 0.03 mm": 3e-5}
        )
    )
    _assert_legends_hide_no_data(fig)
    _assert_limits_hold_every_point(fig)
    _assert_title_inside(fig)


def test_a_zero_on_the_log_panel_is_drawn_at_the_floor_and_said():
    before, after = _calibration_data()
    after = {"LM": after["LM"], "oracle": np.zeros(100)}
    fig = _drawn(plots.calibration_errors_figure(before, after, title="t"))
    _assert_limits_hold_every_point(fig)
    texts = " ".join(t.get_text() for t in fig.legends[0].get_texts())
    assert "oracle: 0 (exact), drawn at" in texts.replace("\n", " ")


@pytest.mark.parametrize("zero", [0.0, 3e-14])  # m
def test_payload_errors_say_where_the_oracle_is_drawn(zero):
    rng = np.random.default_rng(2)
    errors = {
        "nominal controller": {m: rng.uniform(0.01, 0.08, 10) for m in (0.0, 4500.0)},
        "elastostatic": {m: rng.uniform(3e-4, 2e-3, 10) for m in (0.0, 4500.0)},
        "oracle": {m: np.full(10, zero) for m in (0.0, 4500.0)},
    }
    fig = _drawn(plots.payload_errors_figure(errors, floor=1e-4))
    _assert_limits_hold_every_point(fig)
    _assert_legends_hide_no_data(fig)
    _assert_title_inside(fig)
    texts = [t.get_text().replace("\n", " ") for t in fig.legends[0].get_texts()]
    note = "0 (exact)" if zero == 0.0 else "< 0.0001 mm (largest 3e-11 mm)"
    assert f"oracle: {note}, drawn at the floor" in texts, texts
    assert any("floor of the log axis, 0.0001 mm" in t for t in texts), texts
    floor_markers = [
        line
        for line in _data_lines(fig)
        if line.get_marker() == "v" and np.size(line.get_xdata())
    ]
    assert len(floor_markers) == 2  # the oracle, one per payload
    for line in floor_markers:
        assert np.all(np.asarray(line.get_ydata()) == 1e-4)


def test_deflection_field_title_fits():
    model = load_robot("demo_rh_elastic")
    model = dataclasses.replace(model, name=model.name + "_true")
    fig = _drawn(plots.deflection_field_figure(model, 4500.0, grid=5))
    _assert_title_inside(fig)
    assert "\n" in fig.get_suptitle()  # wrapped: it did not fit on one line


def test_wrap_title_keeps_line_breaks_and_fits():
    fig = Figure(figsize=(7, 5))
    text = plots.wrap_title("short\n" + LONG_TITLE, fig, 11.0)
    assert text.startswith("short\n")
    assert all(len(line) < 100 for line in text.split("\n"))
    plots.fitted_suptitle(fig, LONG_TITLE)
    _assert_title_inside(_drawn(fig))


def test_saved_figure_holds_everything(tmp_path):
    """bbox_inches='tight': an outside legend is in the PNG, not cut off."""
    from PIL import Image

    before, after = _calibration_data()
    path = plots.plot_calibration_errors(before, after, tmp_path / "f.png", title="t")
    width, height = Image.open(path).size
    assert width > 1000 and height > 600
