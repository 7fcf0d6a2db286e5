# SPDX-License-Identifier: GPL-3.0-or-later
"""What the diffuse paths' radiance cache costs per frame on a still view of Chess.

``python -m benchmarks.radiance_cache_cost [--quick] [--detail 1] [--size 1280x720] [--frames 8]
[--json PATH]``

The cache (passes/diffuse_light/radiance_cache.py) works in denoised frames of a view whose
scene stands still (an object that moves empties it, and such a frame neither reads nor fills
it: the ``frame`` section's Chess, whose pieces move, never uses it). Here one Chess frame
(benchmarks/scenes/chess.py, HYBRID) is redrawn as a still viewport redraws it, denoised, by
two renderers alternating frame by frame in one process, *Radiance Cache* on and off. The
``shade`` step (the diffuse gather, with the cache its deposits, look-ups and the fold of the
deposits into the cells) is reported as its median over the timed frames, as wall time
bracketed by ``ctx.finish()`` and as the main thread's CPU time, with their ratio. The first
frames count the cells most (a new history); the timed frames follow ``WARM_UP`` of them.
"""
from __future__ import annotations

import statistics
import sys
from dataclasses import replace

from benchmarks import bench
from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
from hybrid_engine.gpu import gl_context
from hybrid_engine.scene.settings import RenderSettings

WARM_UP = 2


def _median(results: list, kind: str = "passes") -> float:
    return round(statistics.median(getattr(r, kind).get("shade", 0.0) for r in results), 3)


def measure(detail: float = 1.0, size: tuple[int, int] = (1280, 720), frames: int = 8,
            cube_resolution: int = 256) -> dict:
    """The ``shade`` step's medians with the cache on and off (module docstring)."""
    from hybrid_engine.frame.renderer import Renderer

    width, height = size
    scene, camera = build_chess(detail, bench.FRAME_NUMBER, width, height)
    base = RenderSettings(mode="HYBRID", near_size=bench.FRAME_NEAR_SIZE, max_depth=bench.FRAME_MAX_DEPTH,
                          cube_resolution=cube_resolution, cube_far=CHESS_CUBE_FAR,
                          cube_back_layer=bench.FRAME_BACK_LAYER)
    ctx = gl_context.get_context()
    variants = {"on": replace(base, radiance_cache=True), "off": replace(base, radiance_cache=False)}
    renderers = {name: Renderer(ctx) for name in variants}
    runs: dict[str, list] = {name: [] for name in variants}
    filled = False
    try:
        for index in range(frames + WARM_UP):
            for name, settings in variants.items():
                result = renderers[name].render(scene, camera, settings, timing=True, denoise=True,
                                                sample=index, reuse_world=index > 0)
                if index >= WARM_UP:
                    runs[name].append(result)
        cache = renderers["on"].diffuse_light.cache
        filled = cache is not None and len(cache.read()[0]) > 0
    finally:
        for renderer in renderers.values():
            renderer.release()
    report: dict = {"scene": f"chess (procedural, detail {detail:g}), one still view",
                    "resolution": f"{width}x{height}", "frames": frames,
                    "triangles": int(scene.geometry.triangle_count), "cells_filled": filled}
    for name in variants:
        report[name] = {"shade_ms": _median(runs[name]), "shade_host_ms": _median(runs[name], "host_passes")}
    off = report["off"]["shade_ms"]
    report["ratio"] = round(report["on"]["shade_ms"] / off, 4) if off > 0 else None
    return report


def format_report(report: dict) -> str:
    lines = [f"{report['scene']}, {report['triangles']:,} triangles, {report['resolution']}, "
             f"{report['frames']} timed frames per variant (cells filled: {report['cells_filled']})"]
    for name in ("on", "off"):
        lines.append(f"  cache {name:3s}  shade {report[name]['shade_ms']:9.1f} ms wall, "
                     f"{report[name]['shade_host_ms']:8.1f} ms main thread")
    lines.append(f"  on / off: {report['ratio']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return bench.chess_cost_main(__doc__.splitlines()[0], measure, format_report, "1280x720", argv)


if __name__ == "__main__":
    sys.exit(main())
