# SPDX-License-Identifier: GPL-3.0-or-later
"""Node programs at cube-map hits (trace_ray.glsl, include/cube_tangent.glsl): a
tangent-space Normal Map and a Bump whose Height reads the UV bend the normal where a mirror's
rays meet a ceiling beyond the near cube (HYBRID: a cube hit) as where they meet it in the BVH
(FULL_BVH) and as the camera sees it directly: the faces keep each texel's UV directions, and
the hit reads the UV where the ray meets the texel's plane. Each graph shows its normal as an
emission colour (normal * 0.5 + 0.5), so the images compare the normal itself."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.data import Lights
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from normal_scenes import black_world, mirror_material, settings_for_one_sample
from test_node_program_render import plane_scene
from test_textures import textured_quad, top_down_camera

CEILING_Z = 6.0
SIZE = 48
UV_TURN = math.radians(60.0)  # the UVs turned on the ceiling: its tangent is not an axis
MEAN_BAR, P99_BAR = 1e-3, 3e-3
BORDER = 3


def shown_normal(graph: ShaderGraph, normal: Link) -> ShaderGraph:
    """Emission of ``normal * 0.5 + 0.5``: the normal as a colour."""
    shown = graph.add("VECT_MATH", settings={"operation": "MULTIPLY_ADD"}, Vector=normal,
                      Vector_001=(0.5, 0.5, 0.5), Vector_002=(0.5, 0.5, 0.5))
    graph.surface = Link(graph.add("EMISSION", Color=Link(shown, "Vector"), Strength=1.0), "Emission")
    return graph


def tangent_normal_map(show=shown_normal) -> ShaderGraph:
    """A tangent-space Normal Map whose colour varies over the UV (a distorted Wave mixing two
    tilted normals), shown by ``show``."""
    graph = ShaderGraph()
    uv = Link(graph.add("TEX_COORD"), "UV")
    wave = graph.add("TEX_WAVE", settings={"bands_direction": "DIAGONAL"}, Vector=uv, Scale=1.0, Distortion=4.0)
    mix = graph.add("MIX", settings={"data_type": "RGBA"}, Factor_Float=Link(wave, "Fac"),
                    A_Color=(0.2, 0.7, 0.8, 1.0), B_Color=(0.8, 0.35, 0.7, 1.0))
    normal_map = graph.add("NORMAL_MAP", settings={"space": "TANGENT"}, Color=Link(mix, "Result_Color"))
    return show(graph, Link(normal_map, "Normal"))


def uv_bump(show=shown_normal) -> ShaderGraph:
    """A Bump whose Height is a Noise of the UV, shown by ``show``."""
    graph = ShaderGraph()
    uv = Link(graph.add("TEX_COORD"), "UV")
    noise = graph.add("TEX_NOISE", Vector=uv, Scale=6.0, Detail=2.0)
    bump = graph.add("BUMP", Distance=0.3, Height=Link(noise, "Fac"))
    return show(graph, Link(bump, "Normal"))


GRAPHS = {"normal map": tangent_normal_map, "bump": uv_bump}


def lit_normal(graph: ShaderGraph, normal: Link) -> ShaderGraph:
    """A white Diffuse BSDF with ``normal``: under SUNS_BELOW each colour channel is the
    normal's cosine to one sun, so the light it reflects shows the normal."""
    graph.surface = Link(graph.add("BSDF_DIFFUSE", Color=(1.0, 1.0, 1.0, 1.0), Normal=normal), "BSDF")
    return graph


# Three suns from below, red, green and blue, each towards another side of the ceiling's
# normal (travelling up to it), casting no shadow (the mirror floor would hide the ceiling).
SUNS_BELOW = [dict(kind="SUN", direction=direction, color=color, cast_shadow=False)
              for direction, color in (((-1.0, 0.0, 1.2), (2.0, 0.0, 0.0)), ((0.0, -1.0, 1.2), (0.0, 2.0, 0.0)),
                                       ((0.0, 0.0, 1.0), (0.0, 0.0, 2.0)))]


