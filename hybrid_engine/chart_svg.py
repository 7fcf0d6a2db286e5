# SPDX-License-Identifier: GPL-3.0-or-later
"""The timing report's chart as SVG: vector, with real text, for reading and for documents.

The same stacked per-pass bars as the PNG (``chart_png``, the paper's Figure 5), with what a
bitmap with a 3x5 font cannot carry: a frame-time axis in milliseconds on the left, the
frames-per-second those times mean on the right, the target frame rate as a dashed line, a
legend naming every pass, the near cube's size per frame where it varied (Frame Budget), and
a summary line (mean and 95th-percentile frame time, the slowest pass). Plain text output,
no dependency: ``xml.sax.saxutils`` escapes the names.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from xml.sax.saxutils import escape

WIDTH, HEIGHT = 1000, 560
LEFT, RIGHT, TOP, BOTTOM = 70, 70, 50, 110  # plot margins: axes, title, legend, summary
FONT = "font-family='DejaVu Sans, Arial, sans-serif'"


def _nice_step(span: float, ticks: int = 6) -> float:
    """A round tick spacing (1, 2 or 5 x 10^k) giving about ``ticks`` ticks over ``span``."""
    raw = max(span, 1e-9) / ticks
    power = 10 ** math.floor(math.log10(raw))
    return next(step * power for step in (1, 2, 5, 10) if step * power >= raw)


def _hex(color: Sequence[int]) -> str:
    return "#" + "".join(f"{int(c):02x}" for c in color[:3])


def stacked_bar_svg(frames: Sequence[int], series: Mapping[str, Sequence[float]], colors: Sequence[Sequence[int]],
                    *, title: str, summary: str, target_ms: float | None = None, target_fps: float | None = None,
                    near_sizes: Sequence[float | None] | None = None) -> str:
    """The chart as an SVG document. ``series``: per pass, one value per frame (ms)."""
    names = list(series)
    totals = [sum(series[name][i] for name in names) for i in range(len(frames))]
    top_ms = max([*totals, target_ms or 0.0, 1e-3]) * 1.1
    plot_w, plot_h = WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM

    def y(ms: float) -> float:
        return TOP + plot_h * (1.0 - ms / top_ms)

    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{WIDTH}' height='{HEIGHT}' "
           f"viewBox='0 0 {WIDTH} {HEIGHT}' {FONT} font-size='12'>",
           f"<rect width='{WIDTH}' height='{HEIGHT}' fill='white'/>",
           f"<text x='{WIDTH / 2}' y='24' text-anchor='middle' font-size='16'>{escape(title)}</text>"]
    # Bars, one stacked column per frame.
    slot = plot_w / max(len(frames), 1)
    bar = max(slot * 0.8, 0.5)
    for i, frame in enumerate(frames):
        x = LEFT + i * slot + (slot - bar) / 2
        base = 0.0
        for name, color in zip(names, colors):
            value = float(series[name][i])
            if value > 0:
                out.append(f"<rect x='{x:.2f}' y='{y(base + value):.2f}' width='{bar:.2f}' "
                           f"height='{y(base) - y(base + value):.2f}' fill='{_hex(color)}'>"
                           f"<title>frame {frame}: {escape(name)} {value:.2f} ms</title></rect>")
            base += value
    # Frame-time axis (left) and frames per second (right).
    out.append(f"<line x1='{LEFT}' y1='{TOP}' x2='{LEFT}' y2='{TOP + plot_h}' stroke='black'/>")
    out.append(f"<line x1='{LEFT + plot_w}' y1='{TOP}' x2='{LEFT + plot_w}' y2='{TOP + plot_h}' stroke='black'/>")
    out.append(f"<line x1='{LEFT}' y1='{TOP + plot_h}' x2='{LEFT + plot_w}' y2='{TOP + plot_h}' stroke='black'/>")
    step = _nice_step(top_ms)
    tick = 0.0
    while tick <= top_ms:
        out.append(f"<line x1='{LEFT - 4}' y1='{y(tick):.2f}' x2='{LEFT}' y2='{y(tick):.2f}' stroke='black'/>")
        out.append(f"<text x='{LEFT - 8}' y='{y(tick) + 4:.2f}' text-anchor='end'>{tick:g}</text>")
        tick += step
    for fps in (1, 2, 5, 10, 15, 24, 30, 60, 120, 240):
        ms = 1000.0 / fps
        if ms <= top_ms:
            out.append(f"<line x1='{LEFT + plot_w}' y1='{y(ms):.2f}' x2='{LEFT + plot_w + 4}' y2='{y(ms):.2f}' "
                       "stroke='black'/>")
            out.append(f"<text x='{LEFT + plot_w + 8}' y='{y(ms) + 4:.2f}'>{fps}</text>")
    out.append(f"<text transform='translate(18 {TOP + plot_h / 2}) rotate(-90)' text-anchor='middle'>"
               "frame time (ms)</text>")
    out.append(f"<text transform='translate({WIDTH - 14} {TOP + plot_h / 2}) rotate(90)' text-anchor='middle'>"
               "frames per second</text>")
    out.append(f"<text x='{LEFT + plot_w / 2}' y='{TOP + plot_h + 18}' text-anchor='middle'>"
               f"frames {frames[0] if frames else ''}-{frames[-1] if frames else ''}</text>")
    if target_ms is not None:
        label = f"target {target_fps:g} fps" if target_fps else f"target {target_ms:.1f} ms"
        out.append(f"<line class='target' x1='{LEFT}' y1='{y(target_ms):.2f}' x2='{LEFT + plot_w}' "
                   f"y2='{y(target_ms):.2f}' stroke='#c00000' stroke-dasharray='6 4'/>")
        out.append(f"<text x='{LEFT + plot_w - 4}' y='{y(target_ms) - 4:.2f}' text-anchor='end' "
                   f"fill='#c00000'>{escape(label)}</text>")
    sizes = [s for s in (near_sizes or []) if s is not None]
    if len(sizes) == len(frames) and sizes and max(sizes) > min(sizes):
        # The near cube's size per frame (Frame Budget), scaled to the plot's height.
        high = max(sizes) * 1.1
        points = " ".join(f"{LEFT + (i + 0.5) * slot:.2f},{TOP + plot_h * (1 - s / high):.2f}"
                          for i, s in enumerate(sizes))
        out.append(f"<polyline class='near-size' points='{points}' fill='none' stroke='#202020' "
                   "stroke-width='1.5'/>")
        out.append(f"<text x='{LEFT + 6}' y='{TOP + 14}'>line: near cube size "
                   f"{min(sizes):.2f}-{max(sizes):.2f}</text>")
    # Legend, then the summary.
    x, row = LEFT, HEIGHT - BOTTOM + 40
    for name, color in zip(names, colors):
        out.append(f"<rect x='{x}' y='{row - 10}' width='12' height='12' fill='{_hex(color)}'/>")
        out.append(f"<text class='pass' x='{x + 16}' y='{row}'>{escape(name)}</text>")
        x += 24 + 7 * len(name)
        if x > WIDTH - RIGHT - 80:
            x, row = LEFT, row + 18
    out.append(f"<text class='summary' x='{LEFT}' y='{HEIGHT - 12}'>{escape(summary)}</text>")
    out.append("</svg>")
    return "\n".join(out) + "\n"
