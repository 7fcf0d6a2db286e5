# SPDX-License-Identifier: GPL-3.0-or-later
"""World node graphs (hybrid_engine/passes/lighting/world_bake.py): the Background graph
baked per direction into the environment that escaping rays, the irradiance and the
prefiltered levels read; re-baked only when the World's values change. Against Cycles
through Blender's render path at the end."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.scene.camera import look_at
from hybrid_engine import Camera
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from test_textures import textured_quad

SMALL = dict(near_size=4.0)


def background(color=(0.2, 0.4, 0.6, 1.0), strength: float = 2.0) -> ShaderGraph:
    graph = ShaderGraph()
    node = graph.add("BACKGROUND", Color=color, Strength=strength)
    graph.surface = Link(node, "Background")
    return graph


def sky_scene(sky: Sky) -> SceneData:
    """A white diffuse plane at z = 0 under ``sky``, no lamps."""
    tris, _ = textured_quad((-50, -50, 0), (100, 0, 0), (0, 100, 0), (0.0, 0.0), (1.0, 1.0))
    geo = Geometry.from_objects([(tris, None, 0)])
    table = MaterialTable.from_rows([dict(base_color=(1.0, 1.0, 1.0), roughness=1.0, specular=0.0)])
    return SceneData(geo, table, Lights.from_rows([]), sky)


def horizon_camera(size: int = 32) -> Camera:
    """From above the plane, looking at the horizon and the sky above it."""
    return Camera(matrix_world=look_at((0, 0, 1), (0, 10, 3), up=(0, 0, 1)), width=size, height=size,
                  clip_start=0.1, clip_end=1000.0)


def test_a_background_graph_is_the_sky_the_camera_sees_and_lights_the_plane(renderer):
    """Colour x Strength of the Background node, wherever a ray escapes; a white diffuse
    plane under a uniform sky reflects the sky's radiance."""
    image = renderer.render(sky_scene(Sky(graph=background())), horizon_camera(),
                            RenderSettings(mode="HYBRID", **SMALL)).image[..., :3]
    np.testing.assert_allclose(image[-1, 16], (0.4, 0.8, 1.2), rtol=0.01)  # the sky, top row
    np.testing.assert_allclose(image[2, 16], (0.4, 0.8, 1.2), rtol=0.03)   # the plane, bottom row
    baked_sh = renderer.resources.sky.read_sh()
    renderer.render(sky_scene(Sky(color=(0.4, 0.8, 1.2))), horizon_camera(8), RenderSettings(mode="RASTER", **SMALL))
    np.testing.assert_allclose(baked_sh, renderer.resources.sky.read_sh(), rtol=0.01, atol=1e-4)  # the irradiance


def test_the_environment_is_baked_when_a_world_value_changes_and_only_then(renderer):
    graph = background()
    scene = sky_scene(Sky(graph=graph))
    settings = RenderSettings(mode="RASTER", **SMALL)
    renderer.render(scene, horizon_camera(8), settings)
    bake = renderer.resources.sky.world_bake
    first = bake.bakes
    renderer.render(scene, horizon_camera(8), settings)
    renderer.render(sky_scene(Sky(graph=background())), horizon_camera(8), settings)  # equal values, new objects
    assert bake.bakes == first
    graph.nodes[0].inputs["Strength"] = 3.0
    image = renderer.render(scene, horizon_camera(8), settings).image
    assert bake.bakes == first + 1
    np.testing.assert_allclose(image[-1, 4, :3], (0.6, 1.2, 1.8), rtol=0.01)
    renderer.render(scene, horizon_camera(8), settings)
    assert bake.bakes == first + 1



# -- against Cycles, through Blender's render path ------------------------------------------
def sky_function(direction: np.ndarray) -> np.ndarray:
    """A smooth, coloured environment by direction (what the test images hold)."""
    x, y, z = direction[..., 0], direction[..., 1], direction[..., 2]
    return np.stack([0.6 + 0.4 * x, 0.5 + 0.3 * z, 0.4 + 0.3 * y], -1).astype(np.float32)


def environment_image(projection: str, size: int = 64) -> np.ndarray:
    """(H, W, 4) pixels of sky_function in ``projection`` (row 0 at the bottom)."""
    if projection == "EQUIRECTANGULAR":
        u = (np.arange(2 * size) + 0.5) / (2 * size)
        v = (np.arange(size) + 0.5) / size
        phi, lat = (0.5 - u)[None, :] * 2 * np.pi, (v - 0.5)[:, None] * np.pi
        d = np.stack(np.broadcast_arrays(np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)), -1)
    else:  # a mirror ball seen along +Y: the normal at (u, v), the direction reflected there
        u = (np.arange(size) + 0.5) / size * 2 - 1
        nx, nz = np.meshgrid(u, u)
        ny = -np.sqrt(np.clip(1 - nx * nx - nz * nz, 0.0, 1.0))
        n = np.stack([nx, ny, nz], -1)
        view = np.array([0.0, 1.0, 0.0])
        d = view - 2 * (n @ view)[..., None] * n
    rgb = sky_function(d)
    return np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), np.float32)], -1)


