# SPDX-License-Identifier: GPL-3.0-or-later
"""The node-tree reader (blender_adapter/export/node_graph.py): a material's tree as the flat
``ShaderGraph`` the core compiles, read as Blender evaluates it (groups at any depth,
reroutes, muted nodes and links, unsupported nodes named once), and its hook into the
material export (graph_rows.py: the fixed rows keep the trees they hold exactly)."""
from __future__ import annotations

import numpy as np
import pytest

RAMP_TABLE_SIZE = 256


def Link(node: int, output: str):  # noqa: N802 - reads as the core's Link in the assertions
    """The add-on's own ``Link`` (it is loaded as ``hybrid_rt``, so its classes are not the
    test's ``hybrid_engine`` ones)."""
    import hybrid_rt
    return hybrid_rt.hybrid_engine.scene.shader_graph.Link(node, output)


def _material(name: str = "Graph"):
    import bpy
    material = bpy.data.materials.new(name)
    tree = material.node_tree
    return material, tree.nodes, tree.links, tree.nodes["Principled BSDF"]


def _shape(graph) -> tuple:
    """Everything but the artist's node names (which carry the group path)."""
    return ([(n.kind, n.settings, n.inputs) for n in graph.nodes], graph.surface, graph.displacement)


def _read(addon, material, images: bool = True):
    return addon.blender_adapter.export.node_graph.read_node_graph(material, images=images)


def _only(graph, kind: str):
    (node,) = [n for n in graph.nodes if n.kind == kind]
    return node


def _index(graph, kind: str) -> int:
    (index,) = [i for i, n in enumerate(graph.nodes) if n.kind == kind]
    return index


def _noise_math(nodes, links, vector, amount):
    """Noise (ridged, 4D) -> Math (power, clamped) with ``amount`` as the exponent: the
    nodes the group tests hide inside groups. Returns (math node, noise W socket)."""
    noise = nodes.new("ShaderNodeTexNoise")
    noise.noise_dimensions = "4D"
    noise.noise_type = "RIDGED_MULTIFRACTAL"
    noise.normalize = False
    noise.inputs["Scale"].default_value = 7.5
    noise.inputs["Detail"].default_value = 3.0
    math = nodes.new("ShaderNodeMath")
    math.operation = "POWER"
    math.use_clamp = True
    links.new(vector, noise.inputs["Vector"])
    links.new(noise.outputs["Fac"], math.inputs[0])
    if isinstance(amount, float):
        math.inputs[1].default_value = amount
    else:
        links.new(amount, math.inputs[1])
    return math, next(s for s in noise.inputs if s.identifier == "W")


def _socket(sockets, identifier: str):
    """A socket by identifier (the Mix node has several inputs named "A")."""
    return next(s for s in sockets if s.identifier == identifier)


def _ramp_to_base_colour(nodes, links, principled, value_socket):
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.2, 0.3, 1.0)
    links.new(value_socket, ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], principled.inputs["Base Color"])
    principled.inputs["Roughness"].default_value = 0.25


