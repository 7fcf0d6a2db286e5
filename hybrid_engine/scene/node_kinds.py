# SPDX-License-Identifier: GPL-3.0-or-later
"""The shader node kinds the core evaluates: one list that the Blender adapter (which names
every other node to the artist) and the node-program compiler share.

Kinds are Blender's node ``type`` strings (``ShaderGraph`` uses them as ``GraphNode.kind``).
The set is the issue's coverage for surfaces (EEVEE's, less what a rasterising hybrid cannot
have): a node outside it is reported once by name and its outputs take their default
values, so the material still renders with the rest of its graph. Structural nodes (groups,
reroutes, Group Input/Output, frames) never reach the core: the adapter resolves them.
"""
from __future__ import annotations

INPUT_KINDS = frozenset({
    "TEX_COORD", "UVMAP", "VERTEX_COLOR", "ATTRIBUTE", "NEW_GEOMETRY", "OBJECT_INFO", "FRESNEL",
    "LAYER_WEIGHT", "VALUE", "RGB", "LIGHT_PATH",
})
TEXTURE_KINDS = frozenset({
    "TEX_IMAGE", "TEX_NOISE", "TEX_VORONOI", "TEX_WAVE", "TEX_CHECKER", "TEX_BRICK", "TEX_GRADIENT",
    "TEX_MAGIC", "TEX_WHITE_NOISE",
})
COLOUR_VECTOR_KINDS = frozenset({
    "MIX", "MIX_RGB", "VALTORGB", "CURVE_RGB", "CURVE_VEC", "CURVE_FLOAT", "HUE_SAT", "INVERT", "GAMMA",
    "BRIGHTCONTRAST", "MATH", "VECT_MATH", "MAP_RANGE", "CLAMP", "SEPARATE_COLOR", "COMBINE_COLOR",
    "SEPXYZ", "COMBXYZ", "MAPPING", "VECTOR_ROTATE", "NORMAL_MAP", "BUMP",
})
SHADER_KINDS = frozenset({
    "MIX_SHADER", "ADD_SHADER", "BSDF_PRINCIPLED", "BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_GLASS",
    "BSDF_REFRACTION", "BSDF_TRANSPARENT", "EMISSION",
})
# The World's own nodes: its Background graph is baked into the environment per direction
# (hybrid_engine/passes/lighting/world_bake.py); in a material they evaluate as in a World.
WORLD_KINDS = frozenset({"BACKGROUND", "TEX_ENVIRONMENT", "TEX_SKY"})
SUPPORTED_KINDS = WORLD_KINDS | INPUT_KINDS | TEXTURE_KINDS | COLOUR_VECTOR_KINDS | SHADER_KINDS