def ceiling(back: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A 2 m square at CEILING_Z facing down (``back``: the same square and UVs wound the other
    way, facing up: the camera and the mirror see its back), its UVs turned by UV_TURN about
    their centre."""
    tris, uvs = textured_quad((-1, -1, CEILING_Z), (0, 2, 0), (2, 0, 0), (0.0, 0.0), (1.0, 1.0))
    c, s = math.cos(UV_TURN), math.sin(UV_TURN)
    centred = uvs - 0.5
    turned = (np.stack([c * centred[..., 0] - s * centred[..., 1], s * centred[..., 0] + c * centred[..., 1]], -1)
              + 0.5).astype(np.float32)
    if back:
        return tris[:, [0, 2, 1]].copy(), turned[:, [0, 2, 1]].copy()
    return tris, turned


def mirrored(renderer, graph: ShaderGraph, mode: str, lit_cube: bool = False, back: bool = False,
             lamps: tuple = ()) -> np.ndarray:
    """The ceiling in a mirror floor at z = 0, seen from above at z = 3: with a near cube of
    half-size 1 the ceiling lies in the cube map in HYBRID (``lit_cube``: its hits read the
    lit cube map's texels), lit by ``lamps`` (rows)."""
    floor, floor_uvs = textured_quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), (0.0, 0.0), (1.0, 1.0))
    tris, uvs = ceiling(back)
    rows = [dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0), dict()]
    scene = plane_scene([(floor, floor_uvs, 0), (tris, uvs, 1)], [None, graph], rows)
    scene = dataclasses.replace(scene, lights=Lights.from_rows(list(lamps)))
    settings = RenderSettings(mode=mode, near_size=1.0, cube_far=20.0, cube_resolution=256, max_depth=1,
                              lit_cube=lit_cube)
    return renderer.render(scene, top_down_camera(size=SIZE, scale=1.6), settings).image[..., :3]


def direct(renderer, graph: ShaderGraph, back: bool = False) -> np.ndarray:
    """The ceiling seen from below by the mirror image of the camera above, flipped to the
    mirror's view (a camera looking up has x to its left)."""
    tris, uvs = ceiling(back)
    camera = Camera(matrix_world=look_at((0, 0, -3), (0, 0, 0), up=(0, 1, 0)), width=SIZE, height=SIZE,
                    projection="ORTHO", ortho_scale=1.6, clip_start=0.1, clip_end=20.0)
    image = renderer.render(plane_scene([(tris, uvs, 0)], [graph]), camera, RenderSettings(mode="RASTER")).image
    return image[:, ::-1, :3]


def inner(image: np.ndarray) -> np.ndarray:
    return image[BORDER:-BORDER, BORDER:-BORDER].astype(np.float64)


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    d = np.abs(inner(a) - inner(b))
    return float(d.mean()), float(np.percentile(d, 99))


@pytest.mark.parametrize("trace_variant", ["cpu", "gpu"], indirect=True)
@pytest.mark.parametrize("graph", sorted(GRAPHS))
def test_a_uv_bent_normal_at_a_cube_hit_matches_the_bvh_hit_and_the_direct_view(renderer, trace_variant, graph):
    """The megakernel ("cpu") and the waves ("gpu", whose hit records carry the frame)."""
    seen = direct(renderer, GRAPHS[graph]())
    assert inner(seen).std(axis=(0, 1)).max() > 0.02, "the graph bends no normal"
    cube = mirrored(renderer, GRAPHS[graph](), "HYBRID")
    bvh = mirrored(renderer, GRAPHS[graph](), "FULL_BVH")
    for name, image in (("cube map", cube), ("BVH", bvh)):
        mean, p99 = difference(image, seen)
        assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{graph}, {name} against the direct view: {mean:.4f}, {p99:.4f}"
    mean, p99 = difference(cube, bvh)
    assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{graph}, cube map against BVH: {mean:.4f}, {p99:.4f}"


