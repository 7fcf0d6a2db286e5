# SPDX-License-Identifier: GPL-3.0-or-later
"""Mapping and Vector Rotate (gpu_shaders/include/nodes/mapping.glsl) against Cycles: every
vector type with a rotation on all three axes and scales that change sign and reach zero,
and every rotation type, inverted and not, about an off-origin centre."""
from __future__ import annotations

from node_grid import Case, by_id, check_cases, glsl_affine, glsl_vec3

MAPPING_CODES = {"POINT": 0, "TEXTURE": 1, "VECTOR": 2, "NORMAL": 3}
VECTOR_ROTATE_CODES = {"AXIS_ANGLE": 0, "X_AXIS": 1, "Y_AXIS": 2, "Z_AXIS": 3, "EULER_XYZ": 4}

VECTOR = ((0.125, 0.0, -2.0), (0.0, 0.125, -2.0), (0.0625, -0.0625, 0.5))
LOCATION = ((0.0, 0.0, 0.5), (0.0, 0.0, -0.25), (0.03125, 0.0, 1.0))
ROTATION = ((0.0, 0.0625, -1.0), (0.0625, 0.0, 0.25), (0.03125, 0.03125, -0.75))
SCALE = ((0.0, 0.0625, -1.0), (0.0, 0.0, 2.0), (0.0625, 0.0, 0.5))      # x is 0 on row 16
CENTER = ((0.0, 0.0, 0.25), (0.0, 0.0, -0.5), (0.0, 0.0, 0.125))
AXIS = ((0.0625, 0.0, -1.0), (0.0, 0.0625, -1.0), (0.0, 0.0, 0.0))       # (0,0,0) at u=v=16
ANGLE = (0.0625, -0.0625, 0.5)


def _mapping_case(vector_type: str) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeMapping")
        for identifier, spec in (("Vector", VECTOR), ("Location", LOCATION), ("Rotation", ROTATION),
                                 ("Scale", SCALE)):
            grid.links.new(grid.vector(spec), by_id(node.inputs, identifier))
        node.vector_type = vector_type
        return node.outputs[0]
    args = ", ".join(glsl_vec3(s) for s in (VECTOR, LOCATION, ROTATION, SCALE))
    glsl = f"vec3 r; node_mapping({MAPPING_CODES[vector_type]}, {args}, r); return vec4(r, 1.0);"
    return Case(f"Mapping {vector_type}", build, glsl)


def _rotate_case(rotation_type: str, invert: bool) -> Case:
    def build(grid):
        node = grid.nodes.new("ShaderNodeVectorRotate")
        for identifier, spec in (("Vector", VECTOR), ("Center", CENTER), ("Axis", AXIS),
                                 ("Rotation", ROTATION)):
            grid.links.new(grid.vector(spec), by_id(node.inputs, identifier))
        grid.links.new(grid.scalar(ANGLE), by_id(node.inputs, "Angle"))
        node.rotation_type = rotation_type
        node.invert = invert
        return node.outputs[0]
    glsl = f"""vec3 r; node_vector_rotate({VECTOR_ROTATE_CODES[rotation_type]}, {str(invert).lower()},
        {glsl_vec3(VECTOR)}, {glsl_vec3(CENTER)}, {glsl_vec3(AXIS)}, {glsl_affine(ANGLE)},
        {glsl_vec3(ROTATION)}, r); return vec4(r, 1.0);"""
    return Case(f"Vector Rotate {rotation_type} invert={invert}", build, glsl)


def test_every_mapping_type_matches_cycles(addon, ctx, tmp_path):
    check_cases(ctx, tmp_path, [_mapping_case(t) for t in MAPPING_CODES], ["include/nodes/mapping.glsl"])


def test_every_vector_rotation_matches_cycles_inverted_and_not(addon, ctx, tmp_path):
    cases = [_rotate_case(t, i) for t in VECTOR_ROTATE_CODES for i in (False, True)]
    check_cases(ctx, tmp_path, cases, ["include/nodes/mapping.glsl"])
