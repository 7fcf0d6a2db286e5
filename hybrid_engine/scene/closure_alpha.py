# SPDX-License-Identifier: GPL-3.0-or-later
"""A material graph's closure alpha as a short program of its own: the part of the graph its
coverage depends on (issue 38, Deliver 4).

Blender's alpha is the closure's: a Transparent BSDF mixed in by a Mix Shader (whose factor a
texture, a Math chain or a Fresnel may give), Add Shaders of it, and a Principled BSDF's
Alpha, whatever feeds them. Coverage is tested wherever a surface is seen (the G-buffer and
the cube faces, the shadow maps, the BVH's any-hit traversal: gpu_shaders/include/alpha.glsl),
and most of those places must not run the whole graph: the any-hit test runs per candidate
triangle of every ray, the shadow maps per texel of every lamp. So the coverage is compiled
apart, by the same compiler (node_program.py), from a copy of the graph in which every
shader that cannot be transparent is a plain Diffuse of constant inputs and a Principled
keeps only its Alpha: the compiler then leaves out every node that feeds only colours,
roughnesses and normals, and the program is the alpha's nodes and the shader mix around
them. Its closure's alpha is the full program's (the same transparent weight, node_program.glsl).

A graph whose coverage is a constant 1 (no Transparent BSDF, no Principled Alpha below 1 or
linked) has no alpha program, and its material keeps the row's alpha (materials.py). Nor has
a graph whose coverage is a Principled Alpha read straight from an image (its alpha, a
channel, or a clip of either: ``row_reads_coverage``), as importers build every alpha-cut
card: the material row's alpha image gives that coverage exactly, for the price of one
texel fetch, where a program call would weigh on every shader that tests coverage.
"""
from __future__ import annotations

from .shader_graph import GraphNode, Link, ShaderGraph

_MIXES = ("MIX_SHADER", "ADD_SHADER")


def _shader_nodes(graph: ShaderGraph) -> list[int]:
    """The shader nodes the surface reaches through Mix and Add Shaders, surface first."""
    found: list[int] = []
    stack = [graph.surface.node] if graph.surface is not None else []
    while stack:
        index = stack.pop()
        if index in found or not 0 <= index < len(graph.nodes):
            continue
        found.append(index)
        node = graph.nodes[index]
        if node.kind in _MIXES:
            stack.extend(v.node for k, v in node.inputs.items() if k != "Fac" and isinstance(v, Link))
    return found


def _alpha_input_matters(node: GraphNode) -> bool:
    value = node.inputs.get("Alpha", 1.0)
    return isinstance(value, Link) or (isinstance(value, (int, float)) and float(value) < 1.0)


def has_closure_alpha(graph: ShaderGraph | None) -> bool:
    """True when ``graph``'s coverage is not a constant 1: a Transparent BSDF or a Principled
    Alpha below 1 (or linked) that the surface reaches."""
    if graph is None or graph.surface is None:
        return False
    for index in _shader_nodes(graph):
        node = graph.nodes[index]
        if node.kind == "BSDF_TRANSPARENT" or (node.kind == "BSDF_PRINCIPLED" and _alpha_input_matters(node)):
            return True
    return False


def closure_alpha_graph(graph: ShaderGraph | None) -> ShaderGraph | None:
    """The copy of ``graph`` whose program computes only its closure's alpha (module
    docstring), or None when its coverage is a constant 1. Node indices are kept, so links
    and names stay the artist's."""
    if not has_closure_alpha(graph):
        return None
    nodes = list(graph.nodes)
    for index in _shader_nodes(graph):
        node = graph.nodes[index]
        if node.kind in _MIXES or node.kind == "BSDF_TRANSPARENT":
            continue
        if node.kind == "BSDF_PRINCIPLED":
            kept = {"Alpha": node.inputs["Alpha"]} if "Alpha" in node.inputs else {}
            nodes[index] = GraphNode(node.kind, node.name, dict(node.settings), kept)
        else:  # opaque: a Diffuse of constant inputs (weight 1, transparent weight 0)
            nodes[index] = GraphNode("BSDF_DIFFUSE", node.name, {}, {})
    return ShaderGraph(nodes, _output_of(graph, nodes), None)


def _output_of(graph: ShaderGraph, nodes: list[GraphNode]) -> Link:
    """The surface link, renamed where its node became a Diffuse (whose output is "BSDF")."""
    surface = graph.surface
    kind = nodes[surface.node].kind
    if kind == "BSDF_DIFFUSE" and graph.nodes[surface.node].kind != "BSDF_DIFFUSE":
        return Link(surface.node, "BSDF")
    return surface


# -- coverage the material row reads: an image's value through these, as the Blender adapter
# reads it (blender_adapter/export/alpha.py)
_IMAGE_DEFAULTS = {"projection": "FLAT", "extension": "REPEAT", "interpolation": "Linear"}


def _link_node(graph: ShaderGraph, value) -> GraphNode | None:
    if not isinstance(value, Link) or not 0 <= value.node < len(graph.nodes):
        return None
    return graph.nodes[value.node]


def _plain_image(graph: ShaderGraph, value) -> bool:
    """True when ``value`` is an Image Texture's Alpha or Color (or one channel of its Color
    through a Separate Color in RGB mode) at the mesh's UV, tiled and filtered as the row's
    alpha image is."""
    node = _link_node(graph, value)
    if node is not None and node.kind == "SEPARATE_COLOR":
        if node.settings.get("mode", "RGB") != "RGB" or value.output not in ("Red", "Green", "Blue"):
            return False
        value = node.inputs.get("Color")
        node = _link_node(graph, value)
        if node is None or value.output != "Color":
            return False
    if node is None or node.kind != "TEX_IMAGE" or int(node.settings.get("texture", -1)) < 0:
        return False
    if "Vector" in node.inputs:
        return False
    return all(node.settings.get(k, v) == v for k, v in _IMAGE_DEFAULTS.items())


def _constant(value) -> bool:
    return isinstance(value, (int, float))


def _image_or_clip(graph: ShaderGraph, value) -> bool:
    """``_plain_image``, or one through a threshold: ``1 - (x < c)``, ``x > c``, Round."""
    if _plain_image(graph, value):
        return True
    node = _link_node(graph, value)
    if node is None or node.kind != "MATH" or node.settings.get("use_clamp", 0):
        return False
    operation = node.settings.get("operation", "ADD")
    a, b = node.inputs.get("Value", 0.5), node.inputs.get("Value_001", 0.5)
    if operation == "SUBTRACT" and _constant(a) and float(a) == 1.0:
        inner = _link_node(graph, b)
        return (inner is not None and inner.kind == "MATH" and not inner.settings.get("use_clamp", 0)
                and inner.settings.get("operation") == "LESS_THAN"
                and _plain_image(graph, inner.inputs.get("Value")) and _constant(inner.inputs.get("Value_001", 0.5)))
    if operation == "GREATER_THAN":
        return _plain_image(graph, a) and _constant(b)
    return operation == "ROUND" and _plain_image(graph, a)


def row_reads_coverage(graph: ShaderGraph | None) -> bool:
    """True when ``graph``'s coverage is its surface Principled BSDF's Alpha read from an image
    (``_image_or_clip``), which the material row's alpha image holds as it is: such a graph
    needs no alpha program (module docstring)."""
    if graph is None or graph.surface is None or not 0 <= graph.surface.node < len(graph.nodes):
        return False
    surface = graph.nodes[graph.surface.node]
    return surface.kind == "BSDF_PRINCIPLED" and _image_or_clip(graph, surface.inputs.get("Alpha"))
# -- end of coverage the material row reads
