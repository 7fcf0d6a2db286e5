# SPDX-License-Identifier: GPL-3.0-or-later
"""Mix Shader lobes (gpu_shaders/include/node_program.glsl, "closure lobes"): a Diffuse and a
Glossy mixed by a Fresnel render as Cycles renders them, a red diffuse under a white gloss,
rather than one lobe of the mean parameters (a washed-out, rough red). Against Cycles through
Blender's render path: an emission-free sphere under a sun and a grey World."""
from __future__ import annotations

import math

import numpy as np
import pytest

SIZE = 64
RED = (0.6, 0.04, 0.03)


def _lacquer(bpy):
    """Diffuse (red) and a sharp white Glossy mixed by a Fresnel of IOR 1.5."""
    material = bpy.data.materials.new("lacquer")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*RED, 1.0)
    glossy = nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.inputs["Roughness"].default_value = 0.1
    fresnel = nodes.new("ShaderNodeFresnel")
    fresnel.inputs["IOR"].default_value = 1.5
    mix = nodes.new("ShaderNodeMixShader")
    links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
    links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    links.new(glossy.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], nodes["Material Output"].inputs["Surface"])
    return material


def _sphere_scene(bpy):
    """A smooth lacquered sphere of radius 1 at the origin, a sun from over the camera's
    shoulder, a grey World, a camera looking at the sphere from -Y."""
    from mathutils import Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(_lacquer(bpy))
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = math.radians(2.0)
    sun_object = bpy.data.objects.new("sun", sun)
    sun_object.rotation_mode = "QUATERNION"
    sun_object.rotation_quaternion = Vector((0, 0, -1)).rotation_difference(Vector((-0.3, 1.0, -0.5)).normalized())
    scene.collection.objects.link(sun_object)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.lens = 50.0
    camera.location = (0.0, -5.0, 0.0)
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new("grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.32, 0.36, 1.0)
    scene.world = world
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.film_transparent = True  # the sphere's mask: Cycles' alpha
    scene.cycles.device = "CPU"
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.hybrid_rt.render_samples = 8
    return scene


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """(Hybrid RT, Cycles) renders of the sphere, and the sphere's pixel mask."""
    import bpy

    from conftest import load_addon
    from test_engine import render_exr

    folder = tmp_path_factory.mktemp("lobes")
    bpy.ops.wm.read_factory_settings(use_empty=False)
    module = load_addon()
    module.register()
    try:
        scene = _sphere_scene(bpy)
        scene.render.engine = "CYCLES"
        scene.cycles.max_bounces = 4
        cycles = render_exr(bpy, scene, folder / "cycles.exr")
        scene.render.engine = "HYBRID_RT"
        scene.hybrid_rt.mode = "HYBRID"
        ours = render_exr(bpy, scene, folder / "ours.exr")
    finally:
        module.unregister()
    return ours[..., :3], cycles[..., :3], cycles[..., 3] > 0.99


def _luminance(pixels: np.ndarray) -> np.ndarray:
    return pixels @ np.array([0.2126, 0.7152, 0.0722])


def test_a_fresnel_mix_of_diffuse_and_glossy_keeps_the_diffuse_red_as_cycles_does(renders):
    """The diffuse layer's colour is the Diffuse BSDF's, not the mean with the white gloss:
    the sphere's red over green and blue is Cycles' (the mean of the two lobes washes it
    out by a third)."""
    ours, cycles, sphere = renders
    assert sphere.sum() > 500

    def redness(image: np.ndarray) -> float:
        px = image[sphere]
        return float(np.median(px[:, 0] / (px[:, 1] + px[:, 2] + 1e-6)))

    assert redness(ours) == pytest.approx(redness(cycles), rel=0.1)
    assert np.abs(ours[sphere] - cycles[sphere]).mean() <= 0.03


def test_the_gloss_keeps_its_own_roughness_and_shows_the_suns_highlight(renders):
    """The Glossy lobe keeps its roughness (0.1), so the sun makes a sharp highlight on the
    sphere as in Cycles; a lobe of the mean roughness (the Diffuse's 1 and the gloss's,
    weighted by the Fresnel) spreads it into nothing."""
    ours, cycles, sphere = renders
    assert _luminance(cycles[sphere]).max() > 2.0
    assert _luminance(ours[sphere]).max() > 2.0
