# SPDX-License-Identifier: GPL-3.0-or-later
"""What the Color Attribute node costs a frame: ``python -m benchmarks.node_attributes``.

Usage::

    python -m benchmarks.node_attributes [--rounds N] [--size PIXELS] [--instances K]

A floor of K x K instances of smooth spheres (4,800 triangles each, a mesh per row) under a top view, shaded
by a Principled BSDF whose Base Color is a constant ("constant") or the mesh's colour
attribute through a Color Attribute node ("attribute"), rendered in RASTER and HYBRID (its
mirror bounce reads the attribute at BVH and cube-map hits too). The two scenes alternate
round by round (the machine's speed drifts within a run) and each render is bracketed by
``ctx.finish()``; prints the median of each and the ratio. Also times the host's upload of the
attribute scene's first frame (the store laid out) against an edit of one mesh's colours (that
mesh's block written again).
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.gpu import gl_context
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances, ObjectMesh
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph

ROUNDS = 5


def sphere(segments: int = 60, rings: int = 40) -> ObjectMesh:
    """A UV sphere of radius 0.45 with a colour per corner (a function of the corner's
    position)."""
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    points = 0.45 * np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    index = np.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b, c, d = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]
    corners = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    normals = points / np.linalg.norm(points, axis=1, keepdims=True).clip(1e-9)
    colour = np.concatenate([0.5 + points, np.ones((len(points), 1))], 1).astype(np.float32)
    flat = corners.reshape(-1)
    return ObjectMesh(positions=points, corner_vertices=flat, normals=normals, corner_normals=flat,
                      slots=np.zeros(len(corners), np.int32), attributes={"Col": colour[flat]})


def principled(attribute: bool) -> ShaderGraph:
    graph = ShaderGraph()
    colour = (graph.add("VERTEX_COLOR", settings={"layer_name": "Col"}) if attribute
              else graph.add("RGB", Color=(0.6, 0.5, 0.4, 1.0)))
    bsdf = graph.add("BSDF_PRINCIPLED", Roughness=0.3, Metallic=0.5,
                     **{"Base Color": Link(colour, "Color")})
    graph.surface = Link(bsdf, "BSDF")
    return graph


def scene(attribute: bool, k: int) -> SceneData:
    """k rows of k spheres, each row its own mesh (so an edit of one mesh is a k-th of them)."""
    centres = [(i - (k - 1) / 2, j - (k - 1) / 2, 0.0) for j in range(k) for i in range(k)]
    matrices = np.repeat(np.eye(4, dtype=np.float32)[None], k * k, 0)
    matrices[:, :3, 3] = centres
    instances = Instances(meshes=[sphere() for _ in range(k)], mesh=np.repeat(np.arange(k, dtype=np.int32), k),
                          matrices=matrices, slot_materials=[np.int32([0])] * (k * k))
    table = MaterialTable.from_rows([dict()])
    table.node_graphs = [principled(attribute)]
    lights = Lights.from_rows([dict(kind="SUN", direction=(0.3, 0.2, -1.0), color=(3.0, 3.0, 3.0))])
    return SceneData(InstancedGeometry(instances), table, lights, Sky(color=(0.05, 0.05, 0.05)))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--instances", type=int, default=6)
    args = parser.parse_args(argv)
    ctx = gl_context.get_context()
    renderer = Renderer(ctx)
    k = args.instances
    camera = Camera(matrix_world=look_at((0.0, -0.5 * k, 0.8 * k), (0, 0, 0), up=(0, 0, 1)),
                    width=args.size, height=args.size)
    scenes = {"constant": scene(False, k), "attribute": scene(True, k)}
    modes = ("RASTER", "HYBRID")
    times: dict[tuple[str, str], list[float]] = {(m, s): [] for m in modes for s in scenes}
    for name in scenes:  # compile and upload once, outside the timings
        for mode in modes:
            renderer.render(scenes[name], camera, RenderSettings(mode=mode))
    for _ in range(args.rounds):
        for mode in modes:
            for name, data in scenes.items():
                renderer.render(data, camera, RenderSettings(mode=mode))  # its upload, untimed
                ctx.finish()
                start = time.perf_counter()
                renderer.render(data, camera, RenderSettings(mode=mode))
                ctx.finish()
                times[(mode, name)].append((time.perf_counter() - start) * 1e3)
    print(f"{k * k} spheres ({scenes['constant'].geometry.triangle_count // (k * k):,} triangles each), "
          f"{args.size}^2 pixels, {gl_context.renderer_name()}, median of {args.rounds}")
    for mode in modes:
        base = statistics.median(times[(mode, "constant")])
        attr = statistics.median(times[(mode, "attribute")])
        print(f"  {mode:7s} constant {base:8.1f} ms   attribute {attr:8.1f} ms   ratio {attr / base:5.2f}")
    store = renderer.gpu_scene.node_attributes
    gpu = renderer.gpu_scene
    data = scenes["attribute"]
    edits, firsts = [], []
    for _ in range(args.rounds):
        mesh = data.geometry.instances.meshes[0]
        painted = mesh.deformed(mesh.positions, mesh.normals,
                                attributes={"Col": np.random.default_rng(1).random((3 * mesh.triangle_count, 4))})
        data.geometry.instances.meshes[0] = painted
        start = time.perf_counter()
        gpu.upload(data)
        edits.append((time.perf_counter() - start) * 1e3)
        edit_bytes = store.bytes_written
        store._layout = None  # lay the store out again: what a first frame costs
        start = time.perf_counter()
        gpu.upload(data)
        firsts.append((time.perf_counter() - start) * 1e3)
        first_bytes = store.bytes_written
    print(f"  upload: first frame {statistics.median(firsts):.2f} ms ({first_bytes:,} bytes of attributes), "
          f"one mesh's colours edited {statistics.median(edits):.2f} ms ({edit_bytes:,} bytes)")


if __name__ == "__main__":
    main()