def _world_scene(bpy, view: str, size: int = 32):
    """A factory-empty scene: ``view`` "SKY" is a perspective camera at the horizon looking
    towards -Y and 17 degrees up; "PLANE" an orthographic camera above a white diffuse plane."""
    import math

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    scene.world = world
    camera = bpy.data.cameras.new("camera")
    camera_object = bpy.data.objects.new("camera", camera)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    if view == "SKY":
        camera.lens = 18.0
        camera_object.location = (0.0, 0.0, 1.0)
        camera_object.rotation_euler = (math.radians(107.0), 0.0, math.pi)
    else:
        camera.type = "ORTHO"
        camera.ortho_scale = 2.0
        camera_object.location = (0.0, 0.0, 5.0)
        material = bpy.data.materials.new("white")
        material.use_nodes = True
        bsdf = material.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        bsdf.inputs["Roughness"].default_value = 1.0
        bsdf.inputs["Specular IOR Level"].default_value = 0.0
        bpy.ops.mesh.primitive_plane_add(size=400.0)
        bpy.context.object.data.materials.append(material)
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 1
    scene.hybrid_rt.render_samples = 4
    return scene, world.node_tree


def _both(bpy, scene, tmp_path) -> tuple[np.ndarray, np.ndarray]:
    from test_engine import render_exr

    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., :3]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[..., :3]
    return ours, cycles


def _environment_world(bpy, tree, projection: str) -> None:
    """Background <- Environment Texture (``projection``) <- Texture Coordinate Generated:
    a World the plain reader cannot take, only the graph."""
    nodes, links = tree.nodes, tree.links
    image = bpy.data.images.new("sky", *environment_image(projection).shape[1::-1], alpha=True, float_buffer=True)
    image.pixels.foreach_set(environment_image(projection).ravel())
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    texture.projection = projection
    coords = nodes.new("ShaderNodeTexCoord")
    links.new(coords.outputs["Generated"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], nodes["Background"].inputs["Color"])
    nodes["Background"].inputs["Strength"].default_value = 1.5


@pytest.mark.parametrize("projection", ["EQUIRECTANGULAR", "MIRROR_BALL"])
def test_an_environment_texture_world_matches_cycles_seen_and_as_light(addon, tmp_path, projection):
    import bpy

    scene, tree = _world_scene(bpy, "SKY")
    _environment_world(bpy, tree, projection)
    ours, cycles = _both(bpy, scene, tmp_path)
    assert np.abs(ours - cycles).mean() <= 0.01 * cycles.mean(), (ours.mean((0, 1)), cycles.mean((0, 1)))
    scene, tree = _world_scene(bpy, "PLANE", 16)
    _environment_world(bpy, tree, projection)
    ours, cycles = _both(bpy, scene, tmp_path)
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)


def _sky_world(tree, sky_type: str = "PREETHAM") -> None:
    nodes, links = tree.nodes, tree.links
    sky = nodes.new("ShaderNodeTexSky")
    sky.sky_type = sky_type
    sky.sun_direction = (0.4, -0.5, 0.5)
    sky.turbidity = 3.0
    links.new(sky.outputs["Color"], nodes["Background"].inputs["Color"])


def test_a_preetham_sky_texture_world_is_within_5_percent_of_cycles(addon, tmp_path):
    """The sky seen at the horizon and its light on a white diffuse plane (the issue's bar)."""
    import bpy

    scene, tree = _world_scene(bpy, "SKY")
    _sky_world(tree)
    ours, cycles = _both(bpy, scene, tmp_path)
    print("sky", ours.mean((0, 1)), cycles.mean((0, 1)), np.abs(ours - cycles).mean() / cycles.mean())
    assert np.abs(ours - cycles).mean() <= 0.05 * cycles.mean()
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)
    scene, tree = _world_scene(bpy, "PLANE", 16)
    _sky_world(tree)
    scene.cycles.samples = 256
    ours, cycles = _both(bpy, scene, tmp_path)
    print("plane", ours.mean((0, 1)), cycles.mean((0, 1)))
    np.testing.assert_allclose(ours.mean((0, 1)), cycles.mean((0, 1)), rtol=0.05)


def test_an_unsupported_world_node_is_named_once_and_the_rest_renders(addon):
    """A Blackbody (not evaluated) feeding a Mix Shader's second Background: named once,
    however often the World is read; the first Background still lights the sky."""
    import bpy

    messages = addon.blender_adapter.messages
    extract_sky = addon.blender_adapter.export.world.extract_sky
    _scene, tree = _world_scene(bpy, "SKY", 8)
    nodes, links = tree.nodes, tree.links
    other = nodes.new("ShaderNodeBackground")
    blackbody = nodes.new("ShaderNodeBlackbody")
    links.new(blackbody.outputs[0], other.inputs["Color"])
    mix = nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.0
    links.new(nodes["Background"].outputs[0], mix.inputs[1])
    links.new(other.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], nodes["World Output"].inputs["Surface"])
    nodes["Background"].inputs["Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    with messages.collecting() as told:
        skies = [extract_sky(bpy.context.scene.world) for _ in range(2)]
    assert [m for m in told if "Blackbody" in m] == ["world: Blackbody nodes are not supported; their outputs take "
                                                     "their default values"]
    assert skies[0].graph is not None and [n.kind for n in skies[0].graph.nodes].count("BACKGROUND") == 2