@pytest.mark.parametrize("trace_variant", ["cpu", "gpu"], indirect=True)
def test_a_back_faces_tangent_space_normal_map_at_a_hit_matches_the_direct_view(renderer, trace_variant):
    """Seen from behind, the shading normal is flipped and so is the tangent frame that maps the
    Normal Map's colour (Cycles negates the whole mapped normal; the G-buffer's cotangent frame
    flips with the view): at a hit the triangle's UV directions must flip with it."""
    seen = direct(renderer, tangent_normal_map(), back=True)
    assert inner(seen).std(axis=(0, 1)).max() > 0.02, "the graph bends no normal"
    for mode in ("HYBRID", "FULL_BVH"):
        mean, p99 = difference(mirrored(renderer, tangent_normal_map(), mode, back=True), seen)
        assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{mode} against the direct view: {mean:.4f}, {p99:.4f}"


@pytest.mark.parametrize("graph", sorted(GRAPHS))
def test_the_lit_cube_maps_texels_bend_the_normal_as_the_cube_hits_do(renderer, graph):
    """The lit cube map runs a texel's program with the frame the face keeps
    (cube_light_shade.comp.glsl), so what a mirror reads from it is the normal a cube hit
    shades: the two differ by where in its texel each takes the UV, and for the Bump by its
    filter width (the texel's there, the ray cone's at a hit). Without the frame the texels'
    normals are flat, several times the bars off. The normal shows in the suns' light the
    texels store (lit_normal), not in an emission: the texels hold none, the reader adds the
    hit's own."""
    per_hit = mirrored(renderer, GRAPHS[graph](show=lit_normal), "HYBRID", lamps=SUNS_BELOW)
    stored = mirrored(renderer, GRAPHS[graph](show=lit_normal), "HYBRID", lit_cube=True, lamps=SUNS_BELOW)
    assert inner(per_hit).std(axis=(0, 1)).max() > 0.02, "the graph bends no normal"
    mean, p99 = difference(stored, per_hit)
    mean_bar, p99_bar = {"normal map": (0.01, 0.07), "bump": (0.03, 0.15)}[graph]
    assert mean <= mean_bar and p99 <= p99_bar, f"{graph}, lit cube map against cube hits: {mean:.4f}, {p99:.4f}"


# -- against Cycles, through Blender's render path ------------------------------------------
def _blender_graph(bpy, material, graph: str) -> None:
    """``graph``'s nodes in Blender (GRAPHS): the normal shown as an emission colour."""
    nodes, links = material.node_tree.nodes, material.node_tree.links
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)
    uv = nodes.new("ShaderNodeTexCoord").outputs["UV"]
    if graph == "normal map":
        wave = nodes.new("ShaderNodeTexWave")
        wave.bands_direction = "DIAGONAL"
        wave.inputs["Scale"].default_value = 1.0
        wave.inputs["Distortion"].default_value = 4.0
        links.new(uv, wave.inputs["Vector"])
        mix = nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        mix.inputs[6].default_value = (0.2, 0.7, 0.8, 1.0)  # A (colour)
        mix.inputs[7].default_value = (0.8, 0.35, 0.7, 1.0)  # B (colour)
        links.new(wave.outputs["Fac"], mix.inputs[0])
        normal_map = nodes.new("ShaderNodeNormalMap")
        normal_map.space = "TANGENT"
        links.new(mix.outputs[2], normal_map.inputs["Color"])
        normal = normal_map.outputs["Normal"]
    else:
        noise = nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 6.0
        noise.inputs["Detail"].default_value = 2.0
        links.new(uv, noise.inputs["Vector"])
        bump = nodes.new("ShaderNodeBump")
        bump.inputs["Distance"].default_value = 0.3
        links.new(noise.outputs["Fac"], bump.inputs["Height"])
        normal = bump.outputs["Normal"]
    shown = nodes.new("ShaderNodeVectorMath")
    shown.operation = "MULTIPLY_ADD"
    shown.inputs[1].default_value = (0.5, 0.5, 0.5)
    shown.inputs[2].default_value = (0.5, 0.5, 0.5)
    links.new(normal, shown.inputs[0])
    emission = nodes.new("ShaderNodeEmission")
    links.new(shown.outputs["Vector"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])


