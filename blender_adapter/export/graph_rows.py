# SPDX-License-Identifier: GPL-3.0-or-later
"""Which material node graphs the fixed material rows hold exactly, and the rows' stand-in
for the others.

The rows (materials.py, hybrid_engine/scene/data.py ``MaterialTable``) are the fast path: a
Principled BSDF (or a lone Diffuse, Glossy, Glass or Emission shader) whose colours come from
constants or an image (directly, or times a constant through a Multiply mix, as glTF imports
a base colour factor), whose Roughness and Metallic come from an image or one channel of it
(or glTF's factor Multiply of it by 0 or 1),
and whose Normal from a tangent-space Normal Map of an image (its UV map name is not read:
the rows assume the mesh's render UV map, as glTF assets have one). Chess sets and glTF assets are
made of nothing else; they keep the rows and never reach the node program. Any other graph
is handed to the core whole (``MaterialTable.node_graphs``), and its row is only what a
renderer without node programs shows: the constants of the first shader it finds.

Everything here works on the flat ``ShaderGraph`` and the rows, so groups, reroutes and
muted nodes are already resolved; no bpy.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...hybrid_engine.scene.data import MaterialTable
from ...hybrid_engine.scene.shader_graph import GraphNode, Link, ShaderGraph

# Surface shaders the rows read, and per shader which linked inputs they follow exactly.
_COLOUR_LINKS = {
    "BSDF_PRINCIPLED": ("Base Color", "Emission Color"),
    "EMISSION": ("Color",),
    "BSDF_DIFFUSE": ("Color",),
    "BSDF_GLOSSY": ("Color",),
    "BSDF_GLASS": ("Color",),
}
_VALUE_LINKS = ("Roughness", "Metallic")  # Principled only
_SHADER_OUTPUT = {"BSDF_PRINCIPLED": "BSDF", "EMISSION": "Emission", "BSDF_DIFFUSE": "BSDF",
                  "BSDF_GLOSSY": "BSDF", "BSDF_GLASS": "BSDF"}


def rows_hold(graph: ShaderGraph) -> bool:
    """True when the material rows reproduce ``graph`` exactly (module docstring)."""
    if graph.surface is None or graph.displacement is not None:
        return False
    shader = graph.nodes[graph.surface.node]
    if _SHADER_OUTPUT.get(shader.kind) != graph.surface.output:
        return False
    for socket, value in shader.inputs.items():
        if not isinstance(value, Link):
            continue
        if socket in _COLOUR_LINKS[shader.kind]:
            ok = _image_colour(graph, value) or _image_times_constant(graph, value)
        elif shader.kind == "BSDF_PRINCIPLED" and socket in _VALUE_LINKS:
            ok = _image_value(graph, value) or _gltf_factor(graph, value)
        elif shader.kind == "BSDF_PRINCIPLED" and socket == "Normal":
            ok = _normal_map(graph, value)
        else:
            ok = False
        if not ok:
            return False
    return True


def _image_colour(graph: ShaderGraph, link: Link) -> bool:
    """An Image Texture's Color, sampled as the rows sample it: repeated, flat, filtered
    linearly (Closest and Cubic take the node program's fetches), on the render UV map."""
    node = graph.nodes[link.node]
    if node.kind != "TEX_IMAGE" or link.output != "Color":
        return False
    if node.settings.get("extension") != "REPEAT" or node.settings.get("projection") != "FLAT":
        return False
    if node.settings.get("interpolation", "Linear") != "Linear":
        return False
    vector = node.inputs.get("Vector")
    if not isinstance(vector, Link):
        return True
    source = graph.nodes[vector.node]
    return ((source.kind == "UVMAP" and not source.settings.get("uv_map") and not source.settings.get("from_instancer"))
            or (source.kind == "TEX_COORD" and vector.output == "UV" and not source.settings.get("from_instancer")))


def _image_times_constant(graph: ShaderGraph, link: Link) -> bool:
    """A Multiply mix of an image and a constant colour with a constant factor: the image in
    A at any factor, in B at factor 1 (materials._color_input)."""
    node = graph.nodes[link.node]
    if node.kind == "MIX" and node.settings.get("data_type") == "RGBA" and link.output == "Result_Color":
        factor, a, b = (node.inputs.get(k) for k in ("Factor_Float", "A_Color", "B_Color"))
        clamped = node.settings.get("clamp_result", False)
    elif node.kind == "MIX_RGB" and link.output == "Color":
        factor, a, b = (node.inputs.get(k) for k in ("Fac", "Color1", "Color2"))
        clamped = node.settings.get("use_clamp", False)
    else:
        return False
    if node.settings.get("blend_type") != "MULTIPLY" or clamped or not isinstance(factor, float):
        return False
    if isinstance(a, Link) and not isinstance(b, Link):
        return _image_colour(graph, a)
    if isinstance(b, Link) and not isinstance(a, Link):
        return factor == 1.0 and _image_colour(graph, b)
    return False


def _image_value(graph: ShaderGraph, link: Link) -> bool:
    return _image_colour(graph, link) or _image_channel(graph, link)


def _gltf_factor(graph: ShaderGraph, link: Link) -> bool:
    """A Multiply Math node of an image value and a constant 0 or 1, as glTF imports a
    metallic or roughness factor: 0 is the constant 0, 1 the image (materials._gltf_factor)."""
    node = graph.nodes[link.node]
    if node.kind != "MATH" or node.settings.get("operation") != "MULTIPLY" or node.settings.get("use_clamp"):
        return False
    first, second = node.inputs.get("Value"), node.inputs.get("Value_001")
    for constant, other in ((first, second), (second, first)):
        if constant in (0.0, 1.0) and isinstance(other, Link):
            return _image_value(graph, other)
    return False


def _image_channel(graph: ShaderGraph, link: Link) -> bool:
    """One channel of an image through an RGB Separate Color (a glTF's packed image)."""
    node = graph.nodes[link.node]
    if node.kind != "SEPARATE_COLOR" or node.settings.get("mode") != "RGB" or link.output not in ("Red", "Green", "Blue"):
        return False
    colour = node.inputs.get("Color")
    return isinstance(colour, Link) and _image_colour(graph, colour)


def _normal_map(graph: ShaderGraph, link: Link) -> bool:
    """A tangent-space Normal Map of an image, of constant strength."""
    node = graph.nodes[link.node]
    if node.kind != "NORMAL_MAP" or node.settings.get("space") != "TANGENT":
        return False
    colour, strength = node.inputs.get("Color"), node.inputs.get("Strength", 1.0)
    return isinstance(colour, Link) and _image_colour(graph, colour) and not isinstance(strength, Link)


# -- the rows' stand-in for a graph they cannot hold -----------------------------------------

_SHADERS = frozenset(_SHADER_OUTPUT)


def stand_in_inputs(graph: ShaderGraph) -> dict:
    """``principled_to_params`` keyword arguments from the constants of the shader nearest
    the output (breadth first through Mix and Add Shaders and whatever feeds them); linked
    inputs take Blender's defaults. Empty when the graph has no such shader."""
    if graph.surface is None:
        return {}
    seen, queue = {graph.surface.node}, [graph.surface.node]
    while queue:
        node = graph.nodes[queue.pop(0)]
        if node.kind in _SHADERS:
            return _shader_inputs(node)
        for value in node.inputs.values():
            if isinstance(value, Link) and value.node not in seen:
                seen.add(value.node)
                queue.append(value.node)
    return {}


def _shader_inputs(node: GraphNode) -> dict:
    def const(name: str, default):
        value = node.inputs.get(name)
        if value is None or isinstance(value, Link):
            return default
        return tuple(value[:3]) if isinstance(value, tuple) else float(value)

    if node.kind == "BSDF_PRINCIPLED":
        return dict(base_color=const("Base Color", (0.8, 0.8, 0.8)), metallic=const("Metallic", 0.0),
                    roughness=const("Roughness", 0.5), transmission=const("Transmission Weight", 0.0),
                    ior=const("IOR", 1.5), specular_level=const("Specular IOR Level", 0.5),
                    emission=const("Emission Color", (1.0, 1.0, 1.0)),
                    emission_strength=const("Emission Strength", 0.0))
    if node.kind == "EMISSION":
        return dict(base_color=(0.0, 0.0, 0.0), emission=const("Color", (1.0, 1.0, 1.0)),
                    emission_strength=const("Strength", 1.0))
    base = const("Color", (0.8, 0.8, 0.8))
    if node.kind == "BSDF_DIFFUSE":
        return dict(base_color=base, roughness=1.0, specular_level=0.0)
    if node.kind == "BSDF_GLOSSY":
        return dict(base_color=base, metallic=1.0, roughness=const("Roughness", 0.5))
    return dict(base_color=base, transmission=1.0, roughness=const("Roughness", 0.0), ior=const("IOR", 1.5))


# -- the table -------------------------------------------------------------------------------

def table_with_graphs(rows: list[dict]) -> MaterialTable:
    """``MaterialTable.from_rows`` plus each row's ``node_graph``: the images a graph reads
    join the texture list (once per array, shared with the rows' own images) and its Image
    Textures' ``texture`` becomes the layer there. No graph at all: ``node_graphs`` None."""
    graphs = [row.get("node_graph") for row in rows]
    if all(graph is None for graph in graphs):
        return MaterialTable.from_rows(rows)
    textures: list[np.ndarray] = []
    layer_of: dict[int, int] = {}
    for row in rows:
        for pixels in row.get("node_graph_textures", ()):
            if id(pixels) not in layer_of:
                layer_of[id(pixels)] = len(textures)
                textures.append(pixels)
    table = MaterialTable.from_rows(rows, textures=textures)
    placed = [None if graph is None else _with_layers(graph, row.get("node_graph_textures", ()), layer_of)
              for graph, row in zip(graphs, rows)]
    return dataclasses.replace(table, node_graphs=placed)


def _with_layers(graph: ShaderGraph, images, layer_of: dict[int, int]) -> ShaderGraph:
    """A copy of ``graph`` whose ``texture`` settings index the table's texture list."""
    nodes = []
    for node in graph.nodes:
        texture = node.settings.get("texture")
        if isinstance(texture, int) and texture >= 0:
            node = GraphNode(node.kind, node.name, {**node.settings, "texture": layer_of[id(images[texture])]},
                             node.inputs)
        nodes.append(node)
    return ShaderGraph(nodes, graph.surface, graph.displacement)