def test_a_group_nested_two_deep_reads_as_the_same_nodes_written_flat(addon):
    import bpy
    flat, nodes, links, principled = _material("Flat")
    coords = nodes.new("ShaderNodeTexCoord")
    math, w = _noise_math(nodes, links, coords.outputs["Object"], 0.3)
    w.default_value = 1.25
    _ramp_to_base_colour(nodes, links, principled, math.outputs[0])

    inner = bpy.data.node_groups.new("Inner", "ShaderNodeTree")
    inner.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
    amount = inner.interface.new_socket("Amount", in_out="INPUT", socket_type="NodeSocketFloat")
    amount.default_value = 0.9  # the group's interface default: the instance's own value wins
    inner.interface.new_socket("Value", in_out="OUTPUT", socket_type="NodeSocketFloat")
    i_in, i_out = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
    i_math, i_w = _noise_math(inner.nodes, inner.links, i_in.outputs["Vector"], i_in.outputs["Amount"])
    i_w.default_value = 1.25
    inner.links.new(i_math.outputs[0], i_out.inputs["Value"])

    outer = bpy.data.node_groups.new("Outer", "ShaderNodeTree")
    outer.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
    outer.interface.new_socket("Value", in_out="OUTPUT", socket_type="NodeSocketFloat")
    o_in, o_out = outer.nodes.new("NodeGroupInput"), outer.nodes.new("NodeGroupOutput")
    o_group = outer.nodes.new("ShaderNodeGroup")
    o_group.node_tree = inner
    o_group.inputs["Amount"].default_value = 0.3
    reroute = outer.nodes.new("NodeReroute")  # a reroute inside a group too
    outer.links.new(o_in.outputs["Vector"], reroute.inputs[0])
    outer.links.new(reroute.outputs[0], o_group.inputs["Vector"])
    outer.links.new(o_group.outputs["Value"], o_out.inputs["Value"])

    grouped, nodes, links, principled = _material("Grouped")
    coords = nodes.new("ShaderNodeTexCoord")
    group = nodes.new("ShaderNodeGroup")
    group.node_tree = outer
    links.new(coords.outputs["Object"], group.inputs["Vector"])
    _ramp_to_base_colour(nodes, links, principled, group.outputs["Value"])

    flat_graph, grouped_read = _read(addon, flat).graph, _read(addon, grouped)
    assert [n.kind for n in flat_graph.nodes] == ["TEX_COORD", "TEX_NOISE", "MATH", "VALTORGB", "BSDF_PRINCIPLED"]
    assert _shape(grouped_read.graph) == _shape(flat_graph)
    assert grouped_read.structural  # no row can hold a grouped tree
    assert _only(grouped_read.graph, "MATH").name == "Group/Group/Math"  # where the artist finds it


def test_an_unlinked_group_input_gives_the_group_nodes_own_value_converted_to_the_inner_socket(addon):
    import bpy
    material, nodes, links, principled = _material()
    tint = bpy.data.node_groups.new("Tint", "ShaderNodeTree")
    socket = tint.interface.new_socket("Grey", in_out="INPUT", socket_type="NodeSocketFloat")
    socket.default_value = 0.5
    tint.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    g_in, g_out = tint.nodes.new("NodeGroupInput"), tint.nodes.new("NodeGroupOutput")
    diffuse = tint.nodes.new("ShaderNodeBsdfDiffuse")
    tint.links.new(g_in.outputs["Grey"], diffuse.inputs["Color"])  # float into a colour socket
    tint.links.new(diffuse.outputs["BSDF"], g_out.inputs["BSDF"])
    group = nodes.new("ShaderNodeGroup")
    group.node_tree = tint
    group.inputs["Grey"].default_value = 0.125
    links.new(group.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])

    graph = _read(addon, material).graph
    assert [n.kind for n in graph.nodes] == ["BSDF_DIFFUSE"]  # the Principled no longer reaches the output
    assert graph.nodes[0].inputs["Color"] == (0.125, 0.125, 0.125, 1.0)
    assert graph.surface == Link(0, "BSDF")


def test_a_muted_math_node_passes_its_first_input_through(addon):
    material, nodes, links, principled = _material()
    value = nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.375
    math = nodes.new("ShaderNodeMath")
    math.operation = "ADD"
    math.inputs[1].default_value = 10.0
    links.new(value.outputs[0], math.inputs[0])
    links.new(math.outputs[0], principled.inputs["Roughness"])
    lone = nodes.new("ShaderNodeMath")  # muted with its first input unlinked: that value
    lone.inputs[0].default_value = 0.625
    lone.mute = True
    links.new(lone.outputs[0], principled.inputs["Metallic"])
    math.mute = True

    read = _read(addon, material)
    graph = read.graph
    assert [n.kind for n in graph.nodes] == ["VALUE", "BSDF_PRINCIPLED"]
    assert graph.nodes[0].inputs == {"Value": 0.375}  # a Value node's value rides on its output
    shader = graph.nodes[1].inputs
    assert shader["Roughness"] == Link(0, "Value") and shader["Metallic"] == 0.625
    assert read.structural


