# SPDX-License-Identifier: GPL-3.0-or-later
"""Closure alpha (scene/closure_alpha.py, gpu_shaders/include/alpha.glsl): a coverage the
node graph computes (a Transparent BSDF mixed in by a factor of Math nodes, a Principled
Alpha fed by them) cuts the surface where every alpha test runs, from a short program of
the nodes the coverage reads. Against Cycles through Blender's render path at the end."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import variants
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.closure_alpha import closure_alpha_graph, has_closure_alpha, row_reads_coverage
from hybrid_engine.scene.node_program import compile_graph
from hybrid_engine.scene.shader_graph import Link, ShaderGraph
from test_alpha import (DISC_RADIUS, EMISSIVE_CARD, SMALL, _leaf_card_blender, card_scene,
                        check_mirror_against_cycles, check_primary_view_against_cycles, check_shadow_against_cycles,
                        disc_mask, mirror_view, top_camera)
from test_emitter_light import rectangle
from test_textures import textured_quad


def _disc_factor(graph: ShaderGraph, radius: float = DISC_RADIUS) -> int:
    """A node whose Value is 1 inside the UV disc of ``radius`` around (0.5, 0.5)."""
    coords = graph.add("TEX_COORD")
    distance = graph.add("VECT_MATH", settings={"operation": "DISTANCE"}, Vector=Link(coords, "UV"),
                         Vector_001=(0.5, 0.5, 0.0))
    return graph.add("MATH", settings={"operation": "LESS_THAN"}, Value=Link(distance, "Value"),
                     Value_001=radius)


def transparent_mix_graph() -> ShaderGraph:
    """A Transparent BSDF mixed with a noise-coloured Principled by the disc."""
    graph = ShaderGraph()
    fac = _disc_factor(graph)
    noise = graph.add("TEX_NOISE")
    surface = graph.add("BSDF_PRINCIPLED", **{"Base Color": Link(noise, "Color")})
    clear = graph.add("BSDF_TRANSPARENT")
    mix = graph.add("MIX_SHADER", Fac=Link(fac, "Value"), Shader=Link(clear, "BSDF"),
                    Shader_001=Link(surface, "BSDF"))
    graph.surface = Link(mix, "Shader")
    return graph


def test_the_alpha_program_keeps_the_coverages_nodes_and_leaves_the_colours_out():
    graph = transparent_mix_graph()
    alpha = closure_alpha_graph(graph)
    assert alpha is not None
    kinds = compile_graph(alpha).kinds
    assert {"MATH", "VECT_MATH", "TEX_COORD", "MIX_SHADER", "BSDF_TRANSPARENT"} <= kinds
    assert "TEX_NOISE" not in kinds  # the Principled's colour: no part of the coverage
    assert len(compile_graph(alpha).words) < len(compile_graph(graph).words)


def test_a_graph_without_transparency_has_no_alpha_program():
    graph = ShaderGraph()
    fac = _disc_factor(graph)
    a, b = graph.add("BSDF_DIFFUSE"), graph.add("BSDF_GLOSSY")
    graph.surface = Link(graph.add("MIX_SHADER", Fac=Link(fac, "Value"), Shader=Link(a, "BSDF"),
                                   Shader_001=Link(b, "BSDF")), "Shader")
    assert not has_closure_alpha(graph) and closure_alpha_graph(graph) is None
    principled = ShaderGraph()
    principled.surface = Link(principled.add("BSDF_PRINCIPLED", Alpha=Link(_disc_factor(principled), "Value")),
                              "BSDF")
    assert has_closure_alpha(principled)


def image_alpha_graph(through: str = "") -> ShaderGraph:
    """An emitting Principled whose Alpha is image 0's alpha, as importers build cut-out
    cards: straight (``through`` ""), through glTF's clip (``"CLIP"``), or at a Mapping's
    coordinates (``"MAPPING"``: no longer what the row's alpha image reads)."""
    graph = ShaderGraph()
    vector = {}
    if through == "MAPPING":
        coords = graph.add("TEX_COORD")
        vector = {"Vector": Link(graph.add("MAPPING", Vector=Link(coords, "UV"), Scale=(2.0, 2.0, 1.0)), "Vector")}
    image = graph.add("TEX_IMAGE", settings={"texture": 0}, **vector)
    alpha = Link(image, "Alpha")
    if through == "CLIP":
        below = graph.add("MATH", settings={"operation": "LESS_THAN"}, Value=alpha, Value_001=0.5)
        alpha = Link(graph.add("MATH", settings={"operation": "SUBTRACT"}, Value=1.0,
                               Value_001=Link(below, "Value")), "Value")
    graph.surface = Link(graph.add("BSDF_PRINCIPLED", Alpha=alpha, **{"Base Color": (0.0, 0.0, 0.0, 1.0),
                                                                     "Emission Color": (1.0, 1.0, 1.0, 1.0),
                                                                     "Emission Strength": 1.0}), "BSDF")
    return graph


def test_an_alpha_read_straight_from_an_image_is_the_rows_to_read():
    assert row_reads_coverage(image_alpha_graph()) and row_reads_coverage(image_alpha_graph("CLIP"))
    assert not row_reads_coverage(image_alpha_graph("MAPPING"))
    assert not row_reads_coverage(transparent_mix_graph())
    assert all(has_closure_alpha(image_alpha_graph(t)) for t in ("", "CLIP", "MAPPING"))


@pytest.mark.parametrize("through", ["", "CLIP"])
def test_a_scene_whose_coverage_the_rows_read_compiles_no_call_into_the_programs(renderer, through):
    """Cut-out cards as importers build them keep the one-fetch alpha test: the program call
    weighs on every shader that tests coverage (the traversal above all), so it is compiled
    only where some coverage needs it. The cut still matches the disc."""
    card = dict(EMISSIVE_CARD)
    scene = with_graphs(card_scene(card), [card, dict(base_color=(0.0, 0.0, 0.0), emission=(0.25,) * 3)],
                        [image_alpha_graph(through), None])
    image = renderer.render(scene, top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    assert "NODE_PROGRAMS" in renderer.gpu_scene.defines
    assert "NODE_CLOSURE_ALPHA" not in renderer.gpu_scene.defines
    assert ((image[..., 0] > 0.6) != disc_mask()).mean() <= 0.02


def test_an_image_read_at_other_coordinates_keeps_its_alpha_program(renderer):
    card = dict(EMISSIVE_CARD)
    scene = with_graphs(card_scene(card), [card, dict(base_color=(0.0, 0.0, 0.0), emission=(0.25,) * 3)],
                        [image_alpha_graph("MAPPING"), None])
    image = renderer.render(scene, top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    assert "NODE_CLOSURE_ALPHA" in renderer.gpu_scene.defines
    covered = image[..., 0] > 0.6
    assert (covered != disc_mask()).mean() > 0.1  # the disc tiled twice over the card, not once

def card_graph(emits: bool, radius: float = DISC_RADIUS) -> ShaderGraph:
    """The card's graph: a Transparent BSDF mixed with a white Emission (or a grey Diffuse)
    by the UV disc."""
    graph = ShaderGraph()
    fac = _disc_factor(graph, radius)
    surface = graph.add("EMISSION", Strength=1.0) if emits else graph.add("BSDF_DIFFUSE")
    clear = graph.add("BSDF_TRANSPARENT")
    mix = graph.add("MIX_SHADER", Fac=Link(fac, "Value"), Shader=Link(clear, "BSDF"),
                    Shader_001=Link(surface, "Emission" if emits else "BSDF"))
    graph.surface = Link(mix, "Shader")
    return graph


def with_graphs(scene: SceneData, rows: list[dict], graphs: list) -> SceneData:
    table = MaterialTable.from_rows(rows)
    table.node_graphs = list(graphs)
    return SceneData(scene.geometry, table, scene.lights, scene.sky)


@pytest.fixture(params=["cpu", "gpu"])
def kernels(request):
    """Every kernel in one shape: the CPU driver's (world rows, megakernel) or the GPU's
    (instanced draws, one multi-draw of the faces, the waves)."""
    variants.set_override(request.param)
    yield request.param
    variants.set_override(None)


def test_a_graphs_transparent_mix_cuts_the_card_in_the_primary_view(renderer, kernels):
    emitting = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0))
    scene = with_graphs(card_scene(emitting), [emitting, dict(base_color=(0.0, 0.0, 0.0), emission=(0.25,) * 3)],
                        [card_graph(True), None])
    assert scene.materials.has_alpha
    image = renderer.render(scene, top_camera(), RenderSettings(mode="RASTER", **SMALL)).image
    covered = image[..., 0] > 0.6
    assert (covered != disc_mask()).mean() <= 0.02


def card_shadow(on, radius: float = DISC_RADIUS, graph: ShaderGraph | None = None) -> np.ndarray:
    """Where the graph card (a disc of ``radius``, or ``graph``) shades a grey floor from a sun
    at 45 degrees, seen from above the shadow by renderer ``on`` (RASTER): the card's point
    (x, y) casts its shadow where top_camera sees it (disc_mask)."""
    sun = dict(kind="SUN", direction=(1, 0, -1), color=(3, 3, 3), radius=0.0)
    grey = dict(base_color=(0.8, 0.8, 0.8))
    scene = with_graphs(card_scene(grey, lights=[sun], floor_z=-3.0),
                        [grey, dict(base_color=(0.8, 0.8, 0.8), specular=0.0)],
                        [graph or card_graph(False, radius), None])
    camera = Camera(matrix_world=look_at((3, 0, 5), (3, 0, -3), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0)
    image = on.render(scene, camera, RenderSettings(mode="RASTER", **SMALL)).image[..., 0]
    return image < 0.5 * image.max()


def test_a_graphs_transparent_mix_cuts_the_cards_shadow(renderer, kernels):
    assert (~card_shadow(renderer) != ~disc_mask()).mean() <= 0.02


# -- the shadow ray's view of a coverage: Light Path's Is Shadow Ray, and the lamp's Incoming
SHADOW_SHARE = 0.8  # the disc's radius, as a share of DISC_RADIUS, that shadow rays see


def disc_of(radius: float, size: int = 64) -> np.ndarray:
    """disc_mask for a disc of ``radius`` (UV units)."""
    centres = (np.arange(size) + 0.5) / size - 0.5
    x, y = np.meshgrid(centres, centres)
    return x * x + y * y <= radius ** 2


def _cut(graph: ShaderGraph, inside: int) -> ShaderGraph:
    """The card's grey Diffuse where ``inside``'s Value is 1, a Transparent BSDF elsewhere."""
    surface, clear = graph.add("BSDF_DIFFUSE"), graph.add("BSDF_TRANSPARENT")
    mix = graph.add("MIX_SHADER", Fac=Link(inside, "Value"), Shader=Link(clear, "BSDF"),
                    Shader_001=Link(surface, "BSDF"))
    graph.surface = Link(mix, "Shader")
    return graph


def shadow_ray_disc_graph() -> ShaderGraph:
    """A disc whose radius shadow rays see smaller: DISC_RADIUS less (1 - SHADOW_SHARE) of it
    times Light Path's Is Shadow Ray."""
    graph = ShaderGraph()
    path = graph.add("LIGHT_PATH")
    radius = graph.add("MATH", settings={"operation": "MULTIPLY_ADD"}, Value=Link(path, "Is Shadow Ray"),
                       Value_001=-(1.0 - SHADOW_SHARE) * DISC_RADIUS, Value_002=DISC_RADIUS)
    coords = graph.add("TEX_COORD")
    distance = graph.add("VECT_MATH", settings={"operation": "DISTANCE"}, Vector=Link(coords, "UV"),
                         Vector_001=(0.5, 0.5, 0.0))
    inside = graph.add("MATH", settings={"operation": "LESS_THAN"}, Value=Link(distance, "Value"),
                       Value_001=Link(radius, "Value"))
    return _cut(graph, inside)


def oblique_disc_graph() -> ShaderGraph:
    """The disc, there only where it is seen at a slant: Layer Weight's Facing above 0.2 (a
    sun at 45 degrees gives 1 - cos 45 = 0.29; a view along the normal 0)."""
    graph = ShaderGraph()
    weight = graph.add("LAYER_WEIGHT", Blend=0.5)
    slanted = graph.add("MATH", settings={"operation": "GREATER_THAN"}, Value=Link(weight, "Facing"),
                        Value_001=0.2)
    inside = graph.add("MATH", settings={"operation": "MULTIPLY"}, Value=Link(_disc_factor(graph), "Value"),
                       Value_001=Link(slanted, "Value"))
    return _cut(graph, inside)


def test_shadow_maps_run_a_coverage_as_a_shadow_ray_sees_it(renderer, kernels):
    """Cycles' shadow rays evaluate a blocker with Is Shadow Ray set (an artist's glass that
    casts no shadow mixes in a Transparent BSDF by it): the shadow is the smaller disc, while
    the camera sees the whole one."""
    shadow = card_shadow(renderer, graph=shadow_ray_disc_graph())
    assert (shadow != disc_of(SHADOW_SHARE * DISC_RADIUS)).mean() <= 0.02, shadow.mean()
    grey = dict(base_color=(0.8, 0.8, 0.8))
    scene = with_graphs(card_scene(grey, floor_emission=0.0), [grey, dict(base_color=(0.0, 0.0, 0.0))],
                        [shadow_ray_disc_graph(), None])
    sun = dict(kind="SUN", direction=(0, 0, -1), color=(3, 3, 3), radius=0.0)
    scene = SceneData(scene.geometry, scene.materials, Lights.from_rows([sun]), scene.sky)
    seen = renderer.render(scene, top_camera(), RenderSettings(mode="RASTER", **SMALL)).image[..., 0] > 0.1
    assert (seen != disc_mask()).mean() <= 0.02


def test_shadow_maps_see_a_coverage_from_the_lamp(renderer, kernels):
    """Layer Weight and Fresnel read the angle the shadow ray meets the blocker at (Cycles'
    Incoming of the shadow ray): a card there only at a slant casts its disc's shadow from a
    sun at 45 degrees, and none from a sun overhead, which sees it along its normal."""
    slanted = card_shadow(renderer, graph=oblique_disc_graph())
    assert (slanted != disc_mask()).mean() <= 0.02, slanted.mean()
    grey = dict(base_color=(0.8, 0.8, 0.8))
    overhead = dict(kind="SUN", direction=(0, 0, -1), color=(3, 3, 3), radius=0.0)
    scene = with_graphs(card_scene(grey, lights=[overhead], floor_z=-3.0),
                        [grey, dict(base_color=(0.8, 0.8, 0.8), specular=0.0)], [oblique_disc_graph(), None])
    camera = Camera(matrix_world=look_at((0, 0, -2), (0, 0, -3), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0, clip_start=0.01)
    floor = renderer.render(scene, camera, RenderSettings(mode="RASTER", **SMALL)).image[..., 0]
    assert floor.min() > 0.5 * floor.max()  # no shadow under the card


def test_a_value_edit_of_an_alpha_program_draws_the_cached_shadow_again(gl, renderer):
    """The shadow maps keep what did not change from frame to frame (shadow_cache.py): an edit
    of an alpha program's values (the disc's radius, an upload of words) is a change."""
    from hybrid_engine.frame.renderer import Renderer

    card_shadow(renderer)
    edited = card_shadow(renderer, 0.6 * DISC_RADIUS)
    fresh = Renderer(gl)
    try:
        expected = card_shadow(fresh, 0.6 * DISC_RADIUS)
    finally:
        fresh.release()
    assert 0.05 < expected.mean() < 0.5
    assert (edited != expected).mean() <= 0.01, (edited.mean(), expected.mean())


@pytest.mark.parametrize("near_size", [4.0, 0.2], ids=["bvh", "cube_map"])
def test_a_graphs_transparent_mix_cuts_the_card_in_a_mirror(renderer, kernels, near_size):
    """The mirror's rays meet the card in the BVH (its any-hit test runs the alpha program)
    or in the cube map (whose faces ran it), and see it as they see a card cut by an alpha
    image."""
    emitting = dict(base_color=(0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0))
    mirror = dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0)
    scene = with_graphs(card_scene(emitting), [emitting, mirror], [card_graph(True), None])
    camera = Camera(matrix_world=look_at((0, 0, -0.5), (0, 0, -1), up=(0, 1, 0)), width=64, height=64,
                    projection="ORTHO", ortho_scale=2.0, clip_start=0.01)
    settings = RenderSettings(mode="HYBRID", **{**SMALL, "near_size": near_size, "cube_resolution": 256})
    image = renderer.render(scene, camera, settings).image[..., 0]
    # As the same card cut by an alpha image shows (test_alpha.py holds that one to the disc).
    reference = mirror_view(renderer, EMISSIVE_CARD, "HYBRID", near_size)
    assert 0.2 < (image > 0.5).mean() < 0.6
    assert ((image > 0.5) != (reference > 0.5)).mean() <= 0.02


# -- against Cycles, through Blender's render path ------------------------------------------
def _graph_card(bpy, scene, card_emits: bool, through: str) -> None:
    """The card's material made anew: its coverage the UV disc computed by Math nodes, through
    a Mix Shader with a Transparent BSDF (``through`` "MIX") or a Principled Alpha ("ALPHA")."""
    material = bpy.data.materials["card"]
    nodes, links = material.node_tree.nodes, material.node_tree.links
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)
    coords = nodes.new("ShaderNodeTexCoord")
    distance = nodes.new("ShaderNodeVectorMath")
    distance.operation = "DISTANCE"
    distance.inputs[1].default_value = (0.5, 0.5, 0.0)
    links.new(coords.outputs["UV"], distance.inputs[0])
    inside = nodes.new("ShaderNodeMath")
    inside.operation = "LESS_THAN"
    inside.inputs[1].default_value = DISC_RADIUS
    links.new(distance.outputs["Value"], inside.inputs[0])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    if card_emits:
        bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bsdf.inputs["Emission Strength"].default_value = 1.0
    output = nodes["Material Output"]
    if through == "ALPHA":
        links.new(inside.outputs["Value"], bsdf.inputs["Alpha"])
        links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
        return
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(inside.outputs["Value"], mix.inputs["Fac"])
    links.new(clear.outputs["BSDF"], mix.inputs[1])
    links.new(bsdf.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], output.inputs["Surface"])


