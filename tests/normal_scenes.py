# SPDX-License-Identifier: GPL-3.0-or-later
"""Scenes for the shading-normal nodes (Bump, Normal Map) and the camera's coordinates,
rendered through Blender's render path by Hybrid RT and Cycles.

A tile's normal is made visible in two ways: lit by a sun on a Diffuse BSDF (what an artist
sees), or as an emission colour ``normal * 0.5 + 0.5`` (the normal itself, with no shading
model between the engines). The mirror views put a 45-degree mirror above the tile and look
into it horizontally, so the reflected rays come down onto the tile's front face along the
same vertical lines as a top view: the two images agree pixel for pixel after a vertical
flip, and every pixel of the mirror view is shaded at a ray hit (a BVH hit with a near cube
that holds the scene)."""
from __future__ import annotations

import math

import numpy as np

TILE = 64  # pixels per side of a tile's view
BORDER = 3  # pixels of the view's edge left out (a pixel there may see past the tile)


def settings_for_one_sample(scene) -> None:
    """One sample at each pixel's centre in both engines, no bounce in Cycles, no film look."""
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    scene.hybrid_rt.render_samples = 1


def black_world(bpy, scene) -> None:
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world


def shown_vector(nodes, links, vector):
    """``vector * 0.5 + 0.5``: a unit normal as a colour inside 0..1."""
    node = nodes.new("ShaderNodeVectorMath")
    node.operation = "MULTIPLY_ADD"
    links.new(vector, node.inputs[0])
    node.inputs[1].default_value = (0.5, 0.5, 0.5)
    node.inputs[2].default_value = (0.5, 0.5, 0.5)
    return node.outputs["Vector"]


def height(nodes, kind: str):
    """A Height for a Bump: (its socket, a Distance that bends the normal visibly)."""
    if kind == "noise":
        texture = nodes.new("ShaderNodeTexNoise")
        texture.inputs["Scale"].default_value = 4.0
        texture.inputs["Detail"].default_value = 2.0
        return texture.outputs["Fac"], 0.05
    if kind == "wave":
        texture = nodes.new("ShaderNodeTexWave")
        texture.inputs["Scale"].default_value = 1.5
        texture.bands_direction = "DIAGONAL"
        return texture.outputs["Fac"], 0.03
    texture = nodes.new("ShaderNodeTexChecker")
    texture.inputs["Scale"].default_value = 3.0
    return texture.outputs["Fac"], 0.05


def bump_chain(nodes, links, kinds, strength: float = 1.0, invert: bool = False, filter_width: float = 0.1):
    """A Bump per height kind, each one's Normal fed by the previous one's (a chain)."""
    normal = None
    for kind in kinds:
        socket, distance = height(nodes, kind)
        bump = nodes.new("ShaderNodeBump")
        bump.inputs["Distance"].default_value = distance
        bump.inputs["Strength"].default_value = strength
        bump.inputs["Filter Width"].default_value = filter_width
        bump.invert = invert
        links.new(socket, bump.inputs["Height"])
        if normal is not None:
            links.new(normal, bump.inputs["Normal"])
        normal = bump.outputs["Normal"]
    return normal


def normal_map(nodes, links, space: str):
    """A Normal Map in ``space`` whose colour varies over the tile (a distorted Wave mixing two
    tilted normals)."""
    wave = nodes.new("ShaderNodeTexWave")
    wave.inputs["Scale"].default_value = 1.0
    wave.inputs["Distortion"].default_value = 4.0
    wave.bands_direction = "DIAGONAL"
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    links.new(wave.outputs["Fac"], mix.inputs["Factor"])
    mix.inputs["A"].default_value = (0.2, 0.7, 0.8, 1.0)
    mix.inputs["B"].default_value = (0.8, 0.35, 0.7, 1.0)
    node = nodes.new("ShaderNodeNormalMap")
    node.space = space
    links.new(mix.outputs["Result"], node.inputs["Color"])
    return node.outputs["Normal"]


def add_tile(bpy, scene, name: str, build, location=(0.0, 0.0, 0.0), lit: bool = False, uv_turn: float = 0.0):
    """A unit plane turned 30 degrees about Z, its UVs turned by ``uv_turn`` radians about their
    centre (a tangent that is not the object's X); its material shows ``build(nodes, links)``
    (a normal) as an emission colour, or, ``lit``, as a Diffuse BSDF's Normal."""
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=location, rotation=(0.0, 0.0, math.radians(30.0)))
    plane = bpy.context.object
    plane.name = name
    c, s = math.cos(uv_turn), math.sin(uv_turn)
    for loop in plane.data.uv_layers.active.data:
        u, v = loop.uv[0] - 0.5, loop.uv[1] - 0.5
        loop.uv = (0.5 + c * u - s * v, 0.5 + s * u + c * v)
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    if lit:
        shader = nodes.new("ShaderNodeBsdfDiffuse")
        shader.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        links.new(build(nodes, links), shader.inputs["Normal"])
        links.new(shader.outputs["BSDF"], output.inputs["Surface"])
    else:
        shader = nodes.new("ShaderNodeEmission")
        links.new(shown_vector(nodes, links, build(nodes, links)), shader.inputs["Color"])
        links.new(shader.outputs["Emission"], output.inputs["Surface"])
    plane.data.materials.append(material)
    return plane