def test_a_muted_node_without_an_internal_link_gives_its_outputs_default(addon):
    material, nodes, links, principled = _material()
    noise = nodes.new("ShaderNodeTexNoise")  # nothing leads to Fac when muted
    noise.outputs["Fac"].default_value = 0.0
    links.new(noise.outputs["Fac"], principled.inputs["Metallic"])
    principled.inputs["Metallic"].default_value = 0.5
    noise.mute = True
    assert not noise.internal_links
    graph = _read(addon, material).graph
    assert [n.kind for n in graph.nodes] == ["BSDF_PRINCIPLED"] and graph.nodes[0].inputs["Metallic"] == 0.0


def test_reroute_chains_are_followed_and_a_dangling_one_leaves_the_input_its_own_value(addon):
    material, nodes, links, principled = _material()
    checker = nodes.new("ShaderNodeTexChecker")
    previous = checker.outputs["Color"]
    for _ in range(3):
        reroute = nodes.new("NodeReroute")
        links.new(previous, reroute.inputs[0])
        previous = reroute.outputs[0]
    links.new(previous, principled.inputs["Base Color"])
    dangling = nodes.new("NodeReroute")
    links.new(dangling.outputs[0], principled.inputs["Roughness"])
    principled.inputs["Roughness"].default_value = 0.75

    read = _read(addon, material)
    shader = _only(read.graph, "BSDF_PRINCIPLED").inputs
    assert shader["Base Color"] == Link(_index(read.graph, "TEX_CHECKER"), "Color")
    assert shader["Roughness"] == 0.75
    assert "REROUTE" not in [n.kind for n in read.graph.nodes] and not read.structural


def test_muted_and_invalid_links_are_ignored_and_the_input_keeps_its_value(addon):
    material, nodes, links, principled = _material()
    wave = nodes.new("ShaderNodeTexWave")
    muted = links.new(wave.outputs["Fac"], principled.inputs["Roughness"])
    muted.is_muted = True
    principled.inputs["Roughness"].default_value = 0.2
    emission = nodes.new("ShaderNodeEmission")  # a shader into a colour: an invalid link
    invalid = links.new(emission.outputs["Emission"], principled.inputs["Base Color"])
    principled.inputs["Base Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    assert not invalid.is_valid

    read = _read(addon, material)
    assert [n.kind for n in read.graph.nodes] == ["BSDF_PRINCIPLED"]
    shader = read.graph.nodes[0].inputs
    assert shader["Roughness"] == pytest.approx(0.2) and shader["Base Color"] == pytest.approx((0.1, 0.2, 0.3, 1.0))
    assert read.structural


def test_an_unsupported_node_is_named_once_and_the_rest_of_the_graph_is_kept(addon):
    material, nodes, links, principled = _material("Wired")
    math = nodes.new("ShaderNodeMath")
    math.operation = "MULTIPLY"
    for k in range(2):  # two of them: still one message
        wireframe = nodes.new("ShaderNodeWireframe")
        wireframe.outputs["Fac"].default_value = 0.0
        links.new(wireframe.outputs["Fac"], math.inputs[k])
    links.new(math.outputs[0], principled.inputs["Roughness"])

    with addon.blender_adapter.messages.collecting() as told:
        graph = _read(addon, material).graph
    assert told == ["Wired: Wireframe nodes are not supported; their outputs take their default values"]
    assert [n.kind for n in graph.nodes] == ["MATH", "BSDF_PRINCIPLED"]
    assert graph.nodes[0].inputs == {"Value": 0.0, "Value_001": 0.0}
    assert graph.nodes[1].inputs["Roughness"] == Link(0, "Value")


def test_only_nodes_that_reach_the_active_output_are_read_in_evaluation_order(addon):
    material, nodes, links, principled = _material()
    nodes.new("ShaderNodeTexMagic")  # reaches nothing
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "OVERLAY"
    gradient = nodes.new("ShaderNodeTexGradient")
    links.new(gradient.outputs["Color"], _socket(mix.inputs, "A_Color"))
    links.new(gradient.outputs["Fac"], _socket(mix.inputs, "Factor_Float"))
    links.new(_socket(mix.outputs, "Result_Color"), principled.inputs["Base Color"])
    bump = nodes.new("ShaderNodeBump")
    links.new(gradient.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], principled.inputs["Normal"])
    displacement = nodes.new("ShaderNodeDisplacement")
    links.new(displacement.outputs[0], nodes["Material Output"].inputs["Displacement"])

    graph = _read(addon, material).graph
    assert [n.kind for n in graph.nodes] == ["TEX_GRADIENT", "MIX", "BUMP", "BSDF_PRINCIPLED"]
    graph.validate()
    mix_node = graph.nodes[1]
    assert mix_node.settings["blend_type"] == "OVERLAY" and mix_node.settings["data_type"] == "RGBA"
    assert set(mix_node.inputs) == {"Factor_Float", "A_Color", "B_Color"}  # the other types' sockets are unavailable
    assert graph.displacement is None  # Displacement nodes are not supported: reported, left out
    assert "Vector" not in graph.nodes[0].inputs  # unlinked: Blender's implicit coordinates
    assert "Normal" not in graph.nodes[2].inputs and graph.nodes[3].inputs["Normal"] == Link(2, "Normal")