@pytest.mark.parametrize("through", ["MIX", "ALPHA"])
def test_a_graph_computed_coverage_matches_cycles_in_the_primary_view(addon, tmp_path, through):
    import bpy

    check_primary_view_against_cycles(bpy, tmp_path, lambda scene, emits: _graph_card(bpy, scene, emits, through))


def test_a_graph_computed_coverage_casts_cycles_shadow(addon, tmp_path):
    import bpy

    check_shadow_against_cycles(bpy, tmp_path, lambda scene, emits: _graph_card(bpy, scene, emits, "MIX"))


def test_a_graph_computed_coverage_shows_in_a_mirror(addon, tmp_path):
    """The BVH's any-hit test runs the alpha program (HYBRID: the mirror's rays meet the
    card in the near cube)."""
    import bpy

    check_mirror_against_cycles(bpy, tmp_path, lambda scene, emits: _graph_card(bpy, scene, emits, "MIX"))


def test_a_coverage_the_program_computes_is_not_told_as_unread(addon):
    """The row's reader cannot read a Math chain into the Mix's Factor; the alpha program
    does, so the artist is not told that the Factor's own value is used."""
    import bpy

    scene, _ = _leaf_card_blender(bpy, card_emits=True, floor_z=-1.0, floor_kind="EMIT")
    _graph_card(bpy, scene, card_emits=True, through="MIX")
    read = addon.blender_adapter.export.materials.material_params
    with addon.blender_adapter.messages.collecting() as told:
        row = read(bpy.data.materials["card"])
    assert row.get("node_graph") is not None and has_closure_alpha(row["node_graph"])
    assert not [line for line in told if "Factor" in line]


