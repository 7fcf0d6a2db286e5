# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/reports/chart_raster.py: the charts' pixels and the labels handed over with them.

Oracles: pixel positions computed from the chart's value scale for the bars, the lines and
the target line; the labels' boxes for where the chart must leave room for its text.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from hybrid_engine.reports import chart_raster
from hybrid_engine.reports.chart_raster import (
    FONT_SIZE, PALETTE, TARGET_COLOR, Label, line_chart, nice_step, stacked_bar_chart,
)

# A bar's top edge is rounded to a whole pixel row: its height is exact to one row.
BAR_ROW_TOLERANCE = 1
# A 100 000-frame chart is drawn per image, not per bar: seconds would mean a per-bar loop.
LARGE_CHART_SECONDS = 5.0


def color_rows(column: np.ndarray, color) -> np.ndarray:
    """Row indices of one image column that have exactly ``color``."""
    return np.flatnonzero(np.all(column == np.array(color, np.uint8), axis=-1))


# ---------------------------------------------------------------------------------------------
# Ticks

def _smaller_nice_step(step: float) -> float:
    mantissa, exponent = step / 10.0 ** np.floor(np.log10(step)), np.floor(np.log10(step))
    previous = {1: 0.5, 2: 1.0, 5: 2.0}[int(round(mantissa))]
    return previous * 10.0 ** exponent


@pytest.mark.parametrize("span", [0.013, 0.9, 6.0, 7.3, 41.7, 99.99, 100.0, 1234.0, 2.5e5])
def test_nice_step_is_the_smallest_round_step_giving_at_most_the_target_tick_count(span):
    """1, 2 or 5 times a power of ten; at most 6 steps span the range, and the next smaller
    round step would need more."""
    step = nice_step(span, target_ticks=6)
    mantissa = step / 10.0 ** np.floor(np.log10(step))
    assert int(round(mantissa)) in (1, 2, 5) and mantissa == pytest.approx(round(mantissa))
    assert span / step <= 6 * (1 + 1e-9)
    assert span / _smaller_nice_step(step) > 6


# ---------------------------------------------------------------------------------------------
# Charts

def bar_rows(image, column, color):
    rows = color_rows(image[:, column], color)
    return rows.size


def test_stacked_bars_have_heights_proportional_to_pass_times():
    """Three frames, two passes: each segment's pixel height is value / y_max * plot height."""
    frames = [10, 11, 12]
    series = {"first": [2.0, 4.0, 1.0], "second": [6.0, 2.0, 3.0]}
    colors = [PALETTE[0], PALETTE[1]]
    image = stacked_bar_chart(frames, series, colors=colors, width=600, height=400).pixels
    frame = chart_raster._Frame(600, 400, ["first", "second"], FONT_SIZE)
    plot_height = frame.plot_height
    y_max = 10.0  # tallest stack 8 ms * 1.05 rounded up to the 2-ms step
    bar_width = frame.plot_width / 3
    for index in range(3):
        column = int(frame.left + (index + 0.5) * bar_width)
        for name, color in zip(series, colors):
            expected = series[name][index] / y_max * plot_height
            assert abs(bar_rows(image, column, color) - expected) <= BAR_ROW_TOLERANCE, (index, name)
        # The first pass sits at the bottom: its lowest pixel is the plot's bottom row.
        assert color_rows(image[:, column], colors[0]).max() == frame.bottom - 1


def test_target_line_lies_at_the_target_frame_time():
    image = stacked_bar_chart([1, 2], {"pass": [10.0, 20.0]}, target_ms=25.0, width=500, height=300).pixels
    frame = chart_raster._Frame(500, 300, ["pass", "Target 25.0 ms"], FONT_SIZE)
    frame.y_max = 30.0  # 25 ms * 1.05 rounded up to the 5-ms step
    expected_row = int(round(float(frame.y_pixel(25.0))))
    red_rows = color_rows(image[:, frame.left + 1], TARGET_COLOR)
    assert expected_row in red_rows and red_rows.size <= 2


def test_a_far_target_is_named_off_scale_instead_of_squashing_the_bars():
    """1 ms frames against a 41.7 ms target: the bars keep the plot's height."""
    image = stacked_bar_chart([1, 2], {"pass": [1.0, 1.0]}, target_ms=41.7, target_fps=24.0,
                              width=500, height=300).pixels
    frame = chart_raster._Frame(500, 300, ["pass", "Target 24 FPS 41.7 ms (off scale)"], FONT_SIZE)
    column = frame.left + frame.plot_width // 4
    assert bar_rows(image, column, PALETTE[0]) > 0.8 * frame.plot_height
    assert color_rows(image[frame.top:frame.bottom, column], TARGET_COLOR).size == 0


def test_legend_shows_a_swatch_for_every_series():
    names = [f"pass_{i}" for i in range(5)]
    image = stacked_bar_chart([1], {name: [1.0] for name in names}, width=700, height=400).pixels
    frame = chart_raster._Frame(700, 400, names, FONT_SIZE)
    legend = image[:, frame.legend_x:]
    for color in PALETTE[:5]:
        assert np.all(legend == np.array(color, np.uint8), axis=-1).sum() >= frame.swatch ** 2