def test_a_color_ramp_is_baked_as_cycles_bakes_it_from_colorramp_evaluate(addon):
    material, nodes, links, principled = _material()
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "EASE"
    ramp.color_ramp.elements[0].position = 0.2
    ramp.color_ramp.elements[0].color = (1.0, 0.0, 0.0, 0.5)
    middle = ramp.color_ramp.elements.new(0.45)
    middle.color = (0.0, 0.7, 0.1, 1.0)
    links.new(ramp.outputs["Color"], principled.inputs["Base Color"])

    settings = _only(_read(addon, material).graph, "VALTORGB").settings
    expected = [tuple(ramp.color_ramp.evaluate(i / RAMP_TABLE_SIZE)) for i in range(RAMP_TABLE_SIZE + 1)]
    np.testing.assert_array_equal(np.array(settings["color_ramp"], np.float32), np.array(expected, np.float32))
    assert settings["color_ramp_interpolation"] == "EASE"
    assert settings["color_ramp_color_mode"] == "RGB" and settings["color_ramp_hue_interpolation"] == "NEAR"
    assert [p for p, _ in settings["color_ramp_elements"]] == pytest.approx([0.2, 0.45, 1.0])


def test_rgb_curves_are_baked_over_the_points_range_with_the_combined_curve_first(addon):
    material, nodes, links, principled = _material()
    curves = nodes.new("ShaderNodeRGBCurve")
    mapping = curves.mapping
    mapping.use_clip = False
    mapping.curves[3].points.new(0.3, 0.6)  # the combined curve
    mapping.curves[0].points.new(0.5, 0.2)  # red
    mapping.curves[1].points.new(1.5, 1.25)  # green and blue reach past [0, 1]: the range grows
    mapping.curves[2].points.new(-0.25, 0.1)
    mapping.extend = "EXTRAPOLATED"
    mapping.update()
    links.new(curves.outputs["Color"], principled.inputs["Base Color"])

    settings = _only(_read(addon, material).graph, "CURVE_RGB").settings
    assert settings["curve_min_x"] == -0.25 and settings["curve_max_x"] == 1.5 and settings["curve_extrapolate"]
    c, r, g, b = mapping.curves[3], mapping.curves[0], mapping.curves[1], mapping.curves[2]
    steps = np.arange(RAMP_TABLE_SIZE + 1, dtype=np.float32) / np.float32(RAMP_TABLE_SIZE)
    t = np.float32(-0.25) + steps * np.float32(1.75)
    expected = [[mapping.evaluate(k, mapping.evaluate(c, float(x))) for k in (r, g, b)] for x in t]
    np.testing.assert_array_equal(np.array(settings["curve_table"], np.float32), np.array(expected, np.float32))