def _shadow_view_card(bpy, scene, card_emits: bool, reads: str) -> None:
    """The card's material made anew as shadow_ray_disc_graph (``reads`` "SHADOW_RAY") or
    oblique_disc_graph ("FACING") builds it, in Blender's nodes."""
    material = bpy.data.materials["card"]
    nodes, links = material.node_tree.nodes, material.node_tree.links
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)

    def math(operation: str, a, b, c=None):
        node = nodes.new("ShaderNodeMath")
        node.operation = operation
        for socket, value in zip(node.inputs, (a, b, c)):
            if isinstance(value, float):
                socket.default_value = value
            elif value is not None:
                links.new(value, socket)
        return node.outputs["Value"]

    coords = nodes.new("ShaderNodeTexCoord")
    distance = nodes.new("ShaderNodeVectorMath")
    distance.operation = "DISTANCE"
    distance.inputs[1].default_value = (0.5, 0.5, 0.0)
    links.new(coords.outputs["UV"], distance.inputs[0])
    if reads == "SHADOW_RAY":
        path = nodes.new("ShaderNodeLightPath")
        radius = math("MULTIPLY_ADD", path.outputs["Is Shadow Ray"], -(1.0 - SHADOW_SHARE) * DISC_RADIUS,
                      DISC_RADIUS)
        inside = math("LESS_THAN", distance.outputs["Value"], radius)
    else:
        weight = nodes.new("ShaderNodeLayerWeight")
        weight.inputs["Blend"].default_value = 0.5
        inside = math("MULTIPLY", math("LESS_THAN", distance.outputs["Value"], DISC_RADIUS),
                      math("GREATER_THAN", weight.outputs["Facing"], 0.2))
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(inside, mix.inputs["Fac"])
    links.new(clear.outputs["BSDF"], mix.inputs[1])
    links.new(bsdf.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], nodes["Material Output"].inputs["Surface"])