def test_line_chart_passes_through_each_value():
    frames = [1, 2, 3, 4]
    series = {"slow": [40.0, 30.0, 35.0, 45.0], "fast": [10.0, 12.0, 8.0, 9.0]}
    image = line_chart(frames, series, width=600, height=400).pixels
    frame = chart_raster._Frame(600, 400, list(series), FONT_SIZE)
    frame.y_max = 50.0
    margin = 4
    for (name, values), color in zip(series.items(), PALETTE):
        for number, value in zip(frames, values):
            column = int(round(frame.left + margin + (number - 1) / 3 * (frame.plot_width - 2 * margin - 1)))
            rows = color_rows(image[:, column], color)
            assert rows.size, (name, number)
            assert rows.min() - 1 <= frame.y_pixel(value) <= rows.max() + 1, (name, number)


def test_charts_reject_bad_values():
    with pytest.raises(ValueError, match="non-negative"):
        stacked_bar_chart([1, 2], {"pass": [1.0, -1.0]})
    with pytest.raises(ValueError, match="finite"):
        line_chart([1, 2], {"run": [1.0, float("nan")]})
    with pytest.raises(ValueError, match="3 frames"):
        stacked_bar_chart([1, 2, 3], {"pass": [1.0, 2.0]})
    with pytest.raises(ValueError, match="at least one frame"):
        stacked_bar_chart([], {})


def test_a_hundred_thousand_frames_draw_quickly_and_fill_the_plot(rng):
    frames = np.arange(100_000)
    series = {"a": rng.uniform(1, 2, frames.size), "b": rng.uniform(1, 2, frames.size)}
    start = time.perf_counter()
    image = stacked_bar_chart(frames, series).pixels
    assert time.perf_counter() - start < LARGE_CHART_SECONDS
    frame = chart_raster._Frame(1000, 520, ["a", "b"], FONT_SIZE)
    bottom_row = image[frame.bottom - 1, frame.left:frame.right]
    assert np.all(bottom_row == np.array(PALETTE[0], np.uint8))  # every column has a bar


# ---------------------------------------------------------------------------------------------
# Labels: the core hands its text over and draws none

def clipped_box(label: Label, image: np.ndarray) -> tuple[slice, slice]:
    """The rows and columns of a label's box inside the image."""
    x0, y0, x1, y1 = label.box()
    height, width = image.shape[:2]
    return slice(max(y0, 0), min(y1, height)), slice(max(x0, 0), min(x1, width))


CHARTS = {
    "stacked_bars": lambda: stacked_bar_chart([10, 11, 12], {"shade": [2.0, 4.0, 1.0], "trace": [6.0, 2.0, 3.0]},
                                              target_ms=1000 / 24, target_fps=24.0, title="Chess - HYBRID - 3 frames"),
    "lines": lambda: line_chart([10, 11, 12], {"HYBRID": [8.0, 6.0, 4.0], "FULL_BVH": [30.0, 20.0, 25.0]},
                                target_ms=25.0, title="Chess - frame time - HYBRID vs FULL_BVH"),
}


@pytest.mark.parametrize("chart", CHARTS, ids=list(CHARTS))
def test_a_chart_hands_over_its_title_ticks_legend_and_axis_titles_as_labels(chart):
    """The core has no font engine: every piece of text must reach the writer as a label."""
    picture = CHARTS[chart]()
    texts = [label.text for label in picture.labels]
    assert texts[0].startswith("Chess - ")  # the title first
    assert {"Frame", "Time (ms)", "0", "10", "11", "12"} <= set(texts)
    series = ["shade", "trace"] if chart == "stacked_bars" else ["HYBRID", "FULL_BVH"]
    assert set(series) <= set(texts)
    assert any(text.startswith("Target") for text in texts)
    assert all(label.size == FONT_SIZE and label.color == chart_raster.TEXT for label in picture.labels)


@pytest.mark.parametrize("chart", CHARTS, ids=list(CHARTS))
def test_a_charts_pixels_leave_every_label_box_empty_for_the_writer(chart):
    """Text-free pixels: inside each label's box the chart is one flat background colour (no
    burned-in text, and nothing a label would be drawn over)."""
    picture = CHARTS[chart]()
    image = picture.pixels
    assert image.shape == (520, 1000, 3) and image.dtype == np.uint8
    assert not np.all(image == np.array(chart_raster.TEXT, np.uint8), axis=-1).any()
    for label in picture.labels:
        rows, columns = clipped_box(label, image)
        region = image[rows, columns].reshape(-1, 3)
        assert region.size, label
        assert (region == np.array(chart_raster.BACKGROUND, np.uint8)).all(), label


@pytest.mark.parametrize(("align", "columns"), [("left", (100, 139)), ("center", (80, 120)), ("right", (61, 100))])
def test_a_label_box_lies_at_its_anchor_as_aligned(align, columns):
    """'AB3x' is estimated at 0.75 + 0.75 + 0.65 + 0.6 = 2.75 ems, 38.5 pixels at 14 pixels
    to the em, left of, around or right of x = 100 (x0 rounded down, x1 up); its rows are a
    line of text (1.2 ems) centred on y = 50."""
    x0, y0, x1, y1 = Label("AB3x", 100, 50, 14, align=align).box()
    assert (x0, x1) == columns
    assert (y0, y1) == (41, 59)


def test_a_label_refuses_an_unknown_alignment():
    with pytest.raises(ValueError, match="align"):
        Label("x", 0, 0, align="middle")
