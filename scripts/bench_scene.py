# SPDX-License-Identifier: GPL-3.0-or-later
"""HYBRID against FULL_BVH on a scene of the scene library, with bpy as a Python module.

Usage: python scripts/bench_scene.py --scene sponza [--assets DIR] [--detail D] [--frame F]
                                     [--rounds N] [--resolution WxH] [--near-size S]
                                     [--cube-far F] [--cube-resolution N] [--max-depth N]
                                     [--cube-march HIERARCHICAL|SAMPLED] [--json PATH]

The benchmark's frame comparison (``benchmarks/bench.py`` ``compare_modes``, the same
method and figures as ``python -m benchmarks.bench --sections frame`` gives for the
procedural Chess scene) on a scene built by ``benchmarks/scene_library.py``: frames
F .. F + 1 warm the two renderers up, frames F + 2 .. F + N + 1 are timed, the modes
alternating frame by frame. Every frame reaches the core as a timing report's does: the scene
is set to the frame, the evaluated depsgraph is synced (``scene_cache.TrackedScene``: what the
frame changed) and the camera read (``export.camera.camera_from_scene``); the sync is not part of
the frame times (it is the same for both modes) and is reported on its own as ``extract_ms``.

Render settings are the scene's own (near size and cube-map far plane as the library sets
them, the Hybrid RT defaults otherwise) with the paper's maximum depth of 4; each can be
overridden on the command line. Scenes other than ``chess`` load files from the assets folder
(``--assets``, else ``$HYBRID_RT_SCENES``, else ``../shared/scenes`` beside this checkout,
as scripts/make_pictures.py); a missing file stops the run with the library's message naming
it (exit status 2) before anything is built.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict
from pathlib import Path
from types import ModuleType

from addon_loader import load_addon
from make_pictures import (ASSETS_ENV, DEFAULT_ASSETS, DEFAULT_RESOLUTION, EXIT_MISSING_ASSETS, FRAME_COUNT,
                           SCENE_NAMES, assets_folder, check_scene_assets)

FULL_DETAIL = 1.0  # the paper's size


def parse_args(argv: list[str] | None, bench: ModuleType) -> argparse.Namespace:
    """The command line, checked; ``bench`` is the add-on's benchmarks.bench (its
    resolution parser and defaults, so both benchmarks read their options alike)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=SCENE_NAMES, default="sponza", help="scene of the library")
    parser.add_argument("--assets", default=None,
                        help=f"folder of the third-party scenes (default ${ASSETS_ENV}, else {DEFAULT_ASSETS})")
    parser.add_argument("--detail", type=float, default=FULL_DETAIL, help="scene detail in (0, 1]; 1: the paper's")
    parser.add_argument("--frame", type=int, default=0, help="first (warm-up) frame of the animation")
    parser.add_argument("--rounds", type=int, default=bench.ROUNDS, help="timed frames")
    parser.add_argument("--resolution", metavar="WxH", type=bench.parse_resolution, default=DEFAULT_RESOLUTION,
                        help="image size (default %dx%d)" % DEFAULT_RESOLUTION)
    parser.add_argument("--near-size", type=float, default=None, help="near-cube half-size (default: the scene's)")
    parser.add_argument("--cube-far", type=float, default=None, help="cube-map far plane (default: the scene's)")
    parser.add_argument("--cube-resolution", type=int, default=None,
                        help="cube-map face resolution (default: the scene's)")
    parser.add_argument("--cube-march", choices=bench.CUBE_MARCHES, default=None,
                        help="how HYBRID marches the cube map (default: the scene's)")
    parser.add_argument("--max-depth", type=int, default=bench.FRAME_MAX_DEPTH,
                        help=f"maximum ray recursion (default {bench.FRAME_MAX_DEPTH}, the paper's)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON to PATH")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error("--rounds must be >= 1")
    if not (math.isfinite(args.detail) and 0.0 < args.detail <= 1.0):
        parser.error("--detail must lie in (0, 1]")
    last = args.frame + bench.WARM_UP_FRAMES + args.rounds - 1
    if args.frame < 0 or last >= FRAME_COUNT:
        parser.error(f"frames {args.frame}..{last} (--frame, {bench.WARM_UP_FRAMES} warm-up frames, --rounds) "
                     f"must lie in the animation's 0..{FRAME_COUNT - 1}")
    return args


