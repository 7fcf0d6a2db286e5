# SPDX-License-Identifier: GPL-3.0-or-later
"""Frame-time charts as text-free pixels plus the labels to write on them, drawn with numpy.

Timing reports must be producible wherever the renderer runs: inside Blender (whose Python
has numpy but no matplotlib), headless on a build machine, in tests. So the charts of the
paper's evaluation (Figure 5: per-pass time of every frame of an animation as stacked bars;
Figure 6: the frame time of two modes as lines) are rasterized here straight into an
(H, W, 3) uint8 array: bars, lines, axes, grid, legend swatches, the target line.

Text is not drawn here. The core has neither a font engine nor an image library (it runs
without Blender), so a chart is a ``ChartPicture``: the pixels and a list of ``Label``s
(text, anchor, size, colour, alignment) that an image writer with a font engine draws and
saves (``blender_adapter/chart_images.py``: Blender's blf and OpenImageIO). Without a font
the margins cannot be measured, so they are laid out with an upper bound of the text's
width (``estimated_width``).

Arrays are row 0 at the top, as PNG stores them. Drawing is vectorised per image, not per
bar or per pixel, so a 100 000-frame chart takes as long as a 10-frame one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from .diagnostic_legend import fill_rect

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

FONT_SIZE = 14  # label size in pixels (the font's em)
ALIGNMENTS = ("left", "center", "right")
# Upper bounds of a character's advance in ems, by kind, for laying out margins without a
# font: capitals are the widest in proportional fonts (Blender's Inter included), digits
# next; everything else is narrower.
CAPITAL_EM, DIGIT_EM, OTHER_EM = 0.75, 0.65, 0.6
# A line of text: capitals centred on the label's row, descenders and ascenders inside.
LINE_EM = 1.2


def estimated_width(text: str, size: int) -> float:
    """An upper bound of ``text``'s width in pixels at ``size`` (see CAPITAL_EM)."""
    ems = sum(CAPITAL_EM if char.isupper() else DIGIT_EM if char.isdigit() else OTHER_EM for char in text)
    return ems * size