@pytest.mark.parametrize("reads", ["SHADOW_RAY", "FACING"])
def test_a_coverage_casts_the_shadow_cycles_shadow_rays_see(addon, tmp_path, reads):
    """Is Shadow Ray and the shadow ray's Incoming (Layer Weight's Facing at 45 degrees), as
    the shadow maps run the alpha program, against Cycles' shadow rays."""
    import bpy

    check_shadow_against_cycles(bpy, tmp_path, lambda scene, emits: _shadow_view_card(bpy, scene, emits, reads))


def shadow_clear_graph(ray_depth: int | None = None) -> ShaderGraph:
    """A black Diffuse that shadow rays see as a Transparent BSDF (Light Path's Is Shadow
    Ray): there for every ray but a shadow ray. With ``ray_depth``, a Transparent BSDF where
    Light Path's Ray Depth is that instead."""
    graph = ShaderGraph()
    path = graph.add("LIGHT_PATH")
    fac = Link(path, "Is Shadow Ray")
    if ray_depth is not None:
        fac = Link(graph.add("MATH", settings={"operation": "COMPARE"}, Value=Link(path, "Ray Depth"),
                             Value_001=float(ray_depth), Value_002=0.5), "Value")
    mix = graph.add("MIX_SHADER", Fac=fac,
                    Shader=Link(graph.add("BSDF_DIFFUSE", Color=(0.0, 0.0, 0.0, 1.0)), "BSDF"),
                    Shader_001=Link(graph.add("BSDF_TRANSPARENT"), "BSDF"))
    graph.surface = Link(mix, "Shader")
    return graph