def add_sun(bpy, scene) -> None:
    """A sharp sun from the side (50 degrees from the zenith), so that bent normals shade."""
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_object = bpy.data.objects.new("sun", sun)
    sun_object.rotation_euler = (math.radians(50.0), 0.0, math.radians(30.0))
    scene.collection.objects.link(sun_object)


def add_camera(bpy, scene, ortho_scale: float):
    camera = bpy.data.cameras.new("camera")
    camera.type = "ORTHO"
    camera.ortho_scale = ortho_scale
    camera.clip_start = 0.01
    camera_object = bpy.data.objects.new("camera", camera)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    return camera_object


def mirror_material(bpy):
    """A new perfect white mirror: a Principled BSDF, metallic, roughness 0."""
    mirror = bpy.data.materials.new("mirror")
    mirror.use_nodes = True
    bsdf = mirror.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.0
    return mirror


def mirror_scene(bpy, build, lit: bool = False, uv_turn: float = 0.0):
    """One tile under a 45-degree mirror (module header); returns the scene and its camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    add_tile(bpy, scene, "tile", build, lit=lit, uv_turn=uv_turn)
    if lit:
        add_sun(bpy, scene)
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0.0, 0.0, 2.0), rotation=(math.radians(-45.0), 0.0, 0.0))
    bpy.context.object.data.materials.append(mirror_material(bpy))
    camera = add_camera(bpy, scene, 0.7)
    black_world(bpy, scene)
    scene.render.resolution_x = scene.render.resolution_y = TILE
    scene.render.resolution_percentage = 100
    settings_for_one_sample(scene)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.near_size = 12.0
    return scene, camera


def primary_and_mirrored(bpy, scene, camera, tmp_path) -> tuple[np.ndarray, np.ndarray]:
    """The tile from above (below the mirror), and seen in the mirror, flipped to match."""
    from test_engine import render_exr

    camera.location, camera.rotation_euler = (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)
    primary = render_exr(bpy, scene, tmp_path / "primary.exr")[..., :3]
    camera.location, camera.rotation_euler = (0.0, -4.0, 2.0), (math.radians(90.0), 0.0, 0.0)
    mirrored = render_exr(bpy, scene, tmp_path / "mirrored.exr")[..., :3]
    return primary, mirrored[::-1]


def inner(image: np.ndarray) -> np.ndarray:
    return image[BORDER:-BORDER, BORDER:-BORDER]


def difference(ours: np.ndarray, theirs: np.ndarray) -> tuple[float, float]:
    """Mean and 99th percentile of the absolute difference."""
    d = np.abs(ours.astype(np.float64) - theirs.astype(np.float64))
    return float(d.mean()), float(np.percentile(d, 99))


def row_scene(bpy, builds: dict, lit: bool = False, uv_turn: float = 0.0):
    """One tile per entry of ``builds`` (name: build) in a row along X, seen from above by an
    orthographic camera whose view each tile fills TILE pixels of; a sun when ``lit``."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    count = len(builds)
    for k, (name, build) in enumerate(builds.items()):
        add_tile(bpy, scene, name, build, location=(k - (count - 1) / 2, 0.0, 0.0), lit=lit, uv_turn=uv_turn)
    if lit:
        add_sun(bpy, scene)
    camera = add_camera(bpy, scene, float(count))
    camera.location = (0.0, 0.0, 3.0)
    black_world(bpy, scene)
    scene.render.resolution_x, scene.render.resolution_y = count * TILE, TILE
    scene.render.resolution_percentage = 100
    settings_for_one_sample(scene)
    return scene, camera


def tile_pixels(image: np.ndarray, k: int) -> np.ndarray:
    """Tile k's pixels of a row scene's view, less a margin: the tiles are turned, so only a
    central square lies inside each (a unit plane turned 30 degrees covers its centre's
    square of side 0.7 at least)."""
    margin = int(TILE * 0.16)
    return image[margin:TILE - margin, k * TILE + margin:(k + 1) * TILE - margin]


def render_both(bpy, scene, tmp_path, mode: str = "RASTER") -> tuple[np.ndarray, np.ndarray]:
    """(Hybrid RT's, Cycles') render of ``scene``."""
    from test_engine import render_exr

    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., :3]
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = mode
    ours = render_exr(bpy, scene, tmp_path / "ours.exr")[..., :3]
    return ours, cycles