@dataclass(frozen=True)
class Label:
    """A piece of chart text, for a writer with a font engine to draw over the pixels.

    ``x`` is the column of the text's left edge, centre or right edge for ``align`` 'left',
    'center' or 'right'; ``y`` the row the middle of its capitals lies on (row 0 at the top);
    ``size`` the font size in pixels. Text is always horizontal: Blender's font engine does
    not rotate text it draws into an image, so the value axis is titled above its ticks.
    """

    text: str
    x: float
    y: float
    size: int = FONT_SIZE
    color: RGB = TEXT
    align: str = "left"

    def __post_init__(self) -> None:
        if self.align not in ALIGNMENTS:
            raise ValueError(f"align must be one of {ALIGNMENTS}, got {self.align!r}")

    def box(self) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1): columns [x0, x1) and rows [y0, y1) the text lies in, from its
        estimated width (not clipped to the image)."""
        width = estimated_width(self.text, self.size)
        left = self.x - {"left": 0.0, "center": width / 2, "right": width}[self.align]
        half = LINE_EM * self.size / 2
        return (math.floor(left), math.floor(self.y - half), math.ceil(left + width), math.ceil(self.y + half))


@dataclass(frozen=True, eq=False)
class ChartPicture:
    """A chart without its text: (H, W, 3) uint8 ``pixels`` (row 0 at the top) and the
    ``labels`` an image writer draws on them."""

    pixels: np.ndarray
    labels: tuple[Label, ...]


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

    def __init__(self, width: int, height: int, legend_labels: Sequence[str], font_size: int) -> None:
        size = self.font_size = font_size
        self.line = math.ceil(LINE_EM * size)  # a row of text
        self.swatch = max(round(0.8 * size), 2)
        self.tick = max(size // 3, 2)
        self.gap = max(size // 4, 2)
        legend_text = max((estimated_width(label, size) for label in legend_labels), default=0.0)
        # Gap, swatch (two swatch heights wide), gap, text, margin.
        legend_width = 14 + 2 * self.swatch + 2 * self.gap + math.ceil(legend_text) + 10
        # Margin, tick labels of up to 7 characters, a gap, the ticks.
        self.left = 4 + math.ceil(estimated_width("0" * 7, size)) + self.gap + self.tick
        self.right = width - legend_width
        # Margin, the title, a gap, the value axis' title, room for the top tick's label.
        self.top = 6 + math.ceil(2.5 * self.line) + 2 * self.gap
        # The ticks, their labels, the frame axis' title, a margin.
        self.bottom = height - self.tick - self.gap - 2 * self.line - 6
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

    def label(self, text: str, x: float, y: float, align: str = "left") -> Label:
        return Label(text, x, y, self.font_size, TEXT, align)


def _new_image(width: int, height: int) -> np.ndarray:
    image = np.empty((height, width, 3), dtype=np.uint8)
    image[:] = BACKGROUND
    return image


def target_on_scale(data_max: float, target_ms: float | None) -> bool:
    """Whether the target frame time is drawn on the value axis (see TARGET_OFF_SCALE_FACTOR)."""
    return bool(target_ms) and target_ms <= TARGET_OFF_SCALE_FACTOR * max(data_max, 1e-9)


def _y_axis(image: np.ndarray, frame: _Frame, labels: list[Label], data_max: float, target_ms: float | None,
            y_label: str) -> None:
    """Choose the value range (``frame.y_max``), draw grid and y ticks, label them and the axis."""
    on_scale = target_on_scale(data_max, target_ms)
    top_value = max(data_max, target_ms if on_scale else 0.0, 1e-6)
    step = nice_step(top_value * 1.05)
    frame.y_max = math.ceil(top_value * 1.05 / step - 1e-9) * step
    fill_rect(image, frame.left, frame.top, frame.right, frame.bottom, PLOT_BACKGROUND)
    for index in range(int(round(frame.y_max / step)) + 1):
        value = index * step
        row = int(round(float(frame.y_pixel(value))))
        fill_rect(image, frame.left, row, frame.right, row + 1, GRID)
        fill_rect(image, frame.left - frame.tick, row, frame.left, row + 1, AXIS)
        labels.append(frame.label(format_tick(value, step), frame.left - frame.tick - frame.gap, row, "right"))
    labels.append(frame.label(y_label, 4, frame.top - frame.gap - frame.line))


def _x_axis(image: np.ndarray, frame: _Frame, labels: list[Label], first: int, last: int, x_of_frame) -> None:
    step = max(int(nice_step(max(last - first, 1), target_ticks=8)), 1)
    tick = int(math.ceil(first / step) * step)
    tick_row = frame.bottom + frame.tick + frame.gap + frame.line / 2
    while tick <= last:
        column = int(round(float(x_of_frame(tick))))
        fill_rect(image, column, frame.bottom, column + 1, frame.bottom + frame.tick, AXIS)
        labels.append(frame.label(str(tick), column, tick_row, "center"))
        tick += step
    labels.append(frame.label("Frame", (frame.left + frame.right) // 2, tick_row + frame.line, "center"))
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


def _legend(image: np.ndarray, frame: _Frame, labels: list[Label], entries: Sequence[tuple[str, RGB, str]]) -> None:
    """Entries (label, colour, kind 'box' or 'line'), one per row, right of the plot."""
    swatch = frame.swatch
    row_height = max(frame.line, swatch) + frame.gap
    x = frame.legend_x
    y = frame.top
    for text, color, kind in entries:
        if kind == "line":
            fill_rect(image, x, y + swatch // 2 - 1, x + 2 * swatch, y + swatch // 2 + 1, color)
        else:
            fill_rect(image, x, y, x + 2 * swatch, y + swatch, color)
        labels.append(frame.label(text, x + 2 * swatch + 2 * frame.gap, y + swatch / 2))
        y += row_height


def _target_legend(data_max: float, target_ms: float | None,
                   target_fps: float | None) -> list[tuple[str, RGB, str]]:
    """The legend entry of the target frame time (none without a target)."""
    if not target_ms:
        return []
    fps = f" {target_fps:.3g} FPS" if target_fps else ""
    label = f"Target{fps} {target_ms:.1f} ms"
    if not target_on_scale(data_max, target_ms):
        label += " (off scale)"
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
    font_size: int = FONT_SIZE,
) -> ChartPicture:
    """Per-pass time of every frame as stacked bars (paper Figure 5).

    ``series`` maps each pass (bottom of the stack first) to one value per frame in
    milliseconds; ``colors`` gives one colour per series (PALETTE in order by default).
    ``target_ms`` draws the target frame time as a dashed red line.
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
    image, frame, labels = _start(width, height, font_size, legend, data_max, target_ms)

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

    _x_axis(image, frame, labels, int(frame_numbers[0]), int(frame_numbers[-1]), x_of_frame)
    return _finish(image, frame, labels, legend, data_max, target_ms, title)


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
    font_size: int = FONT_SIZE,
) -> ChartPicture:
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
    image, frame, labels = _start(width, height, font_size, legend, data_max, target_ms)

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

    _x_axis(image, frame, labels, int(first), int(last), x_of_frame)
    return _finish(image, frame, labels, legend, data_max, target_ms, title)


def _start(width: int, height: int, font_size: int, legend: Sequence[tuple[str, RGB, str]], data_max: float,
           target_ms: float | None) -> tuple[np.ndarray, _Frame, list[Label]]:
    """A chart's image, geometry and labels so far: background, plot area, value axis."""
    image = _new_image(width, height)
    frame = _Frame(width, height, [entry[0] for entry in legend], font_size)
    labels: list[Label] = []
    _y_axis(image, frame, labels, data_max, target_ms, "Time (ms)")
    return image, frame, labels


def _finish(image: np.ndarray, frame: _Frame, labels: list[Label], legend: Sequence[tuple[str, RGB, str]],
            data_max: float, target_ms: float | None, title: str) -> ChartPicture:
    """Draw the target line (over the data) and the legend; the picture, its title first."""
    if target_on_scale(data_max, target_ms):
        _target_line(image, frame, target_ms)
    _legend(image, frame, labels, legend)
    heading = [frame.label(title, frame.left, 6 + frame.line / 2)] if title else []
    return ChartPicture(image, tuple(heading + labels))