def panel_light_under(renderer, card: str) -> float:
    """The mean light on a grey floor lit only by an emissive panel 2 m above it, with a black
    card at 1 m between (``card``: "none", "opaque", "shadow_clear": opaque but to shadow
    rays, by Light Path's Is Shadow Ray, or "depth_N_clear": a Transparent BSDF where Ray Depth
    is N), seen from between the card and the floor; no bounces, so the floor's light is the
    next-event estimate at the point the camera sees."""
    grey, lamp, black = dict(base_color=(0.8, 0.8, 0.8), specular=0.0), dict(emission=(3.0,) * 3), \
        dict(base_color=(0.0, 0.0, 0.0), specular=0.0)
    objects = [(rectangle(-0.5, 0.5, -0.5, 0.5, 2.0), None, 1), (rectangle(-6, 6, -6, 6, 0.0), None, 0)]
    if card != "none":
        objects.append((rectangle(-1.0, 1.0, -1.0, 1.0, 1.0), None, 2))
    table = MaterialTable.from_rows([grey, lamp, black])
    graphs = {"shadow_clear": shadow_clear_graph(), "depth_1_clear": shadow_clear_graph(ray_depth=1),
              "depth_2_clear": shadow_clear_graph(ray_depth=2)}
    table.node_graphs = [None, None, graphs.get(card)]
    scene = SceneData(Geometry.from_objects(objects), table, Lights.from_rows([]), Sky(color=(0.0, 0.0, 0.0)))
    camera = Camera(matrix_world=look_at((0, 0, 0.5), (0, 0, 0), up=(0, 1, 0)), width=32, height=32,
                    projection="ORTHO", ortho_scale=0.8, clip_start=0.01)
    settings = RenderSettings(mode="HYBRID", near_size=8.0, cube_resolution=64, diffuse_bounces=0)
    total = 0.0
    for sample in range(8):
        total += float(renderer.render(scene, camera, settings, sample=sample).image[..., 0].mean())
    return total / 8


