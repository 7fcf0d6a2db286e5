# SPDX-License-Identifier: GPL-3.0-or-later
"""The World: its Background colour and strength, an equirectangular environment, or its
node graph (baked on the GPU per direction: hybrid_engine/passes/lighting/world_bake.py).

Two shapes of World are read as plain values, because they need no bake and keep every
texel of the image: a Background with constant Color and Strength, and a Background whose
Color is an equirectangular Environment Texture at its default Vector. Every other World
(a Sky Texture, an environment through Mapping or Mix, a mirror ball, a linked Strength, a
Mix Shader of Backgrounds) is read as a graph by the materials' reader (node_graph.py), so
that groups, reroutes and muted nodes resolve as Blender resolves them; a node it does not
evaluate is named once, and the rest of the World still renders. A Sky Texture's sun disc
becomes a sun lamp where its light reaches the World unchanged (hybrid_engine/scene/sky_sun.py);
elsewhere the artist is told that it gives no light.
"""
from __future__ import annotations

from ...hybrid_engine.scene.data import Sky
from ...hybrid_engine.scene.node_codes import SKY_MODELS_EVALUATED
from ...hybrid_engine.scene.node_program import NODE_SPECS
from ...hybrid_engine.scene.sky_sun import disc_irradiance, sun_rows
from . import tell
from .images import environment_pixels
from .materials import socket_value, surface_node
from .node_graph import read_node_graph

# Blender's default world colour when a scene has no World (DNA_world_defaults.h).
DEFAULT_WORLD_COLOR = (0.05, 0.05, 0.05)


def extract_sky(world) -> Sky:
    """The World background (see the module docstring for which shape is read how);
    ``world.color`` without a node tree; Blender's default dark grey without a World."""
    if world is None:
        return Sky(color=DEFAULT_WORLD_COLOR, strength=1.0)
    tree = getattr(world, "node_tree", None)
    node = surface_node(tree)
    if tree is None or (node is None and tree.get_output_node("EEVEE") is None):
        return Sky(color=tuple(world.color), strength=1.0)
    plain = _plain_sky(node)
    if plain is not None:
        return plain
    read = read_node_graph(world)
    if read is None:
        return Sky(color=tuple(world.color), strength=1.0)
    for kind in sorted({n.kind for n in read.graph.nodes} - set(NODE_SPECS)):
        names = [n.name for n in read.graph.nodes if n.kind == kind]
        tell("World %s: node %r (%s) is not evaluated yet; its outputs take their default values",
             world.name, names[0], kind)
    for n in read.graph.nodes:
        if n.kind == "TEX_SKY" and str(n.settings.get("sky_type")) not in SKY_MODELS_EVALUATED:
            tell("World %s: Sky Texture %r: the %s sky model is not evaluated (renders black)", world.name,
                 n.name, str(n.settings.get("sky_type")).replace("_", " ").title())
    discs = [n for n in read.graph.nodes if n.kind == "TEX_SKY" and n.settings.get("sun_disc", True)
             and str(n.settings.get("sky_type")) in ("MULTIPLE_SCATTERING", "SINGLE_SCATTERING")]
    if discs and not sun_rows(read.graph) and any(disc_irradiance(n.settings).any() for n in discs):
        tell("World %s: Sky Texture %r: its sun disc lights the scene only when its Color feeds the "
             "Background's Color directly (Vector unlinked, Strength not linked); here it gives no light",
             world.name, discs[0].name)
    return Sky(color=(0.0, 0.0, 0.0), strength=1.0, graph=read.graph, images=read.images)


def _plain_sky(node) -> Sky | None:
    """The Sky of a Background with constant inputs or a plain equirectangular image; None
    for every other World (read as a graph)."""
    if node is None or node.type != "BACKGROUND" or node.mute:
        return None
    strength_socket = node.inputs.get("Strength")
    if strength_socket is not None and strength_socket.is_linked:
        return None
    color = socket_value(node, "Color", (0.05, 0.05, 0.05, 1.0))[:3]
    strength = float(socket_value(node, "Strength", 1.0))
    color_socket = node.inputs.get("Color")
    if color_socket is None or not color_socket.is_linked:
        return Sky(color=color, strength=strength)
    link = color_socket.links[0]
    source = link.from_node
    if (source.type == "TEX_ENVIRONMENT" and not source.mute and not link.is_muted and source.image is not None
            and source.projection == "EQUIRECTANGULAR" and not source.inputs["Vector"].is_linked):
        return Sky(color=color, strength=strength, environment=environment_pixels(source.image))
    return None
