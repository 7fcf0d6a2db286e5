# SPDX-License-Identifier: GPL-3.0-or-later
"""The host's work per viewport redraw: ``python scripts/bench_redraw.py [--mode HYBRID] [--size 1920x1080]``.

Runs what ``view_draw`` runs before Blender's texture draw (``ViewportSession.frame``) on the
default cube, redraw after redraw of a still view, and prints the main thread's CPU time per
redraw (``time.thread_time()``: the GL driver runs the GPU work on its own threads, so this is
the host's share) and how many read-backs and ``ctx.finish()`` each redraw made, counted by
wrapping moderngl's read calls. Needs bpy.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from addon_loader import load_addon  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mode", default="HYBRID", help="Light Paths > Mode (default HYBRID)")
    parser.add_argument("--size", default="1920x1080", help="region size WxH")
    parser.add_argument("--redraws", type=int, default=12, help="timed redraws (after two)")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))

    import bpy
    import moderngl

    bpy.ops.wm.read_factory_settings(use_empty=False)
    addon = load_addon()
    addon.register()
    counts = {"reads": 0, "finish": 0}

    def counting(cls, name: str, key: str) -> None:
        original = getattr(cls, name)

        def wrapper(self, *a, **k):
            counts[key] += 1
            return original(self, *a, **k)

        setattr(cls, name, wrapper)

    for cls in (moderngl.Buffer, moderngl.Texture, moderngl.Framebuffer):
        for name in ("read", "read_into"):
            counting(cls, name, "reads")
    counting(moderngl.Context, "finish", "finish")

    from hybrid_engine.frame.viewport import RegionInput
    from hybrid_engine.scene.camera import Camera, look_at

    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = args.mode
    scene.hybrid_rt.viewport_samples = 4096
    session = addon.blender_adapter.viewport.ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get(), full=True)
    settings = addon.blender_adapter.properties.settings_from_scene(scene)
    camera = Camera(matrix_world=look_at((7.0, -6.0, 5.0), (0.0, 0.0, 0.0)), width=width, height=height, lens=35.0)
    region = RegionInput(camera.view_matrix(), camera.projection_matrix(), width, height)
    host, reads, finishes = [], set(), set()
    for index in range(args.redraws + 2):
        counts["reads"] = counts["finish"] = 0
        start = time.thread_time()
        frame = session.frame(region, settings)
        spent = (time.thread_time() - start) * 1e3
        if frame.error:
            print(frame.error)
            return 1
        if index >= 2:
            host.append(spent)
            reads.add(counts["reads"])
            finishes.add(counts["finish"])
    session.release()
    print(f"{args.mode} {width}x{height}: host per redraw median {statistics.median(host):.1f} ms "
          f"(min {min(host):.1f}, max {max(host):.1f}); read-backs per redraw {sorted(reads)}; "
          f"ctx.finish() per redraw {sorted(finishes)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