def test_an_emitters_shadow_rays_run_a_coverage_as_shadow_rays(renderer):
    """The emitters' next-event rays are Cycles' shadow rays: a card that is there for every
    ray but a shadow ray lets the panel's light through, as no card does, where an opaque
    card hides it."""
    clear, blocked, shadowed = (panel_light_under(renderer, card) for card in ("none", "shadow_clear", "opaque"))
    assert shadowed < 0.3 * clear
    assert abs(blocked - clear) <= 0.05 * clear, (blocked, clear, shadowed)


def test_an_emitters_shadow_rays_from_the_point_the_camera_sees_have_ray_depth_1(renderer):
    """Cycles' shadow ray has Ray Depth one more than the bounce it leaves from (svm
    light_path.h): 1 from the floor the camera sees. A card transparent only at Ray Depth 1
    lets the panel's light through, as no card does; one transparent only at Ray Depth 2
    hides it, as an opaque card does."""
    clear, depth_1, depth_2 = (panel_light_under(renderer, card) for card in ("none", "depth_1_clear", "depth_2_clear"))
    assert abs(depth_1 - clear) <= 0.05 * clear, (depth_1, clear)
    assert depth_2 < 0.3 * clear, (depth_2, clear)


TUBE_HALF, TUBE_DROP = 0.5, 0.8  # the walls' square around the view, and how far they hang


