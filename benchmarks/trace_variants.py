# SPDX-License-Identifier: GPL-3.0-or-later
"""The two shapes of the ``trace`` kernel side by side on a Chess frame:
``python -m benchmarks.trace_variants``.

Usage::

    python -m benchmarks.trace_variants [--quick] [--rounds N] [--detail D] [--size WxH] [--json PATH]

One Renderer renders the same HYBRID frame of the procedural Chess animation with the
megakernel (``trace=cpu``) and in waves (``trace=gpu``, passes/trace/wave_trace.py),
alternating round by round after one warm-up each (the machine's speed drifts within a run),
and reports the medians of the ``trace`` pass (the renderer's pass timer: wall clock
bracketed by ``ctx.finish()``), their ratio, the wave pipeline's GPU memory (bytes allocated,
per pixel), the most rays any wave wanted, whether the counters agree and the FLIP between
the two images.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.gpu import gl_context, variants
from hybrid_engine.scene.settings import RenderSettings

from .bench import FRAME_BACK_LAYER, FRAME_MAX_DEPTH, FRAME_NEAR_SIZE, FULL_FRAME, QUICK_FRAME, flip_mean, machine_info
from .scenes import CHESS_CUBE_FAR, build_chess

ROUNDS = 7
FRAME = 2  # past the animation's first frames (bench.py's frame section times from here)


def wave_bytes(renderer: Renderer) -> int:
    """GPU bytes the wave pipeline holds (its queues, state and per-pixel sums)."""
    waves = renderer.tracer._waves
    if waves is None:
        return 0
    if hasattr(waves, "bytes_allocated"):
        return waves.bytes_allocated()
    return sum(b.size for b in waves._buffers.values()) + (waves._state.size if waves._state else 0)


def measure(detail: float, size: tuple[int, int], rounds: int) -> dict:
    width, height = size
    scene, camera = build_chess(detail, FRAME, width, height)
    settings = RenderSettings(mode="HYBRID", near_size=FRAME_NEAR_SIZE, max_depth=FRAME_MAX_DEPTH,
                              cube_resolution=FULL_FRAME["cube_resolution"], cube_far=CHESS_CUBE_FAR,
                              cube_back_layer=FRAME_BACK_LAYER)
    renderer = Renderer(gl_context.get_context())
    times: dict[str, list[float]] = {"cpu": [], "gpu": []}
    counts: dict[str, dict] = {}
    images: dict[str, object] = {}
    try:
        for index in range(rounds + 1):
            for family in ("cpu", "gpu") if index % 2 == 0 else ("gpu", "cpu"):
                variants.set_override(f"trace={family}")
                result = renderer.render(scene, camera, settings, sample=0, timing=True)
                counts[family] = {k: v for k, v in result.counts.items() if k.startswith(("rays_", "bvh_nodes",
                                                                                           "cube_steps"))}
                images[family] = result.image
                if index > 0:  # the first round compiles and allocates
                    times[family].append(result.passes["trace"])
        wanted = renderer.tracer._waves.overflowed()
        memory = wave_bytes(renderer)
    finally:
        variants.set_override(None)
        renderer.release()
    mega, waves = statistics.median(times["cpu"]), statistics.median(times["gpu"])
    return {"scene": f"chess detail {detail:g} frame {FRAME}", "resolution": f"{width}x{height}",
            "rounds": rounds, "megakernel_trace_ms": round(mega, 3), "waves_trace_ms": round(waves, 3),
            "waves_over_megakernel": round(waves / mega, 3), "wave_bytes": memory,
            "wave_bytes_per_pixel": round(memory / (width * height), 1), "most_rays_wanted": wanted[0],
            "most_occlusion_rays_wanted": wanted[1], "counters_identical": counts["cpu"] == counts["gpu"],
            "flip_waves_vs_megakernel": round(flip_mean(images["cpu"], images["gpu"]), 6),
            "megakernel_ms_all": [round(v, 2) for v in times["cpu"]],
            "waves_ms_all": [round(v, 2) for v in times["gpu"]]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tiny frame, for a smoke test")
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--detail", type=float, default=None)
    parser.add_argument("--size", default=None, help="WxH (default 640x360)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    frame = QUICK_FRAME if args.quick else FULL_FRAME
    detail = args.detail if args.detail is not None else frame["detail"]
    size = tuple(int(v) for v in args.size.split("x")) if args.size else frame["resolution"]
    report = {"machine": machine_info(), "trace": measure(detail, size, 2 if args.quick else args.rounds)}
    text = json.dumps(report, indent=2)
    if args.json is not None:
        args.json.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
