# SPDX-License-Identifier: GPL-3.0-or-later
"""blender_adapter/chart_images.py: charts written as PNG by OpenImageIO, their text drawn by blf.

Oracles: the core's text-free pixels and its labels' boxes (text must appear inside every
box and nowhere else, which also pins blf's bottom-left origin to the chart's top-down
rows), and OpenImageIO read straight from the tests (image_io.py) for what was written.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import load_addon
from image_io import read_png

# Pixels darker than this on a white chart are text (TEXT is (20, 20, 20)); antialiased
# edges are lighter, glyph stems darker.
DARK = 128
# Each label's glyphs cover at least this many dark pixels (a "1" or a "-" at 14 pixels).
MIN_DARK_PIXELS = 3
# Antialiasing may tint a pixel next to the estimated box.
EDGE_PIXELS = 1


@pytest.fixture(scope="module")
def chart_images():
    load_addon()
    from hybrid_rt.blender_adapter import chart_images

    return chart_images


@pytest.fixture(scope="module")
def chart():
    from hybrid_engine.reports.chart_raster import stacked_bar_chart

    return stacked_bar_chart([1, 2, 3, 4], {"shade": [2.0, 4.0, 1.0, 3.0], "trace": [6.0, 2.0, 3.0, 5.0]},
                             target_ms=1000 / 24, target_fps=24.0, title="Chess - HYBRID - 4 frames")


def box_slices(box, shape, grow: int = 0) -> tuple[slice, slice]:
    x0, y0, x1, y1 = box
    return (slice(max(y0 - grow, 0), min(y1 + grow, shape[0])), slice(max(x0 - grow, 0), min(x1 + grow, shape[1])))


def dark(image: np.ndarray) -> np.ndarray:
    return (image[..., :3] < DARK).all(axis=-1)


def test_the_written_chart_has_the_charts_size_and_text_in_every_label_box_and_nowhere_else(
        chart_images, chart, tmp_path):
    """Every label is drawn (dark pixels inside its box, where the core left background) and
    blf touched no pixel outside the boxes: the labels land where the core laid them out."""
    path = tmp_path / "chart.png"
    chart_images.write_chart(path, chart)
    written = read_png(path)
    assert written.shape == chart.pixels.shape
    outside = np.ones(chart.pixels.shape[:2], bool)
    for label in chart.labels:
        rows, columns = box_slices(label.box(), written.shape)
        assert not dark(chart.pixels[rows, columns]).any(), label
        assert dark(written[rows, columns]).sum() >= MIN_DARK_PIXELS, label
        outside[box_slices(label.box(), written.shape, EDGE_PIXELS)] = False
    np.testing.assert_array_equal(written[outside], chart.pixels[outside])


@pytest.mark.parametrize("align", ["left", "center", "right"])
def test_a_label_is_drawn_at_its_anchor_row_and_column(chart_images, align):
    """blf's origin is the bottom-left corner and its position the baseline: the writer turns
    the label's top-down row into a baseline so that the capitals are centred on it, and
    shifts the text by its measured width for the alignment."""
    from hybrid_engine.reports.chart_raster import Label

    pixels = np.full((120, 240, 3), 255, np.uint8)
    drawn = chart_images.draw_labels(pixels, [Label("HHHH", 120, 40, 20, (0, 0, 0), align)])
    rows, columns = np.nonzero(dark(drawn))
    assert abs((rows.min() + rows.max()) / 2 - 40) <= 1.0
    edge = {"left": columns.min(), "center": (columns.min() + columns.max()) / 2, "right": columns.max()}[align]
    assert abs(edge - 120) <= 3  # the glyphs' side bearings


def test_text_is_drawn_in_the_labels_colour(chart_images):
    """blf writes the colour into the byte image as given (no colour management): the glyphs'
    inner pixels are exactly the label's colour."""
    from hybrid_engine.reports.chart_raster import Label

    pixels = np.full((60, 200, 3), 255, np.uint8)
    drawn = chart_images.draw_labels(pixels, [Label("HIM", 20, 30, 28, (214, 39, 40))])
    assert np.all(drawn == np.array([214, 39, 40], np.uint8), axis=-1).sum() > 20


def test_write_png_round_trips_exactly(chart_images, rng, tmp_path):
    pixels = rng.integers(0, 256, (17, 23, 3), dtype=np.uint8)
    chart_images.write_png(tmp_path / "x.png", pixels)
    np.testing.assert_array_equal(read_png(tmp_path / "x.png"), pixels)
    np.testing.assert_array_equal(chart_images.read_png(tmp_path / "x.png"), pixels)


def test_write_png_refuses_pixels_a_png_cannot_hold(chart_images, tmp_path):
    with pytest.raises(ValueError, match="uint8"):
        chart_images.write_png(tmp_path / "x.png", np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        chart_images.write_png(tmp_path / "x.png", np.zeros((2, 2, 4), np.uint8))
