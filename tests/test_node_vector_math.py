# SPDX-License-Identifier: GPL-3.0-or-later
"""Vector Math node (gpu_shaders/include/nodes/vector_math.glsl) against Cycles: every
operation, on vectors whose components cross zero (zero divisors, zero-length normals and
projection axes on some pixels) and, for REFRACT, both sides of total internal reflection."""
from __future__ import annotations

from node_grid import Case, by_id, check_cases, glsl_affine, glsl_vec3

VECTOR_MATH_CODES = {
    "ADD": 0, "SUBTRACT": 1, "MULTIPLY": 2, "DIVIDE": 3, "MULTIPLY_ADD": 4, "CROSS_PRODUCT": 5,
    "PROJECT": 6, "REFLECT": 7, "REFRACT": 8, "FACEFORWARD": 9, "DOT_PRODUCT": 10,
    "DISTANCE": 11, "LENGTH": 12, "SCALE": 13, "NORMALIZE": 14, "ABSOLUTE": 15, "POWER": 16,
    "SIGN": 17, "MINIMUM": 18, "MAXIMUM": 19, "FLOOR": 20, "CEIL": 21, "FRACTION": 22,
    "MODULO": 23, "WRAP": 24, "SNAP": 25, "SINE": 26, "COSINE": 27, "TANGENT": 28,
}
VALUE_OPERATIONS = {"DOT_PRODUCT", "DISTANCE", "LENGTH"}

A = ((0.25, 0.0, -4.0), (0.0, 0.25, -4.0), (0.125, -0.125, 0.5))
B = ((0.0, 0.25, -4.0), (0.125, 0.0, -2.0), (0.0625, 0.0625, -2.0))   # (0,0,0) at u=16, v=16
C = ((0.0, 0.0625, -1.0), (0.0625, 0.0, -1.0), (0.0, 0.0, 0.5))
SCALE = (0.03125, 0.03125, 0.25)     # 0.25 .. 2.19: refraction into and out of denser media
INPUTS = {
    "REFRACT": (((0.0, 0.0, 0.0), (0.03125, 0.0, -0.5), (0.0, 0.0, -1.0)), (((0.0, 0.0, 0.3), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))), C),
    "POWER": (((0.25, 0.0, -3.875), (0.0, 0.125, 0.0625), (0.125, 0.0, -1.9375)), ((0.0, 0.25, -3.0), (0.0625, 0.0, -1.0), (0.0, 0.125, -2.0)), C),
    "WRAP": (A, ((0.0, 0.125, -2.5), (0.0, 0.0, 1.0), (0.0625, 0.0, 0.0)), ((0.0, 0.0, -1.0), (0.0, 0.0, -1.0), (0.0, 0.0625, -1.0))),
}


def _case(operation: str) -> Case:
    a, b, c = INPUTS.get(operation, (A, B, C))
    output = "Value" if operation in VALUE_OPERATIONS else "Vector"

    def build(grid):
        node = grid.nodes.new("ShaderNodeVectorMath")
        grid.links.new(grid.vector(a), by_id(node.inputs, "Vector"))
        grid.links.new(grid.vector(b), by_id(node.inputs, "Vector_001"))
        grid.links.new(grid.vector(c), by_id(node.inputs, "Vector_002"))
        grid.links.new(grid.scalar(SCALE), by_id(node.inputs, "Scale"))
        node.operation = operation  # after linking: hidden sockets cannot be looked up
        return by_id(node.outputs, output)

    shown = "vec3(value)" if output == "Value" else "vector"
    glsl = f"""vec3 vector; float value;
        node_vector_math({VECTOR_MATH_CODES[operation]}, {glsl_vec3(a)}, {glsl_vec3(b)},
                         {glsl_vec3(c)}, {glsl_affine(SCALE)}, vector, value);
        return vec4({shown}, 1.0);"""
    return Case(operation, build, glsl)


def test_every_vector_math_operation_matches_cycles(addon, ctx, tmp_path):
    cases = [_case(operation) for operation in VECTOR_MATH_CODES]
    check_cases(ctx, tmp_path, cases, ["include/nodes/vector_math.glsl"])
