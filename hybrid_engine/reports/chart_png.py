# SPDX-License-Identifier: GPL-3.0-or-later
"""Frame-time charts drawn with numpy and written as PNG without any plotting library.

Timing reports must be producible wherever the renderer runs: inside Blender (whose Python
has numpy but no matplotlib), headless on a build machine, in tests. So the charts of the
paper's evaluation (Figure 5: per-pass time of every frame of an animation as stacked bars;
Figure 6: the frame time of two modes as lines) are rasterized here straight into an
(H, W, 3) uint8 array, text included (a 3x5 bitmap font, scaled by whole pixels), and
encoded with ``zlib`` + ``struct`` (the tests read them back with Blender's OpenImageIO).

Arrays are row 0 at the top, as PNG stores them. Drawing is vectorised per image, not per
bar or per pixel, so a 100 000-frame chart takes as long as a 10-frame one.
"""
from __future__ import annotations

import math
import struct
import zlib
from typing import Mapping, Sequence

import numpy as np

from .diagnostic_legend import GLYPH_ADVANCE, GLYPH_HEIGHT, _paint_mask, fill_rect, text_mask, text_width  # noqa: F401
from .diagnostic_legend import draw_text as _draw_text

RGB = tuple[int, int, int]

BACKGROUND: RGB = (255, 255, 255)
PLOT_BACKGROUND: RGB = (246, 246, 246)
GRID: RGB = (222, 222, 222)
AXIS: RGB = (40, 40, 40)
TEXT: RGB = (20, 20, 20)
TARGET_COLOR: RGB = (214, 39, 40)
# Series colours (Tableau 10 without its red, which marks the target frame time, plus a few).
PALETTE: tuple[RGB, ...] = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189), (140, 86, 75),
    (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207), (57, 59, 121),
    (140, 162, 82), (189, 158, 57), (132, 60, 57), (123, 65, 115), (82, 84, 163),
)

# When the target frame time lies this many times above the tallest frame, putting it on
# the scale would squash every bar into the bottom few pixels: the legend names it instead.
TARGET_OFF_SCALE_FACTOR = 4.0

def draw_text(image: np.ndarray, text: str, x: int, y: int, color: RGB = TEXT, scale: int = 2,
              align: str = "left") -> None:
    """The legend font's ``draw_text`` in the charts' text colour."""
    _draw_text(image, text, x, y, color, scale, align)


