# SPDX-License-Identifier: GPL-3.0-or-later
"""Build one of the library's test scenes and save it as a .blend.

Usage: python scripts/build_scene.py {chess,chess_real,sponza,large} [--assets ../shared/scenes]
       [--detail 1.0] [--frames 200] [--width 1280 --height 720] --save out/sponza.blend

The scenes are those of ``benchmarks/scene_library.py`` (the paper's Chess, Sponza with
Buddha, bunny and dragon, and a labelled San Miguel stand-in); the add-on is registered from
this checkout exactly as Blender would import it. The saved file renders with Hybrid RT,
EEVEE or Cycles; its textures stay where the assets folder keeps them (never copied).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from addon_loader import load_addon

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_ASSETS = REPO_ROOT.parent / "shared" / "scenes"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="chess, chess_real, sponza or large")
    parser.add_argument("--assets", default=None,
                        help=f"folder of third-party scenes (default: $HYBRID_RT_SCENES, else {DEFAULT_ASSETS})")
    parser.add_argument("--detail", type=float, default=1.0, help="1 is the paper's size; smaller is smaller")
    parser.add_argument("--frames", type=int, default=200, help="length of the animation")
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    parser.add_argument("--save", required=True, help="path of the .blend to write")
    args = parser.parse_args(argv)

    import bpy

    addon = load_addon()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    try:
        from benchmarks import scene_library

        if args.scene not in scene_library.SCENES:
            parser.error(f"unknown scene {args.scene!r}: choose one of {', '.join(scene_library.SCENES)}")
        assets = args.assets
        if assets is None and scene_library.resolve_assets(None) is None and DEFAULT_ASSETS.is_dir():
            assets = DEFAULT_ASSETS
        start = time.perf_counter()
        try:
            scene = scene_library.build_scene(args.scene, assets, detail=args.detail, frame_count=args.frames,
                                              resolution=(args.width, args.height))
        except (scene_library.SceneAssetError, ValueError) as error:
            print(f"build_scene: {error}", file=sys.stderr)
            return 2
        seconds = time.perf_counter() - start
        for other in [s for s in bpy.data.scenes if s != scene]:  # the factory session's empty scene
            bpy.data.scenes.remove(other)
        triangles = scene_library.scene_triangle_count(bpy.context.evaluated_depsgraph_get())
        output = Path(args.save).resolve()
        output.parent.mkdir(parents=True, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=str(output), check_existing=False)
        print(f"build_scene: {scene.name!r} built in {seconds:.1f} s, {triangles:,} triangles at frame 0, "
              f"frames {scene.frame_start}-{scene.frame_end}")
        if "hybrid_rt_label" in scene:
            print(f"build_scene: {scene['hybrid_rt_label']}")
        print(f"build_scene: credits: {scene['hybrid_rt_credits']}")
        print(f"build_scene: wrote {output}")
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