def test_an_image_texture_gives_its_layer_in_the_material_tables_textures_and_its_settings(addon):
    import bpy
    image = bpy.data.images.new("Tiles", 4, 2)
    image.alpha_mode = "PREMUL"
    material, nodes, links, principled = _material()
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.extension = "MIRROR"
    texture.interpolation = "Closest"
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = "Second"
    links.new(uv.outputs["UV"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], principled.inputs["Base Color"])

    other, other_nodes, other_links, other_principled = _material("Other")  # a graph with another image first
    other_texture = other_nodes.new("ShaderNodeTexImage")
    other_texture.image = bpy.data.images.new("Bricks", 8, 8)
    other_links.new(other_texture.outputs["Alpha"], other_principled.inputs["Roughness"])

    materials = addon.blender_adapter.export.materials
    builder = materials.MaterialTableBuilder()
    plain = bpy.data.materials.new("Plain")
    assert [builder.index_of(m) for m in (plain, other, material)] == [1, 2, 3]
    table = builder.table()
    assert table.node_graphs[:2] == [None, None]
    graph = table.node_graphs[3]
    settings = _only(graph, "TEX_IMAGE").settings
    pixels = addon.blender_adapter.export.images.image_pixels
    assert settings["texture"] == 1 and table.textures[1] is pixels(image) and table.textures[1].shape == (2, 4, 4)
    assert _only(table.node_graphs[2], "TEX_IMAGE").settings["texture"] == 0
    assert table.textures[0] is pixels(other_texture.image)
    assert (settings["extension"], settings["interpolation"], settings["projection"]) == ("MIRROR", "Closest", "FLAT")
    assert settings["alpha_mode"] == "PREMUL"
    assert _only(graph, "UVMAP").settings["uv_map"] == "Second"


def test_a_plain_principled_material_keeps_the_rows_and_no_graph(addon):
    import bpy
    material, *_ = _material()
    materials = addon.blender_adapter.export.materials
    row = materials.material_params(material)
    assert "node_graph" not in row
    builder = materials.MaterialTableBuilder()
    builder.index_of(material)
    assert builder.table().node_graphs is None
    assert bpy.data.materials  # the factory scene's material too
    assert "node_graph" not in materials.material_params(bpy.data.materials["Material"])


def test_a_gltf_style_material_keeps_its_rows_unchanged_and_warns_nothing(addon):
    """Images into Base Color (times a constant through a Multiply mix), a packed
    metallic-roughness image through Separate Color and glTF's factor Multiply, and a
    Normal Map: what the rows hold exactly."""
    import bpy
    image = bpy.data.images.new("Albedo", 4, 4)
    packed = bpy.data.images.new("MetalRough", 4, 4)
    normal_image = bpy.data.images.new("Normal", 4, 4)
    material, nodes, links, principled = _material("Asset")
    albedo = nodes.new("ShaderNodeTexImage")
    albedo.image = image
    factor = nodes.new("ShaderNodeMix")
    factor.data_type = "RGBA"
    factor.blend_type = "MULTIPLY"
    _socket(factor.inputs, "Factor_Float").default_value = 1.0
    _socket(factor.inputs, "B_Color").default_value = (0.5, 0.25, 1.0, 1.0)
    links.new(albedo.outputs["Color"], _socket(factor.inputs, "A_Color"))
    links.new(_socket(factor.outputs, "Result_Color"), principled.inputs["Base Color"])
    metal_rough = nodes.new("ShaderNodeTexImage")
    metal_rough.image = packed
    split = nodes.new("ShaderNodeSeparateColor")
    links.new(metal_rough.outputs["Color"], split.inputs["Color"])
    links.new(split.outputs["Green"], principled.inputs["Roughness"])
    metallic_factor = nodes.new("ShaderNodeMath")
    metallic_factor.operation = "MULTIPLY"
    links.new(split.outputs["Blue"], metallic_factor.inputs[0])
    metallic_factor.inputs[1].default_value = 0.0
    links.new(metallic_factor.outputs[0], principled.inputs["Metallic"])
    principled.inputs["Metallic"].default_value = 0.7  # what a factor of 0 hides
    normal_map = nodes.new("ShaderNodeNormalMap")
    normal_map.uv_map = "UVMap"
    normals = nodes.new("ShaderNodeTexImage")
    normals.image = normal_image
    links.new(normals.outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], principled.inputs["Normal"])

    materials = addon.blender_adapter.export.materials
    with addon.blender_adapter.messages.collecting() as told:
        row = materials.material_params(material)
    assert told == [] and "node_graph" not in row
    assert row["base_color"] == pytest.approx((0.5, 0.25, 1.0))
    assert row["base_color_texture"] is not None and row["roughness_texture"] is not None
    assert row["roughness_channel"] == 1 and "metallic_texture" not in row and row["reflectivity"] == 0.0
    assert row["normal_texture"] is not None

    metallic_factor.inputs[1].default_value = 0.5  # a factor the rows cannot hold: the graph
    with addon.blender_adapter.messages.collecting() as told:
        row = materials.material_params(material)
    # Mix, Separate Color and Math are evaluated by the node program: nothing to name.
    assert told == [] and type(row["node_graph"]).__name__ == "ShaderGraph"