def draw_vertical_text(image: np.ndarray, text: str, x: int, y_center: int, color: RGB = TEXT,
                       scale: int = 2) -> None:
    """Draw ``text`` rotated a quarter turn anticlockwise (an axis title), centred on ``y_center``."""
    mask = np.rot90(text_mask(text, scale))
    _paint_mask(image, mask, x, y_center - mask.shape[0] // 2, color)


def nice_step(span: float, target_ticks: int = 6) -> float:
    """A tick spacing of 1, 2 or 5 times a power of ten giving about ``target_ticks`` ticks."""
    if not math.isfinite(span) or span <= 0.0:
        return 1.0
    raw = span / max(target_ticks, 1)
    magnitude = 10.0 ** math.floor(math.log10(raw))
    for multiple in (1.0, 2.0, 5.0, 10.0):
        if multiple * magnitude >= raw * (1.0 - 1e-9):
            return multiple * magnitude
    return 10.0 * magnitude


def format_tick(value: float, step: float) -> str:
    """A tick label with as many decimals as the step needs (0.25 -> '0.25', 20 -> '20')."""
    decimals = 0 if step >= 1.0 else min(int(math.ceil(-math.log10(step) - 1e-9)), 6)
    return f"{value:.{decimals}f}"


# ---------------------------------------------------------------------------------------------
# Chart frame: title, plot area, axes with ticks, legend.

class _Frame:
    """The geometry of one chart: where the plot area lies and how values map to pixels."""

    def __init__(self, width: int, height: int, legend_labels: Sequence[str], scale: int) -> None:
        self.scale = scale
        self.swatch = GLYPH_HEIGHT * scale
        legend_text = max((text_width(label, scale) for label in legend_labels), default=0)
        # Gap, swatch (two glyph heights wide), gap, text, margin.
        legend_width = 14 + 2 * self.swatch + 2 * scale + legend_text + 10
        # Margin, the rotated y title, a gap, tick labels of up to 7 characters, the ticks.
        self.left = 4 + self.swatch + 6 + text_width("0" * 7, scale) + 3 * scale
        self.right = width - legend_width
        self.top = 2 * GLYPH_HEIGHT * scale + 10
        self.bottom = height - 3 * GLYPH_HEIGHT * scale - 14
        if self.right - self.left < 40 or self.bottom - self.top < 40:
            raise ValueError(f"a {width}x{height} chart leaves no room for the plot area")
        self.legend_x = self.right + 14
        self.y_max = 1.0

    @property
    def plot_width(self) -> int:
        return self.right - self.left

    @property
    def plot_height(self) -> int:
        return self.bottom - self.top

    def y_pixel(self, value: float | np.ndarray) -> np.ndarray:
        """Image row (fractional) of a value: 0 lies on the plot's bottom edge, y_max on its top."""
        return self.bottom - np.asarray(value, dtype=np.float64) / self.y_max * self.plot_height


def _new_image(width: int, height: int) -> np.ndarray:
    image = np.empty((height, width, 3), dtype=np.uint8)
    image[:] = BACKGROUND
    return image


def target_on_scale(data_max: float, target_ms: float | None) -> bool:
    """Whether the target frame time is drawn on the value axis (see TARGET_OFF_SCALE_FACTOR)."""
    return bool(target_ms) and target_ms <= TARGET_OFF_SCALE_FACTOR * max(data_max, 1e-9)


def _y_axis(image: np.ndarray, frame: _Frame, data_max: float, target_ms: float | None,
            y_label: str) -> bool:
    """Choose the value range (``frame.y_max``), draw grid, y ticks and the y title.
    Returns whether the target line is on the scale."""
    on_scale = target_on_scale(data_max, target_ms)
    top_value = max(data_max, target_ms if on_scale else 0.0, 1e-6)
    step = nice_step(top_value * 1.05)
    frame.y_max = math.ceil(top_value * 1.05 / step - 1e-9) * step
    fill_rect(image, frame.left, frame.top, frame.right, frame.bottom, PLOT_BACKGROUND)
    scale = frame.scale
    for index in range(int(round(frame.y_max / step)) + 1):
        value = index * step
        row = int(round(float(frame.y_pixel(value))))
        fill_rect(image, frame.left, row, frame.right, row + 1, GRID)
        fill_rect(image, frame.left - 2 * scale, row, frame.left, row + 1, AXIS)
        draw_text(image, format_tick(value, step), frame.left - 3 * scale, row - GLYPH_HEIGHT * scale // 2,
                  scale=scale, align="right")
    draw_vertical_text(image, y_label, 4, (frame.top + frame.bottom) // 2, scale=scale)
    return on_scale


def _x_axis(image: np.ndarray, frame: _Frame, first: int, last: int, x_of_frame) -> None:
    scale = frame.scale
    step = max(int(nice_step(max(last - first, 1), target_ticks=8)), 1)
    tick = int(math.ceil(first / step) * step)
    while tick <= last:
        column = int(round(float(x_of_frame(tick))))
        fill_rect(image, column, frame.bottom, column + 1, frame.bottom + 2 * scale, AXIS)
        draw_text(image, str(tick), column, frame.bottom + 3 * scale, scale=scale, align="center")
        tick += step
    draw_text(image, "FRAME", (frame.left + frame.right) // 2, image.shape[0] - GLYPH_HEIGHT * scale - 4,
              scale=scale, align="center")
    # Axis lines last, over the bars' bottom edge.
    fill_rect(image, frame.left, frame.bottom, frame.right, frame.bottom + 1, AXIS)
    fill_rect(image, frame.left - 1, frame.top, frame.left, frame.bottom + 1, AXIS)


def _target_line(image: np.ndarray, frame: _Frame, target_ms: float) -> None:
    """A dashed horizontal line at the target frame time."""
    row = int(round(float(frame.y_pixel(target_ms))))
    dash = np.arange(frame.left, frame.right)
    dash = dash[(dash - frame.left) % 10 < 6]
    for thickness in (0, 1):
        if frame.top <= row + thickness < frame.bottom + 1:
            image[row + thickness, dash] = TARGET_COLOR


def _legend(image: np.ndarray, frame: _Frame, entries: Sequence[tuple[str, RGB, str]]) -> None:
    """Entries (label, colour, kind 'box' or 'line'), one per row, right of the plot."""
    scale = frame.scale
    row_height = GLYPH_HEIGHT * scale + 2 * scale + 2
    x = frame.legend_x
    y = frame.top
    swatch = frame.swatch
    for label, color, kind in entries:
        if kind == "line":
            fill_rect(image, x, y + swatch // 2 - 1, x + 2 * swatch, y + swatch // 2 + 1, color)
        else:
            fill_rect(image, x, y, x + 2 * swatch, y + swatch, color)
        draw_text(image, label, x + 2 * swatch + 2 * scale, y, scale=scale)
        y += row_height


def _target_legend(data_max: float, target_ms: float | None,
                   target_fps: float | None) -> list[tuple[str, RGB, str]]:
    """The legend entry of the target frame time (none without a target)."""
    if not target_ms:
        return []
    fps = f" {target_fps:.3g} FPS" if target_fps else ""
    label = f"TARGET{fps} {target_ms:.1f} MS"
    if not target_on_scale(data_max, target_ms):
        label += " (OFF SCALE)"
    return [(label, TARGET_COLOR, "line")]


def _check_values(name: str, values: np.ndarray) -> None:
    if values.size and (not np.all(np.isfinite(values)) or values.min() < 0.0):
        raise ValueError(f"{name}: chart values must be finite and non-negative")


def stacked_bar_chart(
    frames: Sequence[int],
    series: Mapping[str, Sequence[float]],
    *,
    colors: Sequence[RGB] | None = None,
    target_ms: float | None = None,
    target_fps: float | None = None,
    title: str = "",
    width: int = 1000,
    height: int = 520,
    scale: int = 2,
) -> np.ndarray:
    """Per-pass time of every frame as stacked bars (paper Figure 5).

    ``series`` maps each pass (bottom of the stack first) to one value per frame in
    milliseconds; ``colors`` gives one colour per series (PALETTE in order by default).
    ``target_ms`` draws the target frame time as a dashed red line. Returns (H, W, 3) uint8.
    """
    names = list(series)
    frame_numbers = np.asarray(frames, dtype=np.int64)
    count = len(frame_numbers)
    if count == 0:
        raise ValueError("a chart needs at least one frame")
    values = np.zeros((count, len(names)), dtype=np.float64)
    for column, name in enumerate(names):
        row = np.asarray(series[name], dtype=np.float64)
        if row.shape != (count,):
            raise ValueError(f"series {name!r} has {row.shape} values for {count} frames")
        _check_values(name, row)
        values[:, column] = row
    colors = list(colors) if colors is not None else [PALETTE[i % len(PALETTE)] for i in range(len(names))]
    if len(colors) != len(names):
        raise ValueError(f"{len(colors)} colours for {len(names)} series")

    stacked = np.cumsum(values, axis=1)
    data_max = float(stacked[:, -1].max()) if names else 0.0
    legend = [(name, colors[i], "box") for i, name in enumerate(names)]
    legend += _target_legend(data_max, target_ms, target_fps)
    image = _new_image(width, height)
    frame = _Frame(width, height, [entry[0] for entry in legend], scale)
    on_scale = _y_axis(image, frame, data_max, target_ms, "TIME (MS)")

    # Each plot column belongs to one frame's bar; wide bars keep a one-pixel gap.
    columns = np.arange(frame.plot_width)
    bar_of_column = columns * count // frame.plot_width
    bar_pixels = frame.plot_width / count
    in_bar = np.ones(frame.plot_width, dtype=bool)
    if bar_pixels >= 4:
        in_bar = (columns + 1) < (bar_of_column + 1) * bar_pixels  # drop each bar's last column
    if names:
        # Value at each plot row's centre; a pixel shows the first pass whose top lies above it.
        row_values = (frame.plot_height - np.arange(frame.plot_height) - 0.5) / frame.plot_height * frame.y_max
        tops = stacked[bar_of_column]  # (plot_width, passes)
        pass_index = (row_values[:, None, None] >= tops[None, :, :]).sum(axis=2)  # (rows, columns)
        filled = (pass_index < len(names)) & in_bar[None, :]
        lut = np.array(colors, dtype=np.uint8).reshape(-1, 3)
        plot = image[frame.top:frame.bottom, frame.left:frame.right]
        plot[filled] = lut[pass_index[filled]]

    def x_of_frame(number: int) -> float:
        index = np.searchsorted(frame_numbers, number)
        return frame.left + (index + 0.5) * bar_pixels

    _x_axis(image, frame, int(frame_numbers[0]), int(frame_numbers[-1]), x_of_frame)
    if on_scale:
        _target_line(image, frame, target_ms)
    _legend(image, frame, legend)
    draw_text(image, title, frame.left, 6, scale=scale)
    return image


def line_chart(
    frames: Sequence[int],
    series: Mapping[str, Sequence[float]],
    *,
    colors: Sequence[RGB] | None = None,
    target_ms: float | None = None,
    target_fps: float | None = None,
    title: str = "",
    width: int = 1000,
    height: int = 520,
    scale: int = 2,
) -> np.ndarray:
    """Frame time of several runs over the same frames as lines (paper Figure 6)."""
    frame_numbers = np.asarray(frames, dtype=np.float64)
    count = len(frame_numbers)
    if count == 0:
        raise ValueError("a chart needs at least one frame")
    names = list(series)
    arrays = []
    for name in names:
        row = np.asarray(series[name], dtype=np.float64)
        if row.shape != (count,):
            raise ValueError(f"series {name!r} has {row.shape} values for {count} frames")
        _check_values(name, row)
        arrays.append(row)
    colors = list(colors) if colors is not None else [PALETTE[i % len(PALETTE)] for i in range(len(names))]
    data_max = max((float(a.max()) for a in arrays), default=0.0)
    legend = [(name, colors[i], "line") for i, name in enumerate(names)]
    legend += _target_legend(data_max, target_ms, target_fps)
    image = _new_image(width, height)
    frame = _Frame(width, height, [entry[0] for entry in legend], scale)
    on_scale = _y_axis(image, frame, data_max, target_ms, "TIME (MS)")

    first, last = float(frame_numbers[0]), float(frame_numbers[-1])
    margin = 4  # keep the end points off the axes
    span = max(last - first, 1.0)

    def x_of_frame(number):
        if count == 1:
            return (frame.left + frame.right) / 2
        return frame.left + margin + (number - first) / span * (frame.plot_width - 2 * margin - 1)

    x_points = np.asarray(x_of_frame(frame_numbers), dtype=np.float64) * np.ones(count)
    if count == 1:
        columns = np.array([int(round(x_points[0]))])
    else:
        columns = np.arange(int(math.ceil(x_points[0])), int(math.floor(x_points[-1])) + 1)
    rows = np.arange(frame.top, frame.bottom)[:, None]
    plot_rows = image[frame.top:frame.bottom]
    for color, values in zip(colors, arrays):
        # The polyline's row at every column; joining each column's row to the next one's
        # leaves no gap on steep segments. Lines are three pixels thick.
        ys = np.interp(columns, x_points, frame.y_pixel(values)) if count > 1 else frame.y_pixel(values)
        following = np.append(ys[1:], ys[-1])
        low, high = np.floor(np.minimum(ys, following)) - 1, np.ceil(np.maximum(ys, following)) + 1
        block = plot_rows[:, columns]
        block[(rows >= low[None, :]) & (rows <= high[None, :])] = color
        plot_rows[:, columns] = block

    _x_axis(image, frame, int(first), int(last), x_of_frame)
    if on_scale:
        _target_line(image, frame, target_ms)
    _legend(image, frame, legend)
    draw_text(image, title, frame.left, 6, scale=scale)
    return image


# ---------------------------------------------------------------------------------------------
# PNG (ISO/IEC 15948): signature, IHDR, one zlib IDAT, IEND; every chunk CRC-32 checked.

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOR_TYPES = {1: 0, 3: 2, 4: 6}  # channels -> PNG colour type (grey, RGB, RGBA)
_CHANNELS = {value: key for key, value in _COLOR_TYPES.items()}


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def _adaptive_filter_rows(array: np.ndarray) -> np.ndarray:
    """Scanlines (filter byte first) with the filter chosen per row: None, Sub, Up, Average or
    Paeth, whichever gives the smallest sum of absolute filtered bytes (libpng's heuristic).
    The encoder side of every filter depends only on the raw bytes, so all rows are filtered
    at once."""
    height, width, channels = array.shape
    raw = array.reshape(height, width * channels).astype(np.int16)
    left = np.zeros_like(raw)
    left[:, channels:] = raw[:, :-channels]
    up = np.zeros_like(raw)
    up[1:] = raw[:-1]
    up_left = np.zeros_like(raw)
    up_left[1:, channels:] = raw[:-1, :-channels]
    estimate = left + up - up_left
    distance_left, distance_up, distance_up_left = (np.abs(estimate - v) for v in (left, up, up_left))
    paeth = np.where((distance_left <= distance_up) & (distance_left <= distance_up_left), left,
                     np.where(distance_up <= distance_up_left, up, up_left))
    candidates = np.stack([raw, raw - left, raw - up, raw - (left + up) // 2, raw - paeth]) & 0xFF
    cost = np.abs(candidates.astype(np.uint8).view(np.int8).astype(np.int32)).sum(axis=2)  # (5, H)
    chosen = np.argmin(cost, axis=0)
    rows = candidates[chosen, np.arange(height)].astype(np.uint8)
    return np.concatenate([chosen.astype(np.uint8)[:, None], rows], axis=1)


def encode_png(pixels: np.ndarray, compression: int = 6, adaptive_filter: bool = False) -> bytes:
    """An 8-bit PNG of an (H, W), (H, W, 3) or (H, W, 4) uint8 array, row 0 at the top.

    Rows are written unfiltered, which suits flat charts; ``adaptive_filter`` picks a filter
    per row, which halves the size of rendered images."""
    array = np.asarray(pixels)
    if array.dtype != np.uint8:
        raise ValueError(f"PNG pixels must be uint8, got {array.dtype}")
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in _COLOR_TYPES or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"PNG pixels must be (H, W), (H, W, 3) or (H, W, 4), got {np.shape(pixels)}")
    height, width, channels = array.shape
    if adaptive_filter:
        raw = _adaptive_filter_rows(array)
    else:  # filter type 0 (None) on every scanline: a zero byte in front of each row
        raw = np.concatenate([np.zeros((height, 1), np.uint8), array.reshape(height, -1)], axis=1)
    header = struct.pack(">IIBBBBB", width, height, 8, _COLOR_TYPES[channels], 0, 0, 0)
    return (PNG_SIGNATURE + _chunk(b"IHDR", header)
            + _chunk(b"IDAT", zlib.compress(raw.tobytes(), compression)) + _chunk(b"IEND", b""))


def write_png(path, pixels: np.ndarray) -> None:
    with open(path, "wb") as handle:
        handle.write(encode_png(pixels))
