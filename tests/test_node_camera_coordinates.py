# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture Coordinate's Camera and Window outputs (node_program.glsl, the frame's camera from
RasterView.node_camera_uniforms): the point in Cycles' camera space (+Z in front of the
camera) and its place on the screen, 0..1. Held to Cycles through Blender's render path on an
emission plane seen by a turned perspective camera, directly and in a HYBRID mirror, where
Cycles gives the hit's own camera-space and window position."""
from __future__ import annotations

import math

import numpy as np
import pytest

from normal_scenes import black_world, difference, inner, mirror_material, settings_for_one_sample

MEAN_BAR, P99_BAR = 0.01, 0.02
SIZE = 64


def _shown(nodes, links, output: str):
    coords = nodes.new("ShaderNodeTexCoord")
    if output == "Window":
        return coords.outputs["Window"]
    scaled = nodes.new("ShaderNodeVectorMath")  # camera space spans metres: into 0..1
    scaled.operation = "MULTIPLY_ADD"
    links.new(coords.outputs["Camera"], scaled.inputs[0])
    scaled.inputs[1].default_value = (0.25, 0.15, 0.1)
    scaled.inputs[2].default_value = (0.5, 0.5, 0.0)
    return scaled.outputs["Vector"]


def _scene(bpy, output: str, mirrored: bool):
    """An emission plane showing ``output``, seen by a perspective camera turned off its
    axes; ``mirrored``: seen only in a perfect mirror (the camera looks at the mirror)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, math.radians(20.0)))
    material = bpy.data.materials.new("coords")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    out, emission = nodes.new("ShaderNodeOutputMaterial"), nodes.new("ShaderNodeEmission")
    links.new(_shown(nodes, links, output), emission.inputs["Color"])
    links.new(emission.outputs["Emission"], out.inputs["Surface"])
    bpy.context.object.data.materials.append(material)
    camera = bpy.data.cameras.new("camera")
    camera.lens = 35.0
    camera.clip_start = 0.01
    camera_object = bpy.data.objects.new("camera", camera)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    if mirrored:
        # The plane faces a 45-degree mirror above it; the camera looks into the mirror.
        bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 2.5), rotation=(math.radians(-45.0), 0.0, 0.0))
        bpy.context.object.data.materials.append(mirror_material(bpy))
        camera_object.location = (0.2, -4.0, 2.6)
        camera_object.rotation_euler = (math.radians(88.0), math.radians(3.0), math.radians(2.0))
    else:
        camera_object.location = (0.4, -0.6, 3.0)
        camera_object.rotation_euler = (math.radians(12.0), math.radians(-6.0), math.radians(15.0))
    black_world(bpy, scene)
    scene.render.resolution_x, scene.render.resolution_y = SIZE + 16, SIZE
    scene.render.resolution_percentage = 100
    settings_for_one_sample(scene)
    scene.cycles.max_bounces = 1 if mirrored else 0
    scene.hybrid_rt.near_size = 16.0
    return scene


@pytest.mark.parametrize("mirrored", [False, True], ids=["direct", "in_a_mirror"])
@pytest.mark.parametrize("output", ["Camera", "Window"])
def test_camera_and_window_coordinates_match_cycles(addon, tmp_path, output, mirrored):
    import bpy
    from test_engine import render_exr

    scene = _scene(bpy, output, mirrored)
    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., :3]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID" if mirrored else "RASTER"
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[..., :3]
    shown = inner(cycles)[..., :2]
    assert shown.std() > 0.05, f"Cycles shows no {output} coordinates"
    # Cycles emits a negative colour as negative light; Hybrid RT's closure cuts emission at 0.
    mean, p99 = difference(inner(ours), np.maximum(inner(cycles), 0.0))
    assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{output}: mean {mean:.4f}, p99 {p99:.4f} against Cycles"
