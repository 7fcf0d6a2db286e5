# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the demo: the paper's Chess scene, generated in code, through Blender's render path.

Usage: python scripts/demo.py [--output out/demo.png] [--width W --height H] [--detail D]
                              [--report-frames N] [--simple]

Registers the add-on from this checkout exactly as Blender would import it, builds the
procedural Chess scene (benchmarks/scene_library.py: 288 pieces, nine mirror spheres,
nothing read from outside the repository) and renders frame 0 with ``bpy.ops.render.render``
in HYBRID mode, then the same frame in PROVENANCE mode (paper Figure 4), then a timing report
over the first frames of the animation (paper Figure 5). On a hardware GPU: the paper's full
scene (2.15 M triangles) at 1280x720; on a software renderer (llvmpipe) detail 0.7
(1.5 M triangles) at 640x360. Writes out/demo.png, out/demo_provenance.png and
out/demo_timing.{json,csv,png}, and prints the per-pass table. ``--simple`` renders the
small five-object scene instead (seconds).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from addon_loader import load_addon

REPO_ROOT = Path(__file__).resolve().parent.parent
CPU_DETAIL = 0.7  # 1.5 M triangles: the largest chess whose per-triangle buffers fit llvmpipe's blocks
REPORT_FRAMES = 5


def principled(name, color, metallic=0.0, roughness=0.5, transmission=0.0, ior=1.45, thickness=0.5):
    import bpy

    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Transmission Weight"].default_value = transmission
    bsdf.inputs["IOR"].default_value = ior
    mat.hybrid_rt.thickness = thickness
    return mat


def build_demo_scene(width: int, height: int):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=False)  # default cube, light and camera
    scene = bpy.context.scene
    cube = bpy.data.objects["Cube"]
    cube.data.materials.clear()
    cube.data.materials.append(principled("Terracotta", (0.8, 0.3, 0.15)))

    bpy.ops.mesh.primitive_plane_add(size=30, location=(0, 0, -1))
    bpy.context.object.data.materials.append(principled("Floor", (0.6, 0.6, 0.55), thickness=1.0))

    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(2.6, 0.4, 0.0), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(principled("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0))

    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(-2.4, -0.8, -0.2), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(
        principled("Glass", (1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, ior=1.5, thickness=0.0)
    )

    light = bpy.data.objects["Light"]
    light.data.energy = 800.0
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = 2.0
    sun_obj = bpy.data.objects.new("Sun", sun)
    sun_obj.rotation_euler = (math.radians(40), math.radians(15), math.radians(30))
    scene.collection.objects.link(sun_obj)

    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.35, 0.5, 0.8, 1.0)
    background.inputs["Strength"].default_value = 0.6

    scene.render.engine = "HYBRID_RT"
    # The near cube reaches past the spheres and the cube (camera ~11 m away): they are ray
    # traced through the BVH, while the far floor and beyond come from the cube map.
    scene.hybrid_rt.near_size = 11.0
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    return scene


def software_gl() -> bool:
    """True when the GL driver is a software renderer (llvmpipe): the demo then renders a
    smaller chess scene at 640x360 instead of the paper's full scene at 1280x720."""
    from hybrid_rt.hybrid_engine.gpu import gl_context  # the add-on package (addon_loader)

    return gl_context.is_software_renderer()


def render_still(scene, output: Path) -> None:
    import bpy

    scene.render.filepath = str(output)
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(REPO_ROOT / "out" / "demo.png"))
    parser.add_argument("--width", type=int, default=None, help="default 1280 on a GPU, 640 on a CPU")
    parser.add_argument("--height", type=int, default=None, help="default 720 on a GPU, 360 on a CPU")
    parser.add_argument("--detail", type=float, default=None,
                        help=f"chess detail (1 = the paper's 2.15 M triangles; default 1 on a GPU, "
                        f"{CPU_DETAIL} on a CPU)")
    parser.add_argument("--report-frames", type=int, default=REPORT_FRAMES,
                        help="frames of the animation in the timing report (0: none)")
    parser.add_argument("--simple", action="store_true",
                        help="the small five-object scene instead of the chess scene")
    args = parser.parse_args(argv)

    import bpy

    addon = load_addon()
    addon.register()
    try:
        software = software_gl()
        width = args.width or (640 if software else 1280)
        height = args.height or (360 if software else 720)
        output = Path(args.output).resolve()
        output.parent.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        if args.simple:
            scene = build_demo_scene(width, height)
            label = "the five-object demo scene"
        else:
            from benchmarks import scene_library

            detail = args.detail or (CPU_DETAIL if software else 1.0)
            scene = scene_library.build_scene("chess", detail=detail, resolution=(width, height))
            label = f"the generated Chess scene (detail {detail:g})"
        print(f"demo: built {label} in {time.perf_counter() - start:.1f} s")

        from hybrid_rt.blender_adapter import engine

        engine.time_final_renders = True  # the per-pass table below
        start = time.perf_counter()
        render_still(scene, output)
        wall = (time.perf_counter() - start) * 1e3
        frame = engine.last_frame
        if frame is None or not output.is_file():
            print("demo: the render produced no image; see the messages above", file=sys.stderr)
            return 1
        print(f"demo: wrote {output} ({width}x{height}, mode {frame.mode})")
        print(f"demo: {frame.counts.get('triangles_total', 0):,} triangles, "
              f"{frame.counts.get('triangles_bvh', 0):,} in the near-cube BVH; "
              f"frame {frame.total_ms:.1f} ms, render call {wall:.1f} ms ({frame.timing_source})")
        for name, ms in frame.passes.items():
            print(f"  {name:<18} {ms:9.2f} ms")

        provenance = output.with_name(output.stem + "_provenance.png")
        mode = scene.hybrid_rt.mode
        scene.hybrid_rt.mode = "PROVENANCE"
        try:
            render_still(scene, provenance)
        finally:
            scene.hybrid_rt.mode = mode
        print(f"demo: wrote {provenance} (PROVENANCE: blue = first secondary ray in the BVH, "
              f"red = in the cube map)")

        if args.report_frames > 0:
            prefix = output.with_name(output.stem + "_timing")
            last = scene.frame_start + args.report_frames - 1
            result = bpy.ops.hybrid_rt.timing_report(filepath=str(prefix), frame_start=scene.frame_start,
                                                     frame_end=last)
            if result != {"FINISHED"}:
                print("demo: the timing report failed; see the messages above", file=sys.stderr)
                return 1
            print(f"demo: wrote {prefix}.json, .csv, .png and .svg (frames {scene.frame_start}-{last})")
            summary = json.loads(prefix.with_suffix(".json").read_text())["summary"]
            print(f"demo: median frame {summary['frame_ms']['median']:.1f} ms "
                  f"({summary['fps']['median']:.2f} FPS), per-pass means:")
            for name, ms in summary["pass_mean_ms"].items():
                print(f"  {name:<18} {ms:9.2f} ms")
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
