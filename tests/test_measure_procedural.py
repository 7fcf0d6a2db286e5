# SPDX-License-Identifier: GPL-3.0-or-later
"""The procedural scene's bake (scripts/measure_procedural.py): the baked variant must hand
each material's Principled the colour the procedural gave it, or the baked variant measures
the bake instead of the renderer's image path.

Oracle: the colour set on the material itself, a Principled's Base Color (unlinked, and
linked from a node) and the Diffuse BSDF's Color under the lacquer's Mix Shader by a
Fresnel. Cycles' DIFFUSE COLOR bake gives none of them: it is the diffuse closure's weight,
which the Principled's specular layer and the Mix Shader's factor both lower.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import load_addon

BAKE_SIZE = 8  # a plane's UVs cover the whole image: every texel is baked
# Linear float texels of a flat colour: the bake's anti-aliasing adds no spread. The darkening
# this guards against is one minus the Fresnel reflectance of IOR 1.5 along the normal.
COLOUR_TOLERANCE = 0.005


@pytest.fixture
def procedural():
    """The script's module on a factory-empty Blender session."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    load_addon()
    import measure_procedural

    return measure_procedural


def _plane(material, x: float):
    import bpy

    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(x, 0.0, 0.0))
    obj = bpy.context.object
    obj.data.materials.append(material)
    return obj


def _baked_colour(obj) -> np.ndarray:
    """The mean RGB of the image the baked Principled reads as its Base Color."""
    tree = obj.data.materials[0].node_tree
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    image = bsdf.inputs["Base Color"].links[0].from_node.image
    pixels = np.empty(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(-1, 4)[:, :3].mean(0)


def test_the_baked_colour_is_the_materials_base_colour_not_the_diffuse_closure_weight(procedural):
    import bpy

    plain, _nodes, _links, output = procedural._material("plain")
    bsdf = plain.node_tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.5, 0.3, 0.2, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.5
    plain.node_tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])

    linked, nodes, links, output = procedural._material("linked")
    rgb = nodes.new("ShaderNodeRGB")
    rgb.outputs["Color"].default_value = (0.2, 0.6, 0.4, 1.0)
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.8
    links.new(rgb.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])

    objects = {(0.5, 0.3, 0.2): _plane(plain, 0.0), (0.2, 0.6, 0.4): _plane(linked, 2.0),
               (0.6, 0.04, 0.03): _plane(procedural.lacquer_material(), 4.0)}
    procedural.bake_to_images(bpy.context.scene, BAKE_SIZE)
    for expected, obj in objects.items():
        np.testing.assert_allclose(_baked_colour(obj), expected, rtol=COLOUR_TOLERANCE,
                                   err_msg=f"{obj.name}: baked colour")
