# SPDX-License-Identifier: GPL-3.0-or-later
"""The World: its Background colour and strength, or an equirectangular environment."""
from __future__ import annotations

from ...hybrid_engine.scene.data import Sky
from . import tell
from .images import environment_pixels
from .materials import socket_value, surface_node

# Blender's default world colour when a scene has no World (DNA_world_defaults.h).
DEFAULT_WORLD_COLOR = (0.05, 0.05, 0.05)


def extract_sky(world) -> Sky:
    """The World background: Background node colour and strength, or an equirectangular
    Environment Texture linked to its Color; ``world.color`` when there is no Background
    node; Blender's default dark grey when the scene has no World."""
    if world is None:
        return Sky(color=DEFAULT_WORLD_COLOR, strength=1.0)
    node = surface_node(world.node_tree)
    if node is None or node.type != "BACKGROUND":
        return Sky(color=tuple(world.color), strength=1.0)
    color = socket_value(node, "Color", (0.05, 0.05, 0.05, 1.0))[:3]
    strength = float(socket_value(node, "Strength", 1.0))
    environment = None
    color_socket = node.inputs.get("Color")
    if color_socket is not None and color_socket.is_linked:
        source = color_socket.links[0].from_node
        if source.type == "TEX_ENVIRONMENT" and source.image is not None:
            if source.projection == "EQUIRECTANGULAR":
                environment = environment_pixels(source.image)
            else:
                tell("World: environment projection %s is not supported; the background colour "
                      "is used", source.projection)
    return Sky(color=color, strength=strength, environment=environment)
