# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/reports/chart_png.py: PNG encoding and the charts.

Oracles: zlib and the PNG specification's byte layout read by hand, and OpenImageIO (the
library Blender reads images with) for the encoder; pixel positions computed from the
chart's value scale for the bars, the lines and the target line.
"""
from __future__ import annotations

import struct
import time
import zlib

import numpy as np
import pytest

from hybrid_engine.reports import chart_png
from image_io import decode_png
from hybrid_engine.reports.chart_png import (
    PALETTE, TARGET_COLOR, encode_png, line_chart, nice_step, stacked_bar_chart,
)

# A bar's top edge is rounded to a whole pixel row: its height is exact to one row.
BAR_ROW_TOLERANCE = 1
# A 100 000-frame chart is drawn per image, not per bar: seconds would mean a per-bar loop.
LARGE_CHART_SECONDS = 5.0


def color_rows(column: np.ndarray, color) -> np.ndarray:
    """Row indices of one image column that have exactly ``color``."""
    return np.flatnonzero(np.all(column == np.array(color, np.uint8), axis=-1))


# ---------------------------------------------------------------------------------------------
# PNG

@pytest.mark.parametrize("shape", [(1, 1, 3), (3, 7, 3), (5, 257, 4), (9, 2), (64, 33, 3)])
def test_png_round_trip_is_bit_exact(rng, shape, tmp_path):
    """What encode_png writes, OpenImageIO (Blender's image library) reads back exactly."""
    pixels = rng.integers(0, 256, size=shape, dtype=np.uint8)
    decoded = decode_png(encode_png(pixels), tmp_path)
    expected = pixels if pixels.ndim == 3 else pixels[:, :, None]
    assert decoded.shape == expected.shape
    np.testing.assert_array_equal(decoded, expected)


def test_png_bytes_follow_the_specification(rng):
    """Read the file by hand: signature, IHDR fields, CRC-32 of every chunk, one filter byte
    (0) in front of each row of the zlib stream, IEND last."""
    pixels = rng.integers(0, 256, size=(4, 6, 3), dtype=np.uint8)
    data = encode_png(pixels)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    offset, chunks = 8, []
    while offset < len(data):
        (length,) = struct.unpack(">I", data[offset:offset + 4])
        tag = data[offset + 4:offset + 8]
        body = data[offset + 8:offset + 8 + length]
        (crc,) = struct.unpack(">I", data[offset + 8 + length:offset + 12 + length])
        assert crc == zlib.crc32(tag + body) & 0xFFFFFFFF, tag
        chunks.append((tag, body))
        offset += 12 + length
    assert [tag for tag, _ in chunks] == [b"IHDR", b"IDAT", b"IEND"]
    width, height, depth, color_type, compression, filtering, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
    assert (width, height, depth, color_type, compression, filtering, interlace) == (6, 4, 8, 2, 0, 0, 0)
    rows = np.frombuffer(zlib.decompress(chunks[1][1]), np.uint8).reshape(4, 1 + 6 * 3)
    assert np.all(rows[:, 0] == 0)
    np.testing.assert_array_equal(rows[:, 1:].reshape(4, 6, 3), pixels)


def test_encoder_rejects_what_png_cannot_hold():
    with pytest.raises(ValueError, match="uint8"):
        encode_png(np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        encode_png(np.zeros((2, 2, 2), np.uint8))
    with pytest.raises(ValueError):
        encode_png(np.zeros((0, 4, 3), np.uint8))


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
    image = stacked_bar_chart(frames, series, colors=colors, width=600, height=400)
    frame = chart_png._Frame(600, 400, ["first", "second"], 2)
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
    image = stacked_bar_chart([1, 2], {"pass": [10.0, 20.0]}, target_ms=25.0, width=500, height=300)
    frame = chart_png._Frame(500, 300, ["pass", "TARGET 25.0 MS"], 2)
    frame.y_max = 30.0  # 25 ms * 1.05 rounded up to the 5-ms step
    expected_row = int(round(float(frame.y_pixel(25.0))))
    red_rows = color_rows(image[:, frame.left + 1], TARGET_COLOR)
    assert expected_row in red_rows and red_rows.size <= 2


def test_a_far_target_is_named_off_scale_instead_of_squashing_the_bars():
    """1 ms frames against a 41.7 ms target: the bars keep the plot's height."""
    image = stacked_bar_chart([1, 2], {"pass": [1.0, 1.0]}, target_ms=41.7, target_fps=24.0,
                              width=500, height=300)
    frame = chart_png._Frame(500, 300, ["pass", "TARGET 24 FPS 41.7 MS (OFF SCALE)"], 2)
    column = frame.left + frame.plot_width // 4
    assert bar_rows(image, column, PALETTE[0]) > 0.8 * frame.plot_height
    assert color_rows(image[frame.top:frame.bottom, column], TARGET_COLOR).size == 0


def test_legend_shows_a_swatch_for_every_series():
    names = [f"pass_{i}" for i in range(5)]
    image = stacked_bar_chart([1], {name: [1.0] for name in names}, width=700, height=400)
    frame = chart_png._Frame(700, 400, names, 2)
    legend = image[:, frame.legend_x:]
    for color in PALETTE[:5]:
        assert np.all(legend == np.array(color, np.uint8), axis=-1).sum() >= frame.swatch ** 2


def test_line_chart_passes_through_each_value():
    frames = [1, 2, 3, 4]
    series = {"slow": [40.0, 30.0, 35.0, 45.0], "fast": [10.0, 12.0, 8.0, 9.0]}
    image = line_chart(frames, series, width=600, height=400)
    frame = chart_png._Frame(600, 400, list(series), 2)
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
    image = stacked_bar_chart(frames, series)
    assert time.perf_counter() - start < LARGE_CHART_SECONDS
    frame = chart_png._Frame(1000, 520, ["a", "b"], 2)
    bottom_row = image[frame.bottom - 1, frame.left:frame.right]
    assert np.all(bottom_row == np.array(PALETTE[0], np.uint8))  # every column has a bar
