# SPDX-License-Identifier: GPL-3.0-or-later
"""Area lamps keep their shape (gpu_shaders/include/lighting.glsl, area_shape): a rectangle
reflects as a rectangle in a mirror, as Cycles shows it, and casts a penumbra stretched along
its long side, as the exact integral over the lamp gives it. Rendered through Blender's render
path; Cycles in the same process and a numpy integral are the oracles."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_engine import render_exr

LAMP_ANGLE = 30.0  # degrees about Z: the lamp's long side is not along an image axis


def _scene(bpy, addon_module, shape: str, size_y: float):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_percentage = 100
    lamp = bpy.data.lights.new("lamp", "AREA")
    lamp.shape, lamp.size, lamp.size_y, lamp.energy = shape, 2.0, size_y, 300.0
    lamp_object = bpy.data.objects.new("lamp", lamp)
    lamp_object.location = (0.0, 0.0, 2.0)
    lamp_object.rotation_euler = (0.0, 0.0, math.radians(LAMP_ANGLE))
    scene.collection.objects.link(lamp_object)
    return scene


def _square(bpy, scene, name, half, z, material):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def _principled(bpy, name, metallic, roughness, specular):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = specular
    return material


def _principal_axes(weights: np.ndarray) -> tuple[float, float, float]:
    """(standard deviation along the long axis, along the short axis, long axis angle in
    degrees) of an image's weights, in pixels."""
    ys, xs = np.mgrid[: weights.shape[0], : weights.shape[1]].astype(np.float64)
    total = weights.sum()
    mx, my = (weights * xs).sum() / total, (weights * ys).sum() / total
    cov = np.array([[(weights * (xs - mx) ** 2).sum(), (weights * (xs - mx) * (ys - my)).sum()],
                    [(weights * (xs - mx) * (ys - my)).sum(), (weights * (ys - my) ** 2).sum()]]) / total
    values, vectors = np.linalg.eigh(cov)
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1])) % 180.0
    return math.sqrt(values[1]), math.sqrt(values[0]), angle


@pytest.mark.parametrize("shape", ["RECTANGLE", "ELLIPSE"])
def test_a_mirror_shows_a_long_area_lamp_as_long_as_cycles_does(addon, tmp_path, shape):
    import bpy
    import mathutils

    scene = _scene(bpy, addon, shape, 0.4)
    _square(bpy, scene, "mirror", 20.0, 0.0, _principled(bpy, "mirror", 1.0, 0.0, 0.5))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.0, -4.0, 2.0)  # sees the lamp's reflection, not the lamp
    camera.rotation_euler = (mathutils.Vector((0.0, 0.0, -2.0)) - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 96, 64
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 32, "CPU"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")
    scene.render.engine = "HYBRID_RT"
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")

    def highlight(image):
        luminance = image[..., :3].mean(axis=-1)
        return (luminance > 0.5 * np.percentile(luminance, 99.5)).astype(np.float64)

    long_c, short_c, angle_c = _principal_axes(highlight(cycles))
    long_o, short_o, angle_o = _principal_axes(highlight(ours))
    assert long_c / short_c > 4.0  # the oracle shows a long highlight
    assert abs(long_o / short_o - long_c / short_c) < 0.15 * long_c / short_c, (long_o / short_o, long_c / short_c)
    assert abs(angle_o - angle_c) < 5.0, (angle_o, angle_c)


def _exact_shadow(size: int, extent: float, half_u: float, half_v: float, blocker_half: float,
                  blocker_z: float, lamp_z: float) -> np.ndarray:
    """The fraction of a rectangular lamp's light (cosine at the floor and at the lamp, over
    the squared distance) that a square blocker takes from each floor pixel, integrated over
    a grid of lamp points: the exact answer a shadow map approximates."""
    centres = -extent + (np.arange(size) + 0.5) * (2.0 * extent / size)
    x, y = np.meshgrid(centres, centres)
    angle = math.radians(LAMP_ANGLE)
    u = np.array([math.cos(angle), math.sin(angle), 0.0])
    v = np.array([-math.sin(angle), math.cos(angle), 0.0])
    s = (np.arange(40) + 0.5) / 40 * 2.0 - 1.0
    t = (np.arange(8) + 0.5) / 8 * 2.0 - 1.0
    lamp = (np.array([0.0, 0.0, lamp_z]) + half_u * s[:, None, None] * u + half_v * t[None, :, None] * v).reshape(-1, 3)
    floor = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 1, 3)
    to_lamp = lamp[None] - floor
    weight = to_lamp[..., 2] ** 2 / (to_lamp ** 2).sum(axis=-1) ** 2
    crossing = floor + to_lamp * (blocker_z / to_lamp[..., 2])[..., None]
    blocked = (np.abs(crossing[..., 0]) <= blocker_half) & (np.abs(crossing[..., 1]) <= blocker_half)
    return ((weight * blocked).sum(axis=-1) / weight.sum(axis=-1)).reshape(size, size)


def test_a_long_area_lamp_casts_a_penumbra_stretched_along_its_long_side(addon, tmp_path):
    import bpy

    size, extent = 96, 1.5
    scene = _scene(bpy, addon, "RECTANGLE", 0.2)
    white = _principled(bpy, "white", 0.0, 1.0, 0.0)
    _square(bpy, scene, "floor", 10.0, 0.0, white)
    blocker = _square(bpy, scene, "blocker", 0.1, 0.7, white)
    camera_data = bpy.data.cameras.new("camera")
    camera_data.type, camera_data.ortho_scale = "ORTHO", 2.0 * extent
    camera = bpy.data.objects.new("camera", camera_data)
    camera.location = (0.0, 0.0, 0.5)  # under the blocker: the floor alone
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.render_samples = 16
    shadowed = render_exr(bpy, scene, tmp_path / "shadowed.exr")[..., :3].mean(axis=-1)
    blocker.hide_render = True
    free = render_exr(bpy, scene, tmp_path / "free.exr")[..., :3].mean(axis=-1)
    ours = np.clip(1.0 - shadowed / np.maximum(free, 1e-6), 0.0, 1.0)
    exact = _exact_shadow(size, extent, 1.0, 0.1, 0.1, 0.7, 2.0)

    long_e, short_e, angle_e = _principal_axes(exact)
    long_o, short_o, angle_o = _principal_axes(ours)
    assert long_e / short_e > 2.5  # the oracle's penumbra is long
    assert abs(long_o / short_o - long_e / short_e) < 0.35 * long_e / short_e, (long_o / short_o, long_e / short_e)
    assert abs(angle_o - angle_e) < 6.0, (angle_o, angle_e)
    assert abs(ours.sum() - exact.sum()) < 0.15 * exact.sum(), (ours.sum(), exact.sum())
