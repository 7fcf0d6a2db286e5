#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Host-side cost of a frame: what Blender's scene costs the CPU before any GPU pass.

``python scripts/bench_host.py [--frames N] [--quick] [--json PATH]`` (the ``host`` section of
``make bench``; needs bpy). Four scenes, each followed frame by frame the way a timing report
follows it (``scene_cache.TrackedScene``: ``frame_set``, the depsgraph handlers' change set,
one sync), and each frame rendered at a thumbnail size so that the renderer's ``upload`` pass
(GPU buffers written from the synced arrays) is timed as well:

``static``
    A static scene of subdivided spheres seen by a moving camera.
``chess``
    The scene library's Chess: its moving pieces and mirror spheres.
``deform``
    One mesh of ~100k vertices deformed by a Wave modifier, every frame.
``instances``
    10,000 unchanged linked duplicates of one 320-triangle mesh.
``scatter``
    A geometry-nodes scatter: 100,000 instances of one 80-triangle mesh on a plane (Distribute
    Points on Faces, Instance on Points), and one small cube that moves, so that every frame's
    sync walks the instances: Blender gives them one by one (``depsgraph.object_instances``),
    with no bulk read of their matrices, and that walk is what remains per instance.

Per scene: ``extract`` (the sync) and ``upload`` (the upload pass, the host's copies: buffer
writes, the instance table) in milliseconds, mean of every frame after the first (which reads
everything), with the triangle count; ``host`` is their sum. The instance transform is GPU
work, a pass of its own: a GPU runs it beside the host, this machine's software driver on the
CPU, reported apart as ``transform``.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from addon_loader import load_addon  # noqa: E402 - also puts the repository root on sys.path

from benchmarks.bench import choice_list  # noqa: E402

SCENES = ("static", "chess", "deform", "instances", "scatter")
FULL = {"static_spheres": 100, "static_subdivisions": 6, "deform_grid": 316, "instances": 10_000, "chess_detail": 1.0,
        "scatter": 100_000}
QUICK = {"static_spheres": 4, "static_subdivisions": 3, "deform_grid": 40, "instances": 200, "chess_detail": 0.05,
         "scatter": 500}
THUMBNAIL = (64, 36)


def _empty_scene():
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.render.resolution_x, scene.render.resolution_y = THUMBNAIL
    scene.hybrid_rt.cube_resolution = 64
    scene.hybrid_rt.shadow_resolution = 256
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location, camera.rotation_euler = (0.0, -30.0, 8.0), (math.radians(75), 0.0, 0.0)
    return scene, camera


def _static(params: dict):
    """Spheres in a ring that stand still; the camera dollies in."""
    import bpy

    scene, camera = _empty_scene()
    mesh = bpy.data.meshes.new("sphere")
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=params["static_subdivisions"], radius=1.0)
    bm.to_mesh(mesh)
    bm.free()
    count = params["static_spheres"]
    for i in range(count):
        # One mesh per sphere: a scene of distinct meshes, not instances of one.
        obj = bpy.data.objects.new(f"Sphere{i}", mesh.copy())
        angle = 2 * math.pi * i / count
        obj.location = (12 * math.cos(angle), 12 * math.sin(angle), 1.0)
        scene.collection.objects.link(obj)
    camera.keyframe_insert("location", frame=1)
    camera.location.y += 8.0
    camera.keyframe_insert("location", frame=20)
    return scene


def _chess(params: dict):
    from benchmarks import scene_library

    return scene_library.build_scene("chess", detail=params["chess_detail"], resolution=THUMBNAIL)


def _deform(params: dict):
    import bpy

    scene, _camera = _empty_scene()
    n = params["deform_grid"]
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=n - 1, y_subdivisions=n - 1, size=20)
    grid = bpy.context.object
    wave = grid.modifiers.new("Wave", "WAVE")
    wave.height, wave.width, wave.speed = 0.6, 1.5, 0.4
    return scene


