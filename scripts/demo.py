# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the default demo scene through Blender's render path with HYBRID_RT.

Usage: python scripts/demo.py [--output out/demo.png] [--width 640] [--height 360]

Builds a small scene in a factory-fresh Blender session (a floor, Blender's default cube,
a mirror sphere, a glass sphere, a sun and a point light; HYBRID mode with the near cube around
the objects), registers the add-on from this
checkout exactly as Blender would import it, and renders with ``bpy.ops.render.render``.
Writes the image and prints the per-pass timing of the frame.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from addon_loader import load_addon

REPO_ROOT = Path(__file__).resolve().parent.parent


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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(REPO_ROOT / "out" / "demo.png"))
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    args = parser.parse_args(argv)

    import bpy

    addon = load_addon()
    addon.register()
    try:
        scene = build_demo_scene(args.width, args.height)
        output = Path(args.output).resolve()
        output.parent.mkdir(parents=True, exist_ok=True)
        scene.render.filepath = str(output)
        scene.render.image_settings.file_format = "PNG"
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        wall = (time.perf_counter() - start) * 1e3
        from hybrid_rt.blender_adapter import engine

        frame = engine.last_frame
        if frame is None or not output.is_file():
            print("demo: the render produced no image; see the messages above", file=sys.stderr)
            return 1
        print(f"demo: wrote {output} ({args.width}x{args.height}, mode {frame.mode})")
        print(f"demo: {frame.counts.get('triangles_total', 0):,} triangles, "
              f"frame {frame.total_ms:.1f} ms, render call {wall:.1f} ms ({frame.timing_source})")
        for name, ms in frame.passes.items():
            print(f"  {name:<16} {ms:9.2f} ms")
        return 0
    finally:
        addon.unregister()


if __name__ == "__main__":
    sys.exit(main())