def _ceiling_over_a_mirror(bpy, build_graph, add_ceiling, facing: str):
    """A new scene: the ceiling ``add_ceiling(rotation)`` adds at CEILING_Z (turned 60 degrees
    about Z, and flipped to face down for ``facing`` front) with the material ``build_graph``
    fills, an 8 m mirror floor, an orthographic camera at z = 3 looking down, a black World,
    SIZE pixels; one sample at each pixel's centre in ours (as Cycles' narrow filter sees it),
    16 in Cycles (the mirror's bounce and the Bump's filter converged). Returns the scene and
    the camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    material = bpy.data.materials.new("ceiling")
    material.use_nodes = True
    build_graph(material)
    add_ceiling((math.pi if facing == "front" else 0.0, 0, UV_TURN))
    bpy.context.object.data.materials.append(material)
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    bpy.context.object.data.materials.append(mirror_material(bpy))
    camera = bpy.data.cameras.new("camera")
    camera.type = "ORTHO"
    camera.ortho_scale = 1.6
    camera_object = bpy.data.objects.new("camera", camera)
    camera_object.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    black_world(bpy, scene)
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    settings_for_one_sample(scene)
    scene.cycles.samples = 16
    scene.cycles.max_bounces = 2
    return scene, camera_object


@pytest.mark.parametrize("facing", ["front", "back"])
@pytest.mark.parametrize("graph", sorted(GRAPHS))
def test_a_uv_bent_normal_at_a_cube_hit_matches_cycles(addon, tmp_path, graph, facing):
    """The ceiling as Blender holds it (a 3 m plane turned 60 degrees about Z and flipped to
    face down: its UVs' directions are no axis, and the tangent is Blender's own), seen in a
    mirror through the cube map (HYBRID, near size 1) and through the BVH, against Cycles.
    ``back``: the plane not flipped, so the mirror sees its back face (a Normal Map's frame
    flips with the normal; the Bump's UV offsets run backwards there, as Cycles takes them
    from its flipped dP/du and dP/dv)."""
    import bpy

    from test_engine import render_exr

    scene, _camera = _ceiling_over_a_mirror(
        bpy, lambda material: _blender_graph(bpy, material, graph),
        lambda rotation: bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0, 0, CEILING_Z), rotation=rotation),
        facing)
    scene.render.engine = "CYCLES"
    cycles = render_exr(bpy, scene, tmp_path / "cycles.exr")[..., :3]
    assert inner(cycles).std(axis=(0, 1)).max() > 0.02, "the graph bends no normal"
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.near_size = 1.0
    scene.hybrid_rt.cube_resolution = 256
    for mode in ("HYBRID", "FULL_BVH"):
        scene.hybrid_rt.mode = mode
        ours = render_exr(bpy, scene, tmp_path / f"{mode}.exr")[..., :3]
        mean, p99 = difference(ours, cycles)
        assert mean <= MEAN_BAR and p99 <= P99_BAR, f"{graph}, {facing}, {mode} against Cycles: {mean:.4f}, {p99:.4f}"


# -- a Bump's Generated and Color Attribute heights, either face, against Cycles ------------
GRID_CUTS = 24
HEIGHT_SOURCES = ("generated", "attribute")
# A cube hit takes its triangle from the texel it meets, and a Color Attribute's gradient is
# the triangle's own (faceted): where a texel straddles two triangles, some pixels show the
# neighbour's slope. Far below a back face stepped the wrong way (0.19 mean).
CUBE_HIT_ATTRIBUTE_BARS = (0.006, 0.1)


def _paint(mesh) -> None:
    """A Color Attribute "Paint" on the points, a smooth grey pattern over the grid."""
    attribute = mesh.color_attributes.new("Paint", "FLOAT_COLOR", "POINT")
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    x, y = co[0::3], co[1::3]
    grey = 0.5 + 0.4 * np.sin(2.1 * x + 0.3) * np.cos(1.7 * y - 0.2)
    attribute.data.foreach_set("color", np.stack([grey, grey, grey, np.ones_like(grey)], -1).ravel())


def _height_bump_graph(material, height: str) -> None:
    """A Bump whose Height is a Noise of the implicit Generated coordinates, or the Color
    Attribute's Fac; the bent normal shown as an emission colour."""
    nodes, links = material.node_tree.nodes, material.node_tree.links
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)
    if height == "generated":
        source = nodes.new("ShaderNodeTexNoise")
        source.inputs["Scale"].default_value = 6.0
        source.inputs["Detail"].default_value = 2.0
        fac, distance = source.outputs["Fac"], 0.3
    else:
        source = nodes.new("ShaderNodeVertexColor")
        source.layer_name = "Paint"
        fac, distance = source.outputs["Color"], 1.0
    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Distance"].default_value = distance
    links.new(fac, bump.inputs["Height"])
    shown = nodes.new("ShaderNodeVectorMath")
    shown.operation = "MULTIPLY_ADD"
    shown.inputs[1].default_value = (0.5, 0.5, 0.5)
    shown.inputs[2].default_value = (0.5, 0.5, 0.5)
    links.new(bump.outputs["Normal"], shown.inputs[0])
    emission = nodes.new("ShaderNodeEmission")
    links.new(shown.outputs["Vector"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])