def _instances(params: dict):
    import bmesh
    import bpy

    scene, _camera = _empty_scene()
    mesh = bpy.data.meshes.new("ico320")
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=3, radius=0.2)  # 320 triangles
    bm.to_mesh(mesh)
    bm.free()
    side = math.ceil(math.sqrt(params["instances"]))
    for i in range(params["instances"]):
        obj = bpy.data.objects.new(f"Ico{i}", mesh)
        obj.location = ((i % side - side / 2) * 0.5, (i // side) * 0.5, 0.2)
        scene.collection.objects.link(obj)
    return scene


def _scatter(params: dict):
    """Geometry nodes scatter ``params["scatter"]`` instances of an icosphere over a plane."""
    import bpy

    scene, _camera = _empty_scene()
    bpy.ops.mesh.primitive_plane_add(size=40)
    ground = bpy.context.object
    tree = bpy.data.node_groups.new("scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    distribute = nodes.new("GeometryNodeDistributePointsOnFaces")
    distribute.distribute_method = "RANDOM"
    distribute.inputs["Density"].default_value = params["scatter"] / (40.0 * 40.0)
    ico = nodes.new("GeometryNodeMeshIcoSphere")
    ico.inputs["Radius"].default_value = 0.05
    ico.inputs["Subdivisions"].default_value = 2  # 80 triangles
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    join = nodes.new("GeometryNodeJoinGeometry")
    links.new(group_in.outputs[0], distribute.inputs["Mesh"])
    links.new(distribute.outputs["Points"], on_points.inputs["Points"])
    links.new(ico.outputs["Mesh"], on_points.inputs["Instance"])
    links.new(on_points.outputs["Instances"], join.inputs[0])
    links.new(group_in.outputs[0], join.inputs[0])
    links.new(join.outputs[0], group_out.inputs[0])
    ground.modifiers.new("scatter", "NODES").node_group = tree
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0.0, 0.0, 1.0))
    mover = bpy.context.object
    mover.keyframe_insert("location", frame=1)
    mover.location.x += 5.0
    mover.keyframe_insert("location", frame=20)
    return scene


BUILDERS = {"static": _static, "chess": _chess, "deform": _deform, "instances": _instances, "scatter": _scatter}


def measure(name: str, params: dict, frames: int) -> dict:
    """Build scene ``name``, follow frames 1..frames, return the per-frame host figures."""
    import bpy
    from hybrid_rt.blender_adapter import engine, scene_cache
    from hybrid_rt.blender_adapter.export.camera import camera_from_scene
    from hybrid_rt.blender_adapter.gl_host import gl_block

    start = time.perf_counter()
    scene = BUILDERS[name](params)
    build_s = time.perf_counter() - start
    tracked = scene_cache.TrackedScene()
    extract_ms, transform_ms, upload_host_ms, walked = [], [], [], []
    triangles = 0
    try:
        tracked.listen()
        for frame in range(1, frames + 1):
            scene.frame_set(frame)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            t0 = time.perf_counter()
            data = tracked.scene_data(depsgraph)
            extract_ms.append((time.perf_counter() - t0) * 1e3)
            walked.append(tracked.last_sync.walked)
            camera = camera_from_scene(scene, depsgraph)
            settings = engine.properties.settings_from_scene(scene)
            with gl_block():
                result = engine.shared_renderer().render(data, camera, settings, timing=True)
            transform_ms.append(float(result.passes["instance_transform"]))
            upload_host_ms.append(engine.shared_renderer().gpu_scene.host_ms)
            triangles = data.geometry.triangle_count
    finally:
        tracked.close()
    later = slice(1, None)
    return {
        "triangles": int(triangles),
        "frames": frames,
        "build_s": round(build_s, 2),
        "extract_ms": round(statistics.fmean(extract_ms[later]), 3),
        "upload_ms": round(statistics.fmean(upload_host_ms[later]), 3),
        # What the instance transform costs a software driver, which runs it on the CPU; a GPU
        # runs it beside the host.
        "transform_ms": round(statistics.fmean(transform_ms[later]), 3),
        "host_ms": round(statistics.fmean(e + u for e, u in zip(extract_ms[later], upload_host_ms[later])), 3),
        "first_frame_extract_ms": round(extract_ms[0], 1),
        "walked_frames": int(sum(walked[later])),
    }


def run(scenes=SCENES, frames: int = 6, quick: bool = False) -> dict:
    addon = load_addon()
    addon.register()
    try:
        params = QUICK if quick else FULL
        return {name: measure(name, params, frames) for name in scenes}
    finally:
        addon.unregister()


def format_table(report: dict) -> str:
    lines = ["host: per frame after the first (ms, mean)",
             f"{'scene':<10} {'triangles':>10} {'extract':>9} {'upload':>8} {'host':>8} {'walked':>7} "
             f"{'transform (GPU work)':>21}"]
    for name, row in report.items():
        lines.append(f"{name:<10} {row['triangles']:>10,} {row['extract_ms']:>9.2f} {row['upload_ms']:>8.2f} "
                     f"{row['host_ms']:>8.2f} {row['walked_frames']:>3}/{row['frames'] - 1} "
                     f"{row['transform_ms']:>21.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python scripts/bench_host.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=6, help="frames followed per scene (>= 2)")
    parser.add_argument("--quick", action="store_true", help="small scenes (seconds, for tests)")
    parser.add_argument("--scenes", type=choice_list(SCENES), default=list(SCENES),
                        help=f"comma-separated subset of {', '.join(SCENES)}")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON to PATH")
    args = parser.parse_args(argv)
    scenes = args.scenes
    if args.frames < 2:
        parser.error("--frames must be >= 2 (the first frame reads everything and is not counted)")
    report = run(scenes, args.frames, args.quick)
    print(format_table(report))
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
