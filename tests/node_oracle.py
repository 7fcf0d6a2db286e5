# SPDX-License-Identifier: GPL-3.0-or-later
"""Two sides of one comparison for shader-node code: Cycles' value of a node graph on a
plane, pixel by pixel, and a GLSL function's value at the same points.

Cycles renders an emission plane that fills an orthographic top view exactly, so the pixel
at column i, row j (row 0 at the bottom) shows the plane's object coordinates
``(-extent + (i + 0.5) * 2 extent / size, same for j, 0)``. One sample with Cycles' smallest
pixel filter puts that sample at the pixel's centre, so no Monte Carlo noise and no filter
blur stand between the two sides: what differs is the node's arithmetic.
"""
from __future__ import annotations

import hashlib
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

PROBE_DIR = Path(tempfile.gettempdir()) / "hybrid_rt_node_probes"


def plane_points(size: int, extent: float) -> np.ndarray:
    """(size, size, 3) object coordinates at the pixel centres, row 0 at the bottom."""
    centres = -extent + (np.arange(size, dtype=np.float64) + 0.5) * (2.0 * extent / size)
    x, y = np.meshgrid(centres, centres)
    return np.stack([x, y, np.zeros_like(x)], axis=-1).astype(np.float32)


def cycles_emission_plane(
    build: Callable[[object, object, object], object],
    out_dir: Path,
    size: int = 64,
    extent: float = 1.0,
) -> np.ndarray:
    """Cycles' rendering of ``build(nodes, links, object_vector)`` (a function that adds nodes
    to an emission material and returns the colour or float output socket to show) on the
    plane, as (size, size, 3) linear float32, row 0 at the bottom.

    The output socket feeds an Emission shader of strength 1 with no other light, so a pixel
    holds the socket's value (a float output shows as grey). The factory scene is reset."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    mesh = bpy.data.meshes.new("plane")
    e = float(extent)
    mesh.from_pydata([(-e, -e, 0.0), (e, -e, 0.0), (e, e, 0.0), (-e, e, 0.0)], [], [(0, 1, 2, 3)])
    plane = bpy.data.objects.new("plane", mesh)
    scene.collection.objects.link(plane)
    material = bpy.data.materials.new("probe")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    coords = nodes.new("ShaderNodeTexCoord")
    shown = build(nodes, links, coords.outputs["Object"])
    links.new(shown, emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    mesh.materials.append(material)

    camera = bpy.data.cameras.new("camera")
    camera.type = "ORTHO"
    camera.ortho_scale = 2.0 * e
    camera.clip_start, camera.clip_end = 0.001 * e, 10.0 * e
    camera_object = bpy.data.objects.new("camera", camera)
    camera_object.location = (0.0, 0.0, e)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world

    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x = render.resolution_y = size
    render.resolution_percentage = 100
    render.film_transparent = False
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "cycles_probe.exr"
    render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    try:
        w, h = image.size
        pixels = np.empty(w * h * 4, np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(h, w, 4)[..., :3].copy()
    finally:
        bpy.data.images.remove(image)


_PROBE_TEMPLATE = """#version 430
layout(local_size_x = 64) in;
{includes}
layout(std430, binding = 0) readonly buffer Points {{ vec4 points[]; }};
layout(std430, binding = 1) writeonly buffer Results {{ vec4 results[]; }};
uniform int u_count;

vec4 probe(vec4 p) {{
{body}
}}

void main() {{
    int i = int(gl_GlobalInvocationID.x);
    if (i >= u_count) return;
    results[i] = probe(points[i]);
}}
"""


def glsl_probe(ctx, includes: list[str], body: str, points: np.ndarray) -> np.ndarray:
    """Run ``body`` (GLSL statements of a ``vec4 probe(vec4 p)`` function that returns a
    value) at each point of ``points`` ((..., 3) or (..., 4) float; a fourth component is
    ``p.w``, 0 if absent) in a compute shader, with ``includes`` (paths under gpu_shaders/,
    e.g. "include/nodes/tex_noise.glsl") included. Returns (..., 4) float32."""
    from hybrid_engine.gpu import shader_loader

    points = np.asarray(points, np.float32)
    shape = points.shape[:-1]
    flat = points.reshape(-1, points.shape[-1])
    padded = np.zeros((len(flat), 4), np.float32)
    padded[:, : flat.shape[1]] = flat
    source = _PROBE_TEMPLATE.format(
        includes="\n".join(f'#include "{name}"' for name in includes), body=body)
    PROBE_DIR.mkdir(parents=True, exist_ok=True)
    path = PROBE_DIR / f"probe_{hashlib.sha1(source.encode()).hexdigest()[:16]}.comp.glsl"
    if not path.is_file():
        path.write_text(source, encoding="utf-8")
    program = shader_loader.compute(ctx, path)
    points_buffer = ctx.buffer(padded.tobytes())
    results = ctx.buffer(reserve=max(len(padded), 1) * 16)
    try:
        points_buffer.bind_to_storage_buffer(0)
        results.bind_to_storage_buffer(1)
        program["u_count"] = len(padded)
        program.run(group_x=max((len(padded) + 63) // 64, 1))
        out = np.frombuffer(results.read(), np.float32).reshape(-1, 4)[: len(padded)]
        return out.reshape(*shape, 4).copy()
    finally:
        points_buffer.release()
        results.release()
