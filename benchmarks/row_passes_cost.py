# SPDX-License-Identifier: GPL-3.0-or-later
"""What the passes that read the G-buffer's world rows cost per frame on Chess.

``python -m benchmarks.row_passes_cost [--quick] [--detail 1] [--size 640x360] [--frames 8]
[--json PATH]``

Three passes need to know which triangle each pixel shows: the denoiser's moved surfaces
(passes/surface_motion/), Cryptomatte and the Vector pass (passes/film/). They find it by
the world row the primary G-buffer keeps per pixel, so their cost should follow the image,
not the triangles. On the procedural Chess scene (benchmarks/scenes/chess.py, HYBRID, the
pieces moving as in bench.py's ``frame`` section):

* ``surface_motion``: the primary raster step's median of a denoised renderer that follows
  the moves, against one that does not (``surface_motion.FOLLOW_MOVES`` off), alternating
  frame by frame in one process; the difference is the pass;
* ``cryptomatte``: the pass's median per sample (Object, Material, Asset at 6 levels);
* ``vector``: the pass's median per sample, the pieces' and the camera's motion of the
  frames around.

Each as wall time bracketed by ``ctx.finish()`` and as the main thread's CPU time (on
llvmpipe the vertex stage of a draw runs there). Compare two trees by running this in each.
"""
from __future__ import annotations

import statistics
import sys

import numpy as np

from benchmarks import bench
from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.gpu import gl_context
from hybrid_engine.passes.film.vector import FRAME_TIMES, VectorRequest
from hybrid_engine.passes.surface_motion import surface_motion
from hybrid_engine.scene.cryptomatte import CryptomatteRequest
from hybrid_engine.scene.motion import MotionSteps
from hybrid_engine.scene.settings import RenderSettings

WARM_UP = 2


def _median(results: list, name: str, kind: str = "passes") -> float:
    return round(statistics.median(getattr(r, kind).get(name, 0.0) for r in results), 3)


def measure(detail: float = 1.0, size: tuple[int, int] = (640, 360), frames: int = 8,
            cube_resolution: int = 256) -> dict:
    """The three passes' medians (module docstring) over ``frames`` timed frames or samples."""
    from hybrid_engine.frame.renderer import Renderer

    width, height = size
    scenes = [build_chess(detail, bench.FRAME_NUMBER + k, width, height) for k in range(frames + WARM_UP + 1)]
    settings = RenderSettings(mode="HYBRID", near_size=bench.FRAME_NEAR_SIZE, max_depth=bench.FRAME_MAX_DEPTH,
                              cube_resolution=cube_resolution, cube_far=CHESS_CUBE_FAR,
                              cube_back_layer=bench.FRAME_BACK_LAYER)
    ctx = gl_context.get_context()
    report: dict = {"scene": f"chess (procedural, detail {detail:g})", "resolution": f"{width}x{height}",
                    "frames": frames, "triangles": int(scenes[0][0].geometry.triangle_count)}
    renderers = {"follow": Renderer(ctx), "still": Renderer(ctx)}
    runs: dict[str, list] = {name: [] for name in renderers}
    try:
        for index, (scene, camera) in enumerate(scenes[1:]):
            for name, renderer in renderers.items():
                surface_motion.FOLLOW_MOVES = name == "follow"
                result = renderer.render(scene, camera, settings, timing=True, denoise=True)
                if index >= WARM_UP:
                    runs[name].append(result)
    finally:
        surface_motion.FOLLOW_MOVES = True
        for renderer in renderers.values():
            renderer.release()
    report["surface_motion"] = {
        "ms": round(_median(runs["follow"], "primary_raster") - _median(runs["still"], "primary_raster"), 3),
        "host_ms": round(_median(runs["follow"], "primary_raster", "host_passes")
                         - _median(runs["still"], "primary_raster", "host_passes"), 3)}
    # One view of the animation, its frames before and after for the Vector pass's motion.
    (before, _), (scene, camera), (after, _) = scenes[0], scenes[1], scenes[2]
    matrices = np.stack([np.asarray(s.geometry.instances.matrices, np.float64) for s in (before, scene, after)])
    cameras = np.stack([np.asarray(c.matrix_world, np.float64) for _, c in scenes[:3]])
    outputs = {"cryptomatte": FrameOutputs(cryptomatte=CryptomatteRequest(("object", "material", "asset"), 6)),
               "vector": FrameOutputs(vector=VectorRequest(MotionSteps(times=FRAME_TIMES, instances=matrices,
                                                                       camera=cameras)))}
    for name, asked in outputs.items():
        renderer = Renderer(ctx)
        try:
            samples = [renderer.render(scene, camera, settings, timing=True, outputs=asked, accumulate=True, sample=0)
                       for _ in range(frames + WARM_UP)][WARM_UP:]
        finally:
            renderer.release()
        report[name] = {"ms": _median(samples, name), "host_ms": _median(samples, name, "host_passes")}
    return report


def format_report(report: dict) -> str:
    lines = [f"{report['scene']}, {report['triangles']:,} triangles, {report['resolution']}, "
             f"{report['frames']} timed frames or samples"]
    for name in ("surface_motion", "cryptomatte", "vector"):
        lines.append(f"  {name:15s} {report[name]['ms']:9.1f} ms wall, {report[name]['host_ms']:8.1f} ms main thread")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return bench.chess_cost_main(__doc__.splitlines()[0], measure, format_report, "640x360", argv)


if __name__ == "__main__":
    sys.exit(main())