def mode_settings(scene, args: argparse.Namespace) -> dict:
    """RenderSettings keyword values shared by both modes: the scene's stored settings with
    the command line's overrides (``mode`` is left to the comparison)."""
    from hybrid_rt.blender_adapter import properties

    values = asdict(properties.settings_from_scene(scene))
    del values["mode"]
    overrides = {"near_size": args.near_size, "cube_far": args.cube_far, "cube_resolution": args.cube_resolution,
                 "cube_march": args.cube_march, "max_depth": args.max_depth}
    values.update({key: value for key, value in overrides.items() if value is not None})
    return values


def blender_frames(scene, first: int, count: int, extract_ms: list[float]) -> Iterator[tuple]:
    """(SceneData, Camera) of frames ``first .. first + count - 1``, each synced only when
    the comparison asks for it.

    The scene is followed as a timing report follows it (``scene_cache.TrackedScene``: the
    first frame reads everything, later ones what their frame changed); each frame is
    rendered before the next ``frame_set``, so the arrays edited in place are never changed
    under a render. Appends each sync's milliseconds to ``extract_ms``.
    """
    import bpy
    from hybrid_rt.blender_adapter import scene_cache
    from hybrid_rt.blender_adapter.export.camera import camera_from_scene

    tracked = scene_cache.TrackedScene()
    tracked.listen()
    try:
        for frame in range(first, first + count):
            scene.frame_set(frame)
            start = time.perf_counter()
            depsgraph = bpy.context.evaluated_depsgraph_get()
            if depsgraph.scene != scene:
                raise RuntimeError(f"the active scene is {depsgraph.scene.name!r}, not the benchmarked {scene.name!r}")
            data = tracked.scene_data(depsgraph)
            camera = camera_from_scene(scene, depsgraph)
            extract_ms.append((time.perf_counter() - start) * 1e3)
            yield data, camera
    finally:
        tracked.close()


def run_comparison(args: argparse.Namespace, assets: Path) -> dict:
    """Build the scene and compare the modes on its frames; the report of
    ``bench.compare_modes`` with the scene's description and extraction times added."""
    from benchmarks import scene_library
    from hybrid_rt.blender_adapter.gl_host import gl_block
    from benchmarks import bench

    start = time.perf_counter()
    scene = scene_library.build_scene(args.scene, assets, detail=args.detail, frame_count=FRAME_COUNT,
                                      resolution=args.resolution)
    build_s = time.perf_counter() - start
    first_timed = args.frame + bench.WARM_UP_FRAMES
    label = (f"{args.scene} (scene library, detail {args.detail:g}, frames {first_timed}-"
             f"{first_timed + args.rounds - 1})")
    extract_ms: list[float] = []
    frames = blender_frames(scene, args.frame, bench.WARM_UP_FRAMES + args.rounds, extract_ms)
    with gl_block():
        report = bench.compare_modes(frames, mode_settings(scene, args), label,
                                     context={"detail": float(args.detail)})
    report.update(scene_label=str(scene.get("hybrid_rt_label", args.scene)),
                  credits=scene_library.CREDITS[args.scene], scene_build_s=round(build_s, 2),
                  extract_ms=round(statistics.median(extract_ms), 3), machine=bench.machine_info())
    return report


def main(argv: list[str] | None = None) -> int:
    addon = load_addon()
    from benchmarks import bench
    from hybrid_rt.hybrid_engine.scene.settings import SettingsError

    args = parse_args(argv, bench)
    assets = assets_folder(args.assets)

    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    try:
        from benchmarks import scene_library

        try:
            check_scene_assets([args.scene], assets, skip_missing=False)
        except scene_library.SceneAssetError as error:
            print(f"bench_scene: {error}", file=sys.stderr)
            print("bench_scene: nothing measured (pass --assets DIR or set $HYBRID_RT_SCENES)", file=sys.stderr)
            return EXIT_MISSING_ASSETS
        try:
            report = run_comparison(args, assets)
        except SettingsError as error:
            print(f"bench_scene: {error}", file=sys.stderr)
            return 2
        print(bench.format_tables({"machine": report["machine"], "frame": report, "variants": bench.variants.chosen()}))
        print(f"scene: {report['scene_label']}; built in {report['scene_build_s']:.1f} s, "
              f"extraction {report['extract_ms']:.1f} ms per frame (not in the frame times)")
        if args.json:
            Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
