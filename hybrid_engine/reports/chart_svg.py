# SPDX-License-Identifier: GPL-3.0-or-later
"""The timing report's chart as SVG: vector, with real text, for reading and for documents.

The same stacked per-pass bars as the PNG (``chart_raster``, the paper's Figure 5), with more
than the PNG's compact chart carries: a frame-time axis in milliseconds on the left, the
frames-per-second those times mean on the right, the target frame rate as a dashed line, a
legend naming every pass, the near cube's size per frame where it varied (Frame Budget), a
strip under the frames showing where each frame's secondary rays ended (BVH, cube map, sky),
and a summary (mean and 95th-percentile frame time, the slowest pass, the rays' story). Plain text output,
no dependency: ``xml.sax.saxutils`` escapes the names.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from xml.sax.saxutils import escape

WIDTH, HEIGHT = 1000, 600
LEFT, RIGHT, TOP, BOTTOM = 70, 70, 50, 150  # plot margins: axes, title, ray strip, legend, summary
# Where rays ended (the strip under the frames): BVH blue, cube map red, sky green, as the
# diagnostic views colour them (diagnostics.PATH_COLOURS).
RAY_END_COLOURS = (("BVH", "#0033ff"), ("cube map", "#ff0d00"), ("sky", "#1ae633"))
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
                    near_sizes: Sequence[float | None] | None = None,
                    ray_shares: Sequence[tuple[float, float, float] | None] | None = None) -> str:
    """The chart as an SVG document. ``series``: per pass, one value per frame (ms).
    ``ray_shares``: per frame, the shares of its rays that ended in the BVH, the cube map and
    the sky (None for a frame without rays)."""
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
    if ray_shares and any(share is not None for share in ray_shares):
        strip_top, strip_h = TOP + plot_h + 28, 18
        out.append(f"<text x='{LEFT - 8}' y='{strip_top + 13}' text-anchor='end'>rays</text>")
        for i, share in enumerate(ray_shares):
            if share is None:
                continue
            x0, y0 = LEFT + i * slot + (slot - bar) / 2, float(strip_top)
            for (name, colour), part in zip(RAY_END_COLOURS, share):
                if part > 0:
                    out.append(f"<rect class='ray-share' x='{x0:.2f}' y='{y0:.2f}' width='{bar:.2f}' "
                               f"height='{strip_h * part:.2f}' fill='{colour}'><title>frame {frames[i]}: "
                               f"{part:.1%} of rays ended in the {name}</title></rect>")
                    y0 += strip_h * part
        x = LEFT + plot_w - 250
        for name, colour in RAY_END_COLOURS:
            out.append(f"<rect x='{x}' y='{strip_top + 22}' width='10' height='10' fill='{colour}'/>")
            out.append(f"<text x='{x + 14}' y='{strip_top + 31}'>rays ended: {name}</text>" if name == "BVH"
                       else f"<text x='{x + 14}' y='{strip_top + 31}'>{name}</text>")
            x += 110 if name == "BVH" else 75
    # Legend, then the summary.
    x, row = LEFT, HEIGHT - BOTTOM + 85
    for name, color in zip(names, colors):
        out.append(f"<rect x='{x}' y='{row - 10}' width='12' height='12' fill='{_hex(color)}'/>")
        out.append(f"<text class='pass' x='{x + 16}' y='{row}'>{escape(name)}</text>")
        x += 24 + 7 * len(name)
        if x > WIDTH - RIGHT - 80:
            x, row = LEFT, row + 18
    lines = summary.split("\n")
    for k, line in enumerate(lines):
        out.append(f"<text class='summary' x='{LEFT}' y='{HEIGHT - 12 - 16 * (len(lines) - 1 - k)}'>"
                   f"{escape(line)}</text>")
    out.append("</svg>")
    return "\n".join(out) + "\n"