def test_a_graph_material_carries_its_graph_a_stand_in_row_and_no_fallback_warnings(addon):
    material, nodes, links, principled = _material("Noisy")
    noise = nodes.new("ShaderNodeTexNoise")
    links.new(noise.outputs["Color"], principled.inputs["Base Color"])
    principled.inputs["Metallic"].default_value = 1.0
    principled.inputs["Roughness"].default_value = 0.125

    materials = addon.blender_adapter.export.materials
    with addon.blender_adapter.messages.collecting() as told:
        builder = materials.MaterialTableBuilder()
        builder.index_of(material)
        table = builder.table()
    assert told == []
    assert table.node_graphs[0] is None and [n.kind for n in table.node_graphs[1].nodes] == ["TEX_NOISE", "BSDF_PRINCIPLED"]
    assert table.reflectivity[1] == 1.0 and table.roughness[1] == 0.125  # the Principled's constants
    assert table.base_color_texture[1] == -1


@pytest.mark.skipif(not (pytest.importorskip("conftest").SHARED_SCENES / "chess_polyhaven").exists(),
                    reason="the shared Chess scene is not here")
def test_the_chess_sets_materials_keep_the_rows_and_no_graphs(addon):
    import bpy
    from conftest import SHARED_SCENES
    bpy.ops.import_scene.gltf(filepath=str(SHARED_SCENES / "chess_polyhaven" / "chess_set_2k.gltf"))
    materials = addon.blender_adapter.export.materials
    reads = [_read(addon, m, images=False) for m in bpy.data.materials if m.name.startswith("chess_set")]
    assert len(reads) == 3
    for read in reads:
        assert not read.structural and addon.blender_adapter.export.graph_rows.rows_hold(read.graph)
    with addon.blender_adapter.messages.collecting() as told:
        rows = [materials.material_params(m, textures=False) for m in bpy.data.materials]
    assert told == [] and all("node_graph" not in row for row in rows)


def test_a_node_the_compiler_does_not_evaluate_yet_is_named_once_and_the_graph_kept(addon, monkeypatch):
    """A kind the reader passes on but the interpreter has no case for (materials._graph_row)
    is told by name, once per render, never dropped silently; the rest of the graph renders.
    The Bump stands for such a kind here: it is taken out of the compiler's table for the test
    (the interpreter evaluates it), so the test does not depend on what is still missing."""
    monkeypatch.delitem(addon.blender_adapter.export.materials.NODE_SPECS, "BUMP")
    material, nodes, links, principled = _material("Bumpy")
    noise = nodes.new("ShaderNodeTexNoise")
    bump = nodes.new("ShaderNodeBump")
    links.new(noise.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], principled.inputs["Normal"])
    links.new(noise.outputs["Color"], principled.inputs["Base Color"])
    materials = addon.blender_adapter.export.materials
    with addon.blender_adapter.messages.collecting() as told:
        row = materials.material_params(material)
        materials.material_params(material)
    assert told == ["Bumpy: node 'Bump' (BUMP) is not evaluated yet; its outputs take their default values"]
    assert {n.kind for n in row["node_graph"].nodes} >= {"TEX_NOISE", "BSDF_PRINCIPLED"}