def mirrored_ceiling_light(renderer, walls: str) -> float:
    """The mean light of a grey ceiling 4 m over a mirror floor, lit by a white World only,
    as the mirror shows it straight up (World Light Screen: the reflections' first hits hide
    the World by one occlusion ray within AO Distance, trace_ray.glsl shade_hit). Around the
    view a square tube of black walls (``walls``: "none", "opaque", "shadow_clear", or
    "depth_2_clear": a Transparent BSDF where Ray Depth is 2) hangs
    from the ceiling: edge-on to the camera's and the mirror's rays, across most of the
    occlusion rays' cosine hemisphere, and nearer than AO Distance, where the floor is not."""
    grey, mirror, black = dict(base_color=(0.8, 0.8, 0.8), specular=0.0), \
        dict(base_color=(1.0, 1.0, 1.0), reflectivity=1.0, roughness=0.0), \
        dict(base_color=(0.0, 0.0, 0.0), specular=0.0)
    objects = [(rectangle(-2, 2, -2, 2, 4.0), None, 0), (rectangle(-4, 4, -4, 4, 0.0), None, 1)]
    if walls != "none":
        h = TUBE_HALF
        for (x, y), (dx, dy) in [((-h, -h), (2 * h, 0)), ((h, -h), (0, 2 * h)), ((h, h), (-2 * h, 0)),
                                 ((-h, h), (0, -2 * h))]:
            quad, _ = textured_quad((x, y, 4.0), (dx, dy, 0.0), (0.0, 0.0, -TUBE_DROP), (0.0, 0.0), (1.0, 1.0))
            objects.append((quad, None, 2))
    table = MaterialTable.from_rows([grey, mirror, black])
    graphs = {"shadow_clear": shadow_clear_graph(), "depth_2_clear": shadow_clear_graph(ray_depth=2)}
    table.node_graphs = [None, None, graphs.get(walls)]
    scene = SceneData(Geometry.from_objects(objects), table, Lights.from_rows([]), Sky(color=(1.0, 1.0, 1.0)))
    camera = Camera(matrix_world=look_at((0, 0, 3), (0, 0, 0), up=(0, 1, 0)), width=16, height=16,
                    projection="ORTHO", ortho_scale=0.6, clip_start=0.01)
    settings = RenderSettings(mode="HYBRID", near_size=8.0, cube_resolution=64, max_depth=1,
                              world_light="SCREEN", ao_distance=1.0)
    total = 0.0
    for sample in range(4):
        total += float(renderer.render(scene, camera, settings, sample=sample).image[..., 0].mean())
    return total / 4


def test_the_occlusion_rays_run_a_coverage_as_shadow_rays(renderer, kernels):
    """AO Distance's occlusion rays ask only whether a blocker hides the World, as Cycles'
    shadow rays do (Is Shadow Ray set; the waves' any-hit kernel and the megakernel alike):
    walls there for every ray but a shadow ray hide none of it, as no walls do, where opaque
    walls darken the ceiling."""
    clear, seen_through, darkened = (mirrored_ceiling_light(renderer, walls)
                                     for walls in ("none", "shadow_clear", "opaque"))
    assert darkened < 0.6 * clear, (darkened, clear)
    assert abs(seen_through - clear) <= 0.02 * clear, (seen_through, clear, darkened)


def test_the_occlusion_rays_of_a_reflections_hit_have_ray_depth_2(renderer, kernels):
    """Cycles' shadow ray has Ray Depth one more than the bounce it leaves from (svm
    light_path.h): 2 from the surface a mirror shows. Walls transparent only at Ray Depth 2
    hide none of the World's light there, as no walls do."""
    clear, seen_through = (mirrored_ceiling_light(renderer, walls) for walls in ("none", "depth_2_clear"))
    assert abs(seen_through - clear) <= 0.02 * clear, (seen_through, clear)