@pytest.mark.parametrize("facing", ["front", "back"])
@pytest.mark.parametrize("height", HEIGHT_SOURCES)
def test_a_bumps_generated_and_attribute_heights_step_as_in_cycles_on_either_face(addon, tmp_path, height, facing):
    """Cycles reads a mesh's interpolated attributes (the Generated coordinates and Color
    Attributes) at the Bump's shifted points through the barycentrics' change, which it solves
    with dP/du and dP/dv flipped with the normal: seen from behind they step backwards while
    the position steps forwards, as the UV does. A gridded ceiling, painted, seen directly from
    below (the G-buffer), and in a mirror through the cube map (HYBRID) and the BVH. The grid's
    flat axis is rounding noise in Blender's texture space, which Generated must not amplify
    (node_programs.texture_space)."""
    import bpy

    from test_engine import render_exr

    def painted_grid(rotation):
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=GRID_CUTS, y_subdivisions=GRID_CUTS, size=3.0,
                                        location=(0, 0, CEILING_Z), rotation=rotation)
        _paint(bpy.context.object.data)

    scene, camera_object = _ceiling_over_a_mirror(bpy, lambda material: _height_bump_graph(material, height),
                                                  painted_grid, facing)
    scene.hybrid_rt.near_size = 1.0
    scene.hybrid_rt.cube_resolution = 256
    views = {"mirror": ((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), ("HYBRID", "FULL_BVH")),
             "direct": ((0.0, 0.0, 3.0), (math.pi, 0.0, 0.0), ("HYBRID",))}
    for view, (location, rotation, modes) in views.items():
        camera_object.location, camera_object.rotation_euler = location, rotation
        scene.render.engine = "CYCLES"
        cycles = render_exr(bpy, scene, tmp_path / f"cycles_{view}.exr")[..., :3]
        assert inner(cycles).std(axis=(0, 1)).max() > 0.02, f"{view}: the height bends no normal"
        scene.render.engine = "HYBRID_RT"
        for mode in modes:
            scene.hybrid_rt.mode = mode
            ours = render_exr(bpy, scene, tmp_path / f"{view}_{mode}.exr")[..., :3]
            mean, p99 = difference(ours, cycles)
            mean_bar, p99_bar = CUBE_HIT_ATTRIBUTE_BARS if (height, mode) == ("attribute", "HYBRID") \
                else (MEAN_BAR, P99_BAR)
            assert mean <= mean_bar and p99 <= p99_bar, \
                f"{height}, {facing}, {view}, {mode} against Cycles: {mean:.4f}, {p99:.4f}"
