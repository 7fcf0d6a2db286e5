# SPDX-License-Identifier: GPL-3.0-or-later
"""Math node (gpu_shaders/include/nodes/math.glsl) against Cycles: every operation, with and
without use_clamp, over inputs that cross zero, leave every operation's domain (negative roots
and logarithms, zero divisors, |x| > 1 for arcsine) and hit its discontinuities."""
from __future__ import annotations

from node_grid import Case, check_cases, glsl_affine

MATH_CODES = {
    "ADD": 0, "SUBTRACT": 1, "MULTIPLY": 2, "DIVIDE": 3, "MULTIPLY_ADD": 4, "POWER": 5,
    "LOGARITHM": 6, "SQRT": 7, "INVERSE_SQRT": 8, "ABSOLUTE": 9, "EXPONENT": 10,
    "MINIMUM": 11, "MAXIMUM": 12, "LESS_THAN": 13, "GREATER_THAN": 14, "SIGN": 15,
    "COMPARE": 16, "SMOOTH_MIN": 17, "SMOOTH_MAX": 18, "ROUND": 19, "FLOOR": 20, "CEIL": 21,
    "TRUNC": 22, "FRACT": 23, "MODULO": 24, "FLOORED_MODULO": 25, "WRAP": 26, "SNAP": 27,
    "PINGPONG": 28, "SINE": 29, "COSINE": 30, "TANGENT": 31, "ARCSINE": 32, "ARCCOSINE": 33,
    "ARCTANGENT": 34, "ARCTAN2": 35, "SINH": 36, "COSH": 37, "TANH": 38, "RADIANS": 39,
    "DEGREES": 40,
}

# Inputs (su, sv, o) -> u * su + v * sv + o over u, v in 0..31: a runs along x, b along y.
A = (0.25, 0.0, -4.0)      # -4 .. 3.75, through 0
B = (0.0, 0.25, -4.0)
C = (0.0625, 0.0625, -1.5)  # -1.5 .. 2.375, through 0
INPUTS = {
    "POWER": ((0.25, 0.0, -3.875), (0.0, 0.25, -3.0), C),   # integer exponents every 4th row
    "ARCSINE": ((0.078125, 0.0, -1.25), B, C),
    "ARCCOSINE": ((0.078125, 0.0, -1.25), B, C),
    "COMPARE": (A, B, (0.0, 0.03125, -0.25)),                # epsilon below, at and above steps
    "WRAP": (A, (0.0, 0.125, -2.5), (0.0, 0.0, -1.0)),        # range 0 on one row
}


def _math_case(operation: str) -> Case:
    a, b, c = INPUTS.get(operation, (A, B, C))

    def build(grid):
        outputs = []
        for use_clamp in (False, True):
            node = grid.nodes.new("ShaderNodeMath")
            node.operation = operation
            node.use_clamp = use_clamp
            for k, spec in enumerate((a, b, c)):
                grid.links.new(grid.scalar(spec), node.inputs[k])
            outputs.append(node.outputs[0])
        combine = grid.nodes.new("ShaderNodeCombineXYZ")
        grid.links.new(outputs[0], combine.inputs[0])
        grid.links.new(outputs[1], combine.inputs[1])
        grid.links.new(grid.scalar(a), combine.inputs[2])
        return combine.outputs[0]

    code = MATH_CODES[operation]
    glsl = f"""
        float a = {glsl_affine(a)}, b = {glsl_affine(b)}, c = {glsl_affine(c)};
        float plain, clamped;
        node_math({code}, a, b, c, false, plain);
        node_math({code}, a, b, c, true, clamped);
        return vec4(plain, clamped, a, 1.0);"""
    return Case(operation, build, glsl)


def test_every_math_operation_matches_cycles_with_and_without_clamp(addon, ctx, tmp_path):
    cases = [_math_case(operation) for operation in MATH_CODES]
    check_cases(ctx, tmp_path, cases, ["include/nodes/math.glsl"])
